"""``aquaspec bench``: frame times per pass against the number of bands."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from aquaspec.cli.common import (MAX_OCEAN_DEPTH_M, add_spread_scattering_option,
                                add_sun_options, add_sun_rendering_options, depth_metres,
                                shadow_map_from, sun_from, waves_from)
from aquaspec.errors import AquaspecError
from aquaspec.io.atomic import check_writable, write_file_atomically
from aquaspec.scene.camera import parse_size
from aquaspec.scene.particles import parse_marine_snow
from aquaspec.transport.models import DEFAULT_MS_MODEL, MS_MODEL_CHOICES


def register(sub):
    p = sub.add_parser(
        "bench", help="cost study: frame time per pass vs number of bands, and ratios",
        description="Time every GPU pass of the built-in scene for several image sizes and band "
                    "counts, fit t(n) = t0 + n t1, and report ratios measured in the same run "
                    "(NumPy reference / GPU, n=8 / n=3, deferred / memory-floor copy; with "
                    "--light sun-sky the sun's passes and sun / no sun, with --wind "
                    "caustics / flat sun).",
        epilog="example: aquaspec bench --light sun-sky --wind 3 --sizes 1280x720 --bands 8,16 "
               "--no-numpy")
    p.add_argument("--sizes", default=None, metavar="WxH,...",
                   help="image sizes to time (default 1280x720,1920x1080; 1280x720 with "
                        "--motion)")
    p.add_argument("--bands", default=None, metavar="N,...",
                   help="band counts to time, fitted as t(n) = t0 + n t1 (default "
                        "3,8,16,32,64; 8 with --motion)")
    p.add_argument("--frames", type=int, default=None, metavar="N",
                   help="timed frames per point (default 20; 36 of each kind with --motion)")
    p.add_argument("--occlusion", action="store_true",
                   help="also time the light-field frame with the scene's occlusion of the "
                        "ambient light on surfaces (the factors kept for a still camera, and "
                        "computed again as when the camera moves), against the frame without "
                        "it in the same run"),
    p.add_argument("--motion", action="store_true",
                   help="time frames of a moving camera (a scripted path through the built-in "
                        "scene, its depth changing by up to 0.92 m per frame) with the waves "
                        "advancing 1/30 s per frame, against as many still frames interleaved "
                        "in the same run; reports moving / still and each pass"),
    p.add_argument("--warmup", type=int, default=3, metavar="N",
                   help="untimed frames first (default 3)")
    p.add_argument("--water", default="IB", metavar="TYPE|FILE.csv",
                   help="Jerlov water type or a CSV wavelength_nm,a,b[,Kd] (default IB)")
    p.add_argument("--depth", type=depth_metres, default=5.0, metavar="M",
                   help=f"camera depth below the surface, 0 to {MAX_OCEAN_DEPTH_M:g} metres "
                        "(default 5)")
    p.add_argument("--ms-model", default=DEFAULT_MS_MODEL, choices=list(MS_MODEL_CHOICES),
                   help=f"multiple-scattering model to time (default {DEFAULT_MS_MODEL})")
    p.add_argument("--phase", default="petzold", choices=("petzold", "ff", "hg", "isotropic"),
                   help="phase function for --ms-model lightfield (default petzold)")
    p.add_argument("--cone-spread", action=argparse.BooleanOptionalAction, default=None,
                   help="--ms-model lightfield: with the forward cone spread over the image "
                        "(the pyramid passes; forward cone 40 degrees; default: on)")
    add_spread_scattering_option(p)
    p.add_argument("--compare-seeds", action="store_true",
                   help="with --ms-model lightfield: also time the seeds' frame on the same "
                        "G-buffer in the same run and report lightfield / seeds")
    add_sun_options(p, light_help="light at the surface (default overcast). sun-sky adds the "
                                  "sun's passes (shadow map, froxels, per pixel) to the frame, "
                                  "timed each, and reports the frame with the sun / without "
                                  "it, measured in the same run")
    add_sun_rendering_options(
        p, wind_help="--light sun-sky: a wind sea (wind speed in m/s at 19.5 m) focusing the "
                     "sun into caustics; the sun over a flat surface is timed beside it and "
                     "caustics / flat sun reported")
    p.add_argument("--lamps", type=int, default=None, metavar="N",
                   help="time the frame with N shadowed lamps fixed to the camera (2: the "
                        "rov-pair preset) against the frame without them, in the same run, "
                        "and print the ratio (default size 1280x720, 8 bands)")
    p.add_argument("--surface", action="store_true",
                   help="time the frames of the sea surface in one run (default 1280x720, 8 "
                        "bands): the built-in view under the index-matched and the flat "
                        "surface, looking up through the flat one, and the sea seen from 5 m "
                        "above it, each with its ratio to the first")
    p.add_argument("--detail", action="store_true",
                   help="time whole displayed frames of the classic built-in scene, plain "
                        "and with marine snow (--marine-snow, default 200,1) drifting, and of "
                        "the detailed built-in scene (textures, normal maps) without and with "
                        "it, alternated in one run, with their ratios to the plain frame "
                        "(default 1280x720, 8 bands)")
    p.add_argument("--marine-snow", default=None, metavar="DENSITY[,SEED][,KEY=VALUE...]",
                   help="with --detail: the particles timed (as for render)")
    p.add_argument("--no-numpy", action="store_true", help="skip the NumPy reference ratio "
                   "(with a sun the reference shades it too: seconds per size)")
    p.add_argument("--json", metavar="OUT.json", help="write the results as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="plot t(n)")
    p.set_defaults(func=run, command="bench")


def run(args):
    # deferred: the bench loads wgpu and every GPU pass; `aquaspec --help` need not
    from aquaspec.apps.bench import format_table, plot, run_bench
    if args.json:
        check_writable(args.json, suffixes=(".json",))
    if args.plot:
        check_writable(args.plot, suffixes=(".png",))
    if args.motion and (args.plot or args.compare_seeds):
        raise AquaspecError(f"--motion times one kind of frame moving and still; accepted "
                            f"without {'--plot' if args.plot else '--compare-seeds'}")
    sizes_text = args.sizes or ("1280x720" if args.motion else "1280x720,1920x1080")
    bands_text = args.bands or ("8" if args.motion else "3,8,16,32,64")
    sizes = [parse_size(s) for s in sizes_text.split(",") if s]
    try:
        bands = [int(b) for b in bands_text.split(",") if b]
    except ValueError:
        raise AquaspecError(f"--bands {bands_text!r} must be comma-separated integers") from None
    frames = args.frames if args.frames is not None else (36 if args.motion else 20)
    sun_elevation, sun_azimuth = sun_from(args)
    waves = waves_from(args)
    if args.sun_shadow_map is not None:
        # deferred: loads wgpu; only a shadow map size is checked against the device
        from aquaspec.gpu.device import max_texture_size
        shadow_map_from(args, max_texture_size())
    if args.detail:
        return _run_detail(args, sizes_text if args.sizes else "1280x720", args.bands or "8",
                           frames)
    if args.surface:
        return _run_surface(args, sizes_text if args.sizes else "1280x720", args.bands or "8",
                            args.frames if args.frames is not None else 12)
    if args.lamps is not None:
        return _run_lamps(args, sizes_text if args.sizes else "1280x720",
                          args.bands or "8", frames)
    if args.motion:
        return _run_motion(args, sizes, bands, frames, sun_elevation, sun_azimuth, waves)
    result = run_bench(sizes=sizes, bands=bands, frames=frames, warmup=args.warmup,
                       water=args.water, depth_m=args.depth, numpy_reference=not args.no_numpy,
                       ms_model=args.ms_model, phase=args.phase, compare_seeds=args.compare_seeds,
                       cone_spread=args.cone_spread, spread_scattering=args.spread_scattering,
                       light=args.light, sun_elevation_deg=sun_elevation,
                       sun_azimuth_deg=sun_azimuth, sun_shadow_map=args.sun_shadow_map,
                       waves=waves, occlusion=args.occlusion,
                       progress=lambda m: print(m, file=sys.stderr, flush=True))
    print(format_table(result))
    if args.json:
        text = json.dumps(result, indent=2)
        write_file_atomically(args.json, lambda tmp: Path(tmp).write_text(text))
    if args.plot:
        plot(result, args.plot)
    return 0


def _run_lamps(args, sizes_text, bands_text, frames):
    """``bench --lamps N``: each size and band count, with N lamps against without."""
    # deferred: the bench loads wgpu and every GPU pass; `aquaspec --help` need not
    from aquaspec.apps.lamp_bench import bench_lamps, run_lamp_bench
    bench_lamps(args.lamps)                     # a bad N refused before any GPU work
    if args.light == "sun-sky" or args.motion or args.compare_seeds or args.occlusion:
        raise AquaspecError("--lamps times the lamps alone; accepted without --light sun-sky, "
                            "--motion, --compare-seeds and --occlusion")
    results = []
    for size in [parse_size(s) for s in sizes_text.split(",") if s]:
        for n in [int(b) for b in bands_text.split(",") if b]:
            row = run_lamp_bench(width=size[0], height=size[1], n_bands=n, n_lamps=args.lamps,
                                 frames=frames, warmup=args.warmup, water=args.water,
                                 depth_m=args.depth, light=args.light, ms_model=args.ms_model,
                                 phase=args.phase,
                                 progress=lambda m: print(m, file=sys.stderr, flush=True))
            print(f"lamps: {row['lamps']} at {size[0]}x{size[1]}, {n} bands: frame with them / "
                  f"without = {row['ratio']:.2f} ({row['lamp_frame_wall_ms']:.1f} / "
                  f"{row['frame_wall_ms']:.1f} ms)")
            results.append(row)
    _write_results(args.json, results)
    return 0


def _run_surface(args, sizes_text, bands_text, frames):
    """``bench --surface``: each size and band count, the surface's frames."""
    # deferred: the bench loads wgpu and every GPU pass; `aquaspec --help` need not
    from aquaspec.apps.surface_bench import format_surface, run_surface_bench
    if args.light != "overcast" or args.motion or args.compare_seeds or args.lamps:
        raise AquaspecError("--surface times the surface's frames alone; accepted without "
                            "--light sun-sky, --motion, --compare-seeds and --lamps")
    results = []
    for size in [parse_size(s) for s in sizes_text.split(",") if s]:
        for n in [int(b) for b in bands_text.split(",") if b]:
            row = run_surface_bench(width=size[0], height=size[1], n_bands=n, frames=frames,
                                    warmup=args.warmup, water=args.water, depth_m=args.depth,
                                    progress=lambda m: print(m, file=sys.stderr, flush=True))
            print(format_surface(row))
            results.append(row)
    _write_results(args.json, results)
    return 0


