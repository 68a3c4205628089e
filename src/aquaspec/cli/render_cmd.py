"""``aquaspec render``: one image of the built-in scene, a mesh, or an RGB-D photo."""

from __future__ import annotations

import argparse
import os
import sys

from aquaspec.cli.common import (MAX_OCEAN_DEPTH_M, add_band_options, add_light_options,
                                add_rgbd_options, add_sensor_options,
                                add_spread_scattering_option, add_sun_rendering_options,
                                add_water_options, check_camspec, comma_floats, depth_metres,
                                exposure_value, finite_float, parse_depth_albedo, parse_range,
                                rgbd_from,
                                shadow_map_from, sun_from, waves_from)
from aquaspec.colour.display import TONEMAPS, WHITE_BALANCE_METHODS
from aquaspec.errors import AquaspecError
from aquaspec.io.atomic import check_writable
from aquaspec.io.layers_file import check_layers_path
from aquaspec.io.linear import LINEAR_SUFFIXES
from aquaspec.io.png import PNG_SUFFIXES
from aquaspec.io.save import save_image
from aquaspec.io.sidecar import sidecar_path
from aquaspec.light.lamp import PRESETS, SPEC_KEYS, parse_lamps
from aquaspec.optics.presets import CAMERA_MODELS, get_camera_model
from aquaspec.scene.particles import parse_marine_snow
from aquaspec.scene.camera import DEFAULT_LOOK_DOWN_DEG, camera_above, parse_size
from aquaspec.scene.bathymetry import bathymetry_from_text, bathymetry_scene, check_camera_over
from aquaspec.scene.builtin import BUILTIN_VARIANTS, RENDER_DEFAULT_VARIANT, default_camera
from aquaspec.scene.seabed import Seabed


