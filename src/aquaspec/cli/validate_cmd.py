"""``aquaspec validate``: the error study against Mitsuba 3."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from aquaspec.cli.common import (add_spread_scattering_option, check_camspec, finite_float,
                                parse_depth_albedo)
from aquaspec.colour.sensors import builtin_sensors, get_sensor, load_camspec
from aquaspec.errors import AquaspecError
from aquaspec.io.atomic import check_writable, write_file_atomically
from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG
from aquaspec.light.sun import check_azimuth, check_elevation
from aquaspec.scene.camera import parse_size
from aquaspec.transport.models import ms_model_name


def register(sub):
    p = sub.add_parser(
        "validate", help="compare with a spectral path tracer (Mitsuba 3) over waters x depths x "
                         "cameras",
        description="Render the validation scene (a ColorChecker board 3 m in front of a "
                    "horizontally looking camera) with Mitsuba 3 and with aquaspec (spectral "
                    "n=8 and 16, RGB n=3, Unreal's single-layer water, the image-formation "
                    "model), for every water, depth and camera, and report RMSE, HSV distance, "
                    "hue, CIEDE2000 and SSIM as CSV, JSON and plots. Needs the 'validation' "
                    "extra (pip install 'aquaspec[validation]'). Reference renders are cached.")
    p.add_argument("--waters", default="I,IA,IB,II,3C", metavar="T,...",
                   help="Jerlov water types or CSV files to study (default I,IA,IB,II,3C)")
    p.add_argument("--source", default="solonenko2015", metavar="NAME",
                   help="published data set for Jerlov types (default solonenko2015; see "
                        "aquaspec list waters)")
    p.add_argument("--depths", default="3,5,9", metavar="M,...",
                   help="camera depths below the surface, metres (default 3,5,9)")
    p.add_argument("--camspec", metavar="PATH",
                   help="camspec_database.txt (Jiang et al. 2013; not shipped): every camera "
                        "in it (default: the built-in sensors)")
    p.add_argument("--sensors", metavar="NAME,...",
                   help="only these sensors (built-in, or cameras of --camspec)")
    p.add_argument("--size", default="96x72", metavar="WxH",
                   help="image size of each render, reference and aquaspec (default 96x72)")
    p.add_argument("--spp", type=int, default=512, metavar="N",
                   help="reference samples per pixel (default 512)")
    p.add_argument("--kd-spp", type=int, default=50000, metavar="N",
                   help="samples per irradiance meter of the reference's Kd (default 50000)")
    p.add_argument("--phase", default="isotropic", choices=("isotropic", "hg", "ff", "petzold"),
                   help="phase function of the path-traced water, also given to aquaspec's "
                        "light-field model: isotropic, Henyey-Greenstein (--g), Fournier-Forand "
                        "(--backscatter) or Petzold's average particle phase function (alone, "
                        "not mixed with pure water); ff and petzold are tabulated in cos(theta) "
                        "(Mitsuba's tabphase), the same table on both sides")
    p.add_argument("--g", type=finite_float, default=None,
                   help="Henyey-Greenstein g for --phase hg (default 0.92)")
    p.add_argument("--backscatter", type=finite_float, default=None, metavar="B",
                   help="backscatter fraction of Fournier-Forand for --phase ff (default 0.0183, "
                        "Petzold's average particle phase function)")
    p.add_argument("--ms-models", default="seeds,lightfield", metavar="M,...",
                   help="aquaspec multiple-scattering models to compare (default "
                        "seeds,lightfield)")
    p.add_argument("--forward-cone", type=finite_float, default=None, metavar="DEG",
                   help="light-field model: scattering within DEG of forward stays in the beam "
                        "towards targets (default 15, or 40 with --cone-spread; 0 = off)")
    p.add_argument("--cone-spread", action=argparse.BooleanOptionalAction, default=None,
                   help="light-field model: the forward cone's light comes from where the cone "
                        "points in the image (a convolution), not from the pixel's own surface "
                        "(default: on when the models include lightfield)")
    add_spread_scattering_option(p)
    p.add_argument("--ambient-shadow", action="store_true",
                   help="light-field model: subtract the scene's first-order shadow in the "
                        "water's light field (aquaspec.transport.lightfield.shadow; goes with --spread-scattering "
                        "multiple; NumPy, seconds per scene)")
    p.add_argument("--seabed-below", metavar="M[,ALBEDO]",
                   help="a flat grey Lambertian seabed M metres below the camera (albedo "
                        "default 0.2) in the reference and in the light field; the light "
                        "field also runs without it (lightfield-deep-n*)")
    p.add_argument("--scene", default="board", metavar="NAME,...",
                   help="validation scenes (default board): board (the thesis's board in open "
                        "water), open (the board 0.25 m above a grey seabed, 0.8 m below the "
                        "camera), ledge (open under a dark slab 0.3 m above the board), wall "
                        "(open before a dark wall 0.4 m behind the board), box (open beside a "
                        "1 m grey box on the seabed); the occluded scenes are level views "
                        "with their own seabed and add the regions seabed, shaded_seabed and "
                        "occluder")
    p.add_argument("--occlusion", action="store_true",
                   help="light-field model: shade with the scene's occlusion of the ambient "
                        "light field (aquaspec.scene.occlusion, issue 36)")
    p.add_argument("--view", default="level", choices=("level", "down"),
                   help="the board facing the camera, which looks level (default, the "
                        "thesis's scene), or lying flat with the camera looking down at it "
                        "at 45 degrees")
    p.add_argument("--light", default="overcast", choices=("overcast", "sun-sky"),
                   help="surface light of both sides: overcast (default; a uniform sky, the "
                        "thesis's setting) or sun-sky (SPECTRL2 sun and sky; the reference "
                        "gets the refracted sun as a directional emitter and the rest as a "
                        "uniform sky)")
    p.add_argument("--sun-elevation", type=finite_float, default=None, metavar="DEG",
                   help="for --light sun-sky: the sun's elevation above the horizon, 1-90 "
                        "(default 60)")
    p.add_argument("--sun-azimuth", type=finite_float, default=None, metavar="DEG",
                   help="for --light sun-sky: the sun's compass angle from -z (the camera's "
                        f"view) towards +x (default {DEFAULT_SUN_AZIMUTH_DEG:g}: behind the "
                        "camera's right shoulder)")
    p.add_argument("--gpu-timing", action="store_true",
                   help="also time aquaspec's GPU renderer per scene (n = largest band count) "
                        "for the speed-up over the reference at equal pixel count")
    p.add_argument("--tyler", action="store_true",
                   help="only compare the light-field model's deep radiance distribution with "
                        "Tyler's measurement (1958, Lake Pend Oreille, from jerlov) for several "
                        "phase functions; needs no path tracer; writes tyler.json and tyler.png")
    p.add_argument("--fluctuations", action="store_true",
                   help="only compare the flicker of the downwelling irradiance under waves "
                        "(its coefficient of variation against depth at 443, 532 and 670 nm, "
                        "from the renderer's caustic maps and light field) with Darecki et "
                        "al.'s measurement (2011, from jerlov); needs no path tracer; writes "
                        "fluctuations.json, fluctuations.md and fluctuations.png")
    p.add_argument("--surface", action="store_true",
                   help="only compare the flat sea surface (Mitsuba's dielectric, overcast sky) "
                        "with the path tracer: Snell's window from below (IB, 5 m, looking up) "
                        "and the sea from 5 m above over --waters, deep and over grey seabeds "
                        "at 3 and 10 m, and the same in the sun at 30 and 60 degrees against a "
                        "slab Monte Carlo (Mitsuba cannot bring a directional sun through its "
                        "dielectric); with --phase isotropic or petzold, --spp, --sensors "
                        "(default nikon-5100-npl); writes surface.json and surface.md")
    p.add_argument("--cache", metavar="DIR", help="reference cache (default: reference/ in $AQUASPEC_CACHE, or "
                   "~/.cache/aquaspec/reference)")
    p.add_argument("--no-cache", action="store_true",
                   help="render every reference again, neither reading nor writing the cache")
    p.add_argument("-o", "--out", default="validation", metavar="DIR",
                   help="output directory (default ./validation)")
    p.set_defaults(func=run, command="validate")


def run(args):
    # deferred: the study loads wgpu and every GPU pass; `aquaspec --help` need not
    from aquaspec.validation.reference import FF_DEFAULT_BACKSCATTER, check_phase, require_mitsuba
    # deferred: as above
    from aquaspec.validation.report import (format_attenuation, format_converged,
                                            format_scenes, format_summary, format_timing,
                                            write_results)
    # deferred: as above
    from aquaspec.validation.study import (REGIONS, DEFAULT_SUN_ELEVATION_DEG, default_cache_dir,
                                           run_study)
    # deferred: as above
    from aquaspec.validation.scenes import SCENES
    if args.g is not None and args.phase != "hg":
        raise AquaspecError(f"--g is the Henyey-Greenstein parameter: it needs --phase hg, "
                            f"not --phase {args.phase}")
    if args.backscatter is not None and args.phase != "ff":
        raise AquaspecError(f"--backscatter is the Fournier-Forand parameter: it needs --phase ff, "
                            f"not --phase {args.phase}")
    g = (0.92 if args.g is None else args.g) if args.phase == "hg" else 0.0
    backscatter = FF_DEFAULT_BACKSCATTER if args.backscatter is None else args.backscatter
    check_phase(args.phase, g, backscatter)        # bad g or B: before anything is rendered
    for opt, val in (("--sun-elevation", args.sun_elevation), ("--sun-azimuth", args.sun_azimuth)):
        if val is not None and args.light != "sun-sky":
            raise AquaspecError(f"{opt} places the sun: it needs --light sun-sky, not "
                                f"--light {args.light}")
    sun_elevation = check_elevation(DEFAULT_SUN_ELEVATION_DEG if args.sun_elevation is None
                                    else args.sun_elevation)
    sun_azimuth = check_azimuth(DEFAULT_SUN_AZIMUTH_DEG if args.sun_azimuth is None
                                else args.sun_azimuth)
    scene_names = _scene_names(args.scene, SCENES)
    if args.seabed_below is not None and scene_names != ("board",):
        raise AquaspecError(f"--seabed-below with --scene {args.scene}; accepted: --scene "
                            "board only (the other scenes have their own seabed)")
    if args.view != "level" and scene_names != ("board",):
        raise AquaspecError(f"--view {args.view} with --scene {args.scene}; accepted: "
                            "--scene board only (the other scenes are level views)")
    if sum((args.tyler, args.fluctuations, args.surface)) > 1:
        raise AquaspecError("--tyler, --fluctuations and --surface are separate checks; "
                            "accepted: one")
    out_dir = _output_dir(args.out, "tyler.json" if args.tyler else
                          "fluctuations.json" if args.fluctuations else
                          "surface.json" if args.surface else "validation.json")
    if args.surface:
        return _run_surface(args, out_dir)
    if args.tyler:
        return _run_tyler(out_dir)
    if args.fluctuations:
        return _run_fluctuations(out_dir)
    require_mitsuba()
    try:
        depths = tuple(float(x) for x in args.depths.split(","))
    except ValueError:
        raise AquaspecError(f"--depths {args.depths!r} must be comma-separated metres") from None
    if not all(0 <= d < float("inf") for d in depths):
        raise AquaspecError(f"--depths {args.depths!r}: depths must be finite and >= 0")
    waters = tuple(w.strip() for w in args.waters.split(",") if w.strip())
    ms_models = tuple(m.strip() for m in args.ms_models.split(",") if m.strip())
    for m in ms_models:
        ms_model_name(m)
    if args.camspec:
        sensors = load_camspec(check_camspec(args.camspec))
    else:
        sensors = builtin_sensors()
    if args.sensors:
        sensors = {name: get_sensor(name, args.camspec) for name in args.sensors.split(",")}
    size = parse_size(args.size)
    cache = None if args.no_cache else (args.cache or default_cache_dir())
    res = run_study(waters=waters, depths=depths, sensors=sensors, source=args.source, size=size,
                    spp=args.spp, kd_spp=args.kd_spp, phase=args.phase,
                    g=g, backscatter=backscatter, ms_models=ms_models,
                    forward_cone_deg=args.forward_cone, cone_spread=args.cone_spread,
                    spread_scattering=args.spread_scattering,
                    ambient_shadow=args.ambient_shadow,
                    **_seabed_below(args.seabed_below), view=args.view,
                    light=args.light, sun_elevation_deg=sun_elevation,
                    sun_azimuth_deg=sun_azimuth,
                    gpu_timing=args.gpu_timing, scene_names=scene_names,
                    occlusion=args.occlusion, cache_dir=cache,
                    progress=lambda m: print(m, file=sys.stderr, flush=True))
    for region in REGIONS:
        print(format_summary(res["rows"], region=region))
        print()
    print(format_converged(res["rows"], res["scenes"]))
    print()
    n_max = max(res["params"]["band_counts"])
    shown = [f"{m}-n{n_max}" for m in ms_models] + [f"lightfield-deep-n{n_max}"]
    print(format_scenes(res["rows"], res["scenes"],
                        [m for m in shown if any(r["method"] == m for r in res["rows"])]))
    print()
    print(format_attenuation(res["waters"]))
    print()
    print(format_timing(res["scenes"]))
    print()
    paths = write_results(res, out_dir)
    print("wrote " + ", ".join(paths.values()))
    return 0


def _output_dir(path, probe_name):
    """Create the output directory and check it is writable, before any work."""
    out = Path(path)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise AquaspecError(f"cannot create the output directory {str(out)!r} "
                            f"({exc.strerror or exc}); give another -o") from None
    check_writable(out / probe_name)
    return out


def _run_tyler(out):
    # deferred: aquaspec.validation loads wgpu and every GPU pass; `aquaspec --help` need not
    from aquaspec.validation.tyler import format_tyler, plot_tyler, tyler_check
    res = tyler_check()
    print(format_tyler(res))
    doc = json.dumps(res, indent=1)
    js = write_file_atomically(out / "tyler.json", lambda t: Path(t).write_text(doc))
    png = plot_tyler(res, out / "tyler.png")
    print(f"wrote {js}, {png}")
    return 0


def _run_fluctuations(out):
    # deferred: aquaspec.validation loads wgpu and every GPU pass; `aquaspec --help` need not
    from aquaspec.validation.fluctuations import (fluctuation_check, format_fluctuations,
                                                  plot_fluctuations)
    res = fluctuation_check(progress=lambda m: print(m, file=sys.stderr, flush=True))
    table = format_fluctuations(res)
    print(table)
    doc = json.dumps(res, indent=1)
    js = write_file_atomically(out / "fluctuations.json", lambda t: Path(t).write_text(doc))
    md = write_file_atomically(out / "fluctuations.md", lambda t: Path(t).write_text(table + "\n"))
    png = plot_fluctuations(res, out / "fluctuations.png")
    print(f"wrote {js}, {md}, {png}")
    return 0


def _run_surface(args, out):
    # deferred: aquaspec.validation loads wgpu and every GPU pass; `aquaspec --help` need not
    from aquaspec.validation.surface_study import format_surface_study, run_surface_study
    # deferred: as above
    from aquaspec.validation.reference import require_mitsuba
    if args.phase not in ("isotropic", "petzold"):
        raise AquaspecError(f"--surface with --phase {args.phase}; accepted: isotropic, petzold")
    require_mitsuba()
    names = [n.strip() for n in (args.sensors or "nikon-5100-npl").split(",") if n.strip()]
    sensors = [get_sensor(n, args.camspec) for n in names]
    w, h = parse_size(args.size)
    res = run_surface_study(waters=tuple(x.strip() for x in args.waters.split(",") if x.strip()),
                            phase=args.phase, size=min(w, h), spp=args.spp, sensors=sensors,
                            progress=lambda m: print(m, file=sys.stderr, flush=True))
    table = format_surface_study(res)
    print(table)
    doc = json.dumps(res, indent=1)
    js = write_file_atomically(out / "surface.json", lambda t: Path(t).write_text(doc))
    md = write_file_atomically(out / "surface.md", lambda t: Path(t).write_text(table + "\n"))
    print(f"wrote {js}, {md}")
    return 0


def _scene_names(text, accepted) -> tuple:
    """--scene NAME,... -> the scenes' names, each one of ``accepted``, none twice."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    bad = [n for n in names if n not in accepted]
    if bad or not names or len(set(names)) != len(names):
        raise AquaspecError(f"--scene {text!r}; accepted: a comma-separated list of "
                            f"{', '.join(accepted)}, each at most once")
    return names


def _seabed_below(text) -> dict:
    """--seabed-below M[,ALBEDO] -> run_study keywords."""
    if text is None:
        return {}
    below, albedo = parse_depth_albedo(text, "--seabed-below", "M[,ALBEDO] with M > 0 metres "
                                       "and ALBEDO in [0, 1], e.g. 2 or 2,0.3")
    return {"seabed_below_m": below, "seabed_albedo": albedo}