def _run_detail(args, sizes_text, bands_text, frames):
    """``bench --detail``: each size and band count, the detailed frames against the plain."""
    # deferred: the bench loads wgpu and every GPU pass; `aquaspec --help` need not
    from aquaspec.apps.detail_bench import (DEFAULT_SNOW, detailed_builtin, format_detail,
                                            run_detail_bench)
    snow = parse_marine_snow(args.marine_snow or DEFAULT_SNOW)    # refused before GPU work
    if args.light == "sun-sky" or args.motion or args.lamps or args.surface:
        raise AquaspecError("--detail times the detail alone; accepted without --light "
                            "sun-sky, --motion, --lamps and --surface")
    results = []
    for size in [parse_size(s) for s in sizes_text.split(",") if s]:
        for n in [int(b) for b in bands_text.split(",") if b]:
            row = run_detail_bench(width=size[0], height=size[1], n_bands=n, frames=frames,
                                   warmup=args.warmup, water=args.water, depth_m=args.depth,
                                   marine_snow=snow, detailed_scene=detailed_builtin,
                                   progress=lambda m: print(m, file=sys.stderr, flush=True))
            print(format_detail(row))
            results.append(row)
    _write_results(args.json, results)
    return 0


def _run_motion(args, sizes, bands, frames, sun_elevation, sun_azimuth, waves):
    """``bench --motion``: each size and band count, moving against still."""
    # deferred: the bench loads wgpu and every GPU pass; `aquaspec --help` need not
    from aquaspec.apps.motion import format_motion, run_motion_bench
    results = []
    for size in sizes:
        for n in bands:
            result = run_motion_bench(
                size=size, bands=n, frames=frames, warmup=args.warmup, water=args.water,
                depth_m=args.depth, ms_model=args.ms_model, phase=args.phase,
                cone_spread=args.cone_spread, spread_scattering=args.spread_scattering,
                light=args.light, sun_elevation_deg=sun_elevation, sun_azimuth_deg=sun_azimuth,
                sun_shadow_map=args.sun_shadow_map, waves=waves,
                progress=lambda m: print(m, file=sys.stderr, flush=True))
            print(format_motion(result))
            results.append(result)
    _write_results(args.json, results)
    return 0


def _write_results(path, results) -> None:
    """``--json``: the one result, or the list of them (nothing without a path)."""
    if path:
        text = json.dumps(results if len(results) > 1 else results[0], indent=2)
        write_file_atomically(path, lambda tmp: Path(tmp).write_text(text))