def register(sub):
    p = sub.add_parser(
        "render", help="render an image (PNG + JSON sidecar, optional linear EXR/NPY)",
        description="Render the built-in seabed scene (or your mesh, or an RGB-D photograph) "
                    "seen through a water type at a depth by a camera, spectrally.",
        epilog="example: aquaspec render --water IB --depth 5 --size 320x180 --bands 8 -o x.png")
    add_water_options(p, required=False)
    p.set_defaults(water="IB")
    p.add_argument("--depth", type=depth_metres, default=5.0, metavar="M",
                   help=f"camera depth below the surface, 0 to {MAX_OCEAN_DEPTH_M:g} metres "
                        "(default 5); deep down, where auto exposure has to brighten the "
                        "image by more than 20 EV, or the image is black, a warning says so")
    add_sensor_options(p)
    add_band_options(p)
    add_light_options(p)
    p.add_argument("--size", default="1280x720", metavar="WxH", help="image size (default 1280x720)")
    p.add_argument("--exposure", type=exposure_value, default="auto", metavar="auto|EV",
                   help="exposure: 'auto' or a value in stops, -64 to 64 (default auto)")
    p.add_argument("--tonemap", default="filmic", choices=list(TONEMAPS),
                   help="tone curve (default filmic)")
    p.add_argument("--white-balance", default="none", choices=list(WHITE_BALANCE_METHODS),
                   help="white balance (default none)")
    p.add_argument("--colour-matrix", default="auto", choices=("auto", "none"),
                   help="display: 'auto' maps camera RGB to sRGB with a matrix fitted on the "
                        "ColorChecker (identity for 'human'); 'none' shows raw camera RGB")
    p.add_argument("--scene", choices=BUILTIN_VARIANTS, default=None,
                   help=f"which built-in scene (default {RENDER_DEFAULT_VARIANT}): classic "
                        "(smooth shapes, one material each) or detailed (rippled sand, rocks "
                        "with crevices, seagrass, a fouled pipe, a wreck plate)")
    p.add_argument("--mesh", metavar="FILE", help="render this OBJ/PLY/glTF/GLB instead of the "
                                                   "built-in scene (placed 3 m in front)")
    p.add_argument("--albedo", metavar="R,G,B", help="linear RGB albedo for --mesh, e.g. 0.5,0.4,0.3")
    add_rgbd_options(p)
    p.add_argument("--cone-spread", action=argparse.BooleanOptionalAction, default=None,
                   help="--ms-model lightfield: the forward cone's light comes from where the "
                        "cone points in the image (an image pyramid; default: on for the "
                        "light field)")
    add_spread_scattering_option(p)
    p.add_argument("--ambient-shadow", action="store_true",
                   help="subtract the scene's first-order shadow in the water's light field "
                        "(goes with --spread-scattering multiple; planned in NumPy from the "
                        "G-buffer, its rays integrated on the GPU with --backend gpu: seconds "
                        "per image)")
    p.add_argument("--occlusion", action="store_true",
                   help="the scene's occlusion of the water's ambient light: surfaces under "
                        "a ledge or before a wall get only the light of the directions they "
                        "see (GPU and NumPy); with --backend numpy the water in the "
                        "occluders' shadow scatters less too (light-field model; an RGB-D "
                        "image's occluder is its visible surface)")
    p.add_argument("--surface", default=None, choices=("index-matched", "flat"),
                   help="the water surface seen from below: flat, the real interface (the "
                        "sky in Snell's window, the water mirrored outside it; the default "
                        "with the light-field model); index-matched, no interface (the "
                        "validation's setting; the default with --ms-model monzon2022)")
    p.add_argument("--seabed", default="scene", metavar="scene|none|DEPTH[,ALBEDO]",
                   help="the light field's lower boundary: the scene's (default; the "
                        "built-in scene's sand), none (deep water), or a flat Lambertian "
                        "seabed DEPTH m below the surface with a grey ALBEDO (default 0.2); "
                        "a --mesh also stands on that seabed, a plane the camera sees out to "
                        "where the water hides it (the built-in scene keeps its sand, an "
                        "RGB-D photograph its own surfaces)")
    p.add_argument("--bathymetry", metavar="FILE[,SPACING_M]",
                   help="a seabed from a bathymetry grid instead of the built-in scene: an "
                        "ESRI ASCII grid (.asc, elevations, its cellsize the spacing), or "
                        "depths in metres (.npy, .csv) or millimetres (16-bit .png) with "
                        "SPACING_M; centred below the camera, drawn from below and from "
                        "above (--camera-height); the light field's seabed its mean depth")
    p.add_argument("--lamp", action="append", default=[], metavar="SPEC",
                   help="a lamp (repeatable): a preset ("
                        + "; ".join(f"{k}: {v[0]}" for k, v in PRESETS.items())
                        + ") or key=value pairs separated by ';', e.g. "
                        "'pos=0.25,0,0;dir=0,0,-1;cone=30;power=20;spectrum=led'; keys: "
                        + "; ".join(f"{k}: {v}" for k, v in SPEC_KEYS.items())
                        + ". Its light on surfaces (shadowed) and scattered once in the water; "
                        "with --light none the scene is lit by the lamps alone")
    add_sun_rendering_options(
        p, wind_help="--light sun-sky: a wind sea on the surface (wind speed in m/s at 19.5 m, "
                     "Pierson-Moskowitz spectrum) whose waves focus the sun into caustics on "
                     "surfaces and in the water (default: a flat surface)")
    p.add_argument("--camera-height", type=finite_float, metavar="M",
                   help="put the camera M metres above the sea: the flat surface mirrors the "
                        "sky (Fresnel) and shows the water's colour and the seabed (--seabed; "
                        "the built-in scene's sand by default) through it (light-field model; "
                        "with the sun its glint, with --wind the waves' facets and glitter and "
                        "the caustics on the seabed; the scene's meshes under the water are "
                        "ray cast through the surface in NumPy); 0: the camera "
                        "at the waterline, half in water (the "
                        "half-and-half view: the sky above the line, the built-in scene "
                        "below it)")
    p.add_argument("--look-down", type=finite_float, default=DEFAULT_LOOK_DOWN_DEG,
                   metavar="DEG", help="with --camera-height: the view's angle below the "
                                       f"horizon, 0-90 (default {DEFAULT_LOOK_DOWN_DEG:g})")
    p.add_argument("--camera-model", metavar="PRESET[:SETTINGS]",
                   help="a real underwater camera: port, lens and noisy sensor (EMVA 1288), "
                        f"one of {', '.join(CAMERA_MODELS)}, optionally with settings, e.g. "
                        "dslr-flat-port:iso=3200,exposure=0.01,seed=1,dof=off (default: a "
                        "perfect pinhole; docs/camera-model.md); --linear then writes the "
                        "noisy raw frame")
    p.add_argument("--marine-snow", metavar="DENSITY[,SEED][,KEY=VALUE...]",
                   help="suspended particles drawn over the image: DENSITY per m^3 (e.g. 300), "
                        "seeded; keys albedo, range (m), slope, dmin, dmax (mm), blur (px), "
                        "current (vx:vy:vz m/s) (default: none; docs/marine-snow.md)")
    p.add_argument("--backend", default="gpu", choices=("gpu", "numpy"),
                   help="gpu (WGSL through wgpu) or numpy (the slow reference)")
    p.add_argument("-o", "--output", required=True, metavar="OUT.png", help="output PNG")
    p.add_argument("--linear", metavar="OUT.exr|OUT.npy",
                   help="also write linear camera RGB (float32 EXR, or NPY)")
    p.add_argument("--layers", metavar="OUT.exr|OUT.npz",
                   help="also write the image-formation layers (float32): backscatter, "
                        "direct signal, the surfaces' own light and albedo, transmission, "
                        "range (aquaspec.rendering.layers; ground truth for restoration research)")
    p.set_defaults(func=run, command="render")


def run(args):
    # deferred: the renderer loads wgpu and every GPU pass; `aquaspec --help` need not
    from aquaspec.rendering.api import render
    check_writable(args.output, suffixes=PNG_SUFFIXES)
    if args.linear:
        check_writable(args.linear, suffixes=LINEAR_SUFFIXES)
    if args.layers:
        check_layers_path(args.layers)
    _check_distinct_outputs(args)
    size = parse_size(args.size)
    check_camspec(args.camspec)
    sun_elevation, sun_azimuth = sun_from(args)
    shadow_map = shadow_map_from(args, _max_texture(args.backend, args.sun_shadow_map))
    rgbd = rgbd_from(args)
    albedo = comma_floats(args.albedo, 3, "--albedo") if args.albedo else None
    seabed = _seabed(args.seabed)
    if albedo and not args.mesh:
        raise AquaspecError("--albedo is only used with --mesh")
    waves = waves_from(args)
    lamps = parse_lamps(args.lamp)     # bad specs fail before any rendering
    camera_model = get_camera_model(args.camera_model)
    marine_snow = parse_marine_snow(args.marine_snow)
    camera = None
    if args.camera_height is not None:
        if rgbd is not None:
            raise AquaspecError("--camera-height shows the sea from above; --rgbd is an "
                                "under-water photograph")
        camera = camera_above(args.camera_height, args.look_down, width=size[0],
                              height=size[1])
    scene = _bathymetry_scene(args, camera, size)
    if scene is not None:
        camera = scene.camera

    def progress(msg):
        print(f"aquaspec render: {msg}", file=sys.stderr, flush=True)

    res = render(water=args.water, source=args.source, depth_m=args.depth, sensor=args.sensor,
                 camspec=args.camspec, bands=args.bands, wavelength_range=parse_range(args.range),
                 size=size, mesh=args.mesh, albedo=albedo, builtin=args.scene, rgbd=rgbd,
                 scene=scene,
                 light=args.light,
                 irradiance_w_m2=args.irradiance, sun_elevation_deg=sun_elevation,
                 sun_azimuth_deg=sun_azimuth, sun_shadow_map=shadow_map,
                 waves=waves, ambient=args.ambient, outside="zero" if args.outside_zero else "error",
                 ms_model=args.ms_model, phase=args.phase,
                 forward_cone_deg=args.forward_cone, cone_spread=args.cone_spread,
                 spread_scattering=args.spread_scattering, ambient_shadow=args.ambient_shadow,
                 occlusion=args.occlusion, seabed=seabed, lamps=lamps, surface=args.surface,
                 exposure=args.exposure, white_balance=args.white_balance, tonemap=args.tonemap,
                 colour_matrix=None if args.colour_matrix == "none" else "auto",
                 layers=bool(args.layers), backend=args.backend, progress=progress,
                 camera_model=camera_model, camera=camera, marine_snow=marine_snow)
    files = save_image(args.output, res.display, res.linear_rgb if args.linear else None,
                       res.params, linear_path=args.linear, layers=res.layers,
                       layers_path=args.layers)
    for w in [*res.warnings(), *files.get("warnings", [])]:
        progress(f"warning: {w}")
    print(f"wrote {files['png']} and {files['sidecar']}"
          + (f" and {files['linear']}" if files.get("linear") else "")
          + (f" and {files['layers']}" if files.get("layers") else "")
          + f" ({res.params['render_seconds']:.2f} s)")
    return 0


def _check_distinct_outputs(args):
    """Two outputs naming one file (-o's sidecar included) would overwrite
    each other: refused before rendering."""
    named = [("-o", args.output), ("-o's sidecar", sidecar_path(args.output)),
             ("--linear", args.linear), ("--layers", args.layers)]
    seen = {}
    for opt, path in named:
        if path is None:
            continue
        key = os.path.realpath(os.path.expanduser(os.fspath(path)))
        if key in seen:
            raise AquaspecError(f"{seen[key]} and {opt} both name {str(path)!r}; accepted: a "
                                "different file for each output")
        seen[key] = opt


def _max_texture(backend, shadow_map):
    """The GPU's largest texture side when a shadow map size is to be checked
    against it (None for the NumPy backend)."""
    if backend != "gpu" or shadow_map is None:
        return None
    # deferred: loads wgpu; only a GPU render with --sun-shadow-map needs the limit
    from aquaspec.gpu.device import max_texture_size
    return max_texture_size()


def _bathymetry_scene(args, camera, size):
    """--bathymetry: the grid's scene with its camera (``camera``, or the
    built-in scenes' at --depth over the grid's centre), or None."""
    if not args.bathymetry:
        return None
    if args.mesh or args.rgbd or args.scene:
        raise AquaspecError("--bathymetry is the scene; it cannot be combined with --mesh, "
                            "--rgbd or --scene")
    bathy = bathymetry_from_text(args.bathymetry)
    camera = camera or default_camera(args.depth, size[0], size[1], 60.0)
    check_camera_over(bathy, camera)
    return bathymetry_scene(bathy, camera)


def _seabed(text):
    """--seabed: "scene", "none" or DEPTH[,ALBEDO] -> what render() takes."""
    t = str(text).strip().lower()
    if t in ("scene", "none"):
        return "scene" if t == "scene" else None
    return Seabed(*parse_depth_albedo(text, "--seabed", "scene, none, or DEPTH[,ALBEDO] in "
                                      "metres (> 0) and [0, 1], e.g. 12 or 12,0.3"))
