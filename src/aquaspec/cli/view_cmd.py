"""``aquaspec view``: the live view, in a window or offscreen (scripted, recorded)."""

from __future__ import annotations

import argparse
import sys

from aquaspec.cli.common import (DEFAULT_SUN_ELEVATION_DEG, MAX_OCEAN_DEPTH_M,
                                 add_camspec_option, add_rgbd_options,
                                 add_spread_scattering_option, band_count, check_camspec,
                                 comma_floats, depth_metres, finite_float, parse_depth_albedo,
                                 rgbd_from, sun_from)
from aquaspec.apps.scale import SCALE_LEVELS
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG
from aquaspec.scene.camera import parse_size
from aquaspec.transport.models import DEFAULT_MS_MODEL, MS_MODEL_CHOICES

#: The window's size without --size (and without --rgbd).
DEFAULT_SIZE = "640x360"
#: The live view's sun elevation 0 is its overcast sky.
_OVERCAST_ELEVATION = 0.0


def register(sub):
    p = sub.add_parser("view", help="live view of the built-in scene: fly the camera; "
                                    "or offscreen, scripted and recorded",
                       description="Render the built-in scene (or --mesh, or --rgbd's photograph) "
                                   "continuously into a "
                                   "window (glfw; pip install 'aquaspec[view]') and fly the "
                                   "camera: "
                                   "W/A/S/D/Q/E move, drag the mouse to look, +/- change the "
                                   "speed, R resets, 1-9 and 0 switch the Jerlov water, , and . "
                                   "step the exposure, P saves "
                                   "the frame (PNG, sidecar, linear EXR), H hides "
                                   "the text, Esc quits. The text over the frame (and the title) "
                                   "shows the frame rate, per-pass milliseconds and the camera's "
                                   "pose; the controls panel beside it (--no-panel: none) changes the water, "
                                   "sensor, bands, models, exposure, tone map, sun, waves "
                                   "and render scale live. The other options set the "
                                   "physics the run starts with. "
                                   "--offscreen draws the "
                                   "same frames without a display; --script drives the camera "
                                   "and the water from a JSON flight script; --record writes "
                                   "the frames as PNG with a run.json sidecar.")
    p.add_argument("--water", default="IB", metavar="TYPE|FILE.csv",
                   help="Jerlov water type (I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C) or a CSV "
                        "wavelength_nm,a,b[,Kd] (default IB)")
    p.add_argument("--depth", type=depth_metres, default=5.0, metavar="M",
                   help=f"camera depth below the surface, 0 to {MAX_OCEAN_DEPTH_M:g} metres "
                        "(default 5)")
    p.add_argument("--bands", type=band_count, default=8, metavar="N",
                   help="number of wavelength bands over 400-700 nm (default 8)")
    p.add_argument("--sensor", default="human", metavar="NAME",
                   help="camera response: 'human', a built-in camera or a camera of --camspec "
                        "(default human)")
    add_camspec_option(p)
    p.add_argument("--ms-model", default=DEFAULT_MS_MODEL, choices=list(MS_MODEL_CHOICES),
                   help=f"multiple-scattering model to start with (default {DEFAULT_MS_MODEL})")
    p.add_argument("--cone-spread", action=argparse.BooleanOptionalAction, default=None,
                   help="start with the light field's forward cone spread over the image "
                        "(default: on)")
    add_spread_scattering_option(p)
    p.add_argument("--light", default="overcast", choices=("overcast", "sun-sky"),
                   help="light at the surface, as for render (default overcast)")
    p.add_argument("--sun-elevation", type=finite_float, default=None, metavar="DEG",
                   help=f"--light sun-sky: the sun's elevation, 1-90 (default "
                        f"{DEFAULT_SUN_ELEVATION_DEG:g})")
    p.add_argument("--sun-azimuth", type=finite_float, default=None, metavar="DEG",
                   help="--light sun-sky: the sun's compass angle, as for render (default "
                        f"{DEFAULT_SUN_AZIMUTH_DEG:g})")
    p.add_argument("--wind", type=finite_float, default=0.0, metavar="M_S",
                   help="a wind sea's caustics under the sun, moving with the frames "
                        "(0 = a flat surface; default 0)")
    p.add_argument("--mesh", metavar="FILE",
                   help="show this OBJ/PLY/glTF/GLB/STL/OFF instead of the built-in scene, "
                        "placed 3 m in front of the camera at --depth, in open water")
    p.add_argument("--surface", default="flat", choices=("index-matched", "flat"),
                   help="the water surface seen from below, as for render (default flat; "
                        "the seeds' model always sees the index-matched one)")
    p.add_argument("--albedo", metavar="R,G,B",
                   help="linear RGB albedo for --mesh, e.g. 0.5,0.4,0.3 (as for render)")
    p.add_argument("--seabed", default=None, metavar="DEPTH[,ALBEDO]",
                   help="with --mesh or --rgbd: a flat seabed DEPTH m below the surface with a "
                        "grey ALBEDO (default 0.2), the light field's lower boundary; a mesh "
                        "stands on it (a plane out to where the water hides it), as for render "
                        "(default: none, deep water; the built-in scene has its sand)")
    add_rgbd_options(p, "show this photograph through the water instead of a scene, from its "
                        "own camera (Q/E move it up and down; the rest of the flight is off)")
    p.add_argument("--size", default=None, metavar="WxH",
                   help="size of the rendered image and of the window (default 640x360; "
                        "with --rgbd the photograph's size)")
    p.add_argument("--scale", type=finite_float, default=1.0, metavar="S",
                   help="render S times the window's width and height and stretch the image "
                        f"to it: one of {', '.join(f'{s:g}' for s in SCALE_LEVELS)} (default 1; "
                        "[ and ] step it in the window)")
    p.add_argument("--target-fps", type=finite_float, default=None, metavar="FPS",
                   help="in a window: choose the render scale automatically to keep this frame "
                        "rate (e.g. 12 on a CPU); not with --offscreen or --record")
    p.add_argument("--camera-model", metavar="PRESET[:SETTINGS]",
                   help="the frames through a real underwater camera's port, vignetting and "
                        "noisy sensor, as for render (no depth of field live; default: a "
                        "perfect pinhole)")
    p.add_argument("--marine-snow", metavar="DENSITY[,SEED][,KEY=VALUE...]",
                   help="suspended particles drifting with the current (key current=vx:vy:vz "
                        "m/s), as for render (default: none)")
    p.add_argument("--panel", action=argparse.BooleanOptionalAction, default=True,
                   help="in a window: the controls panel (imgui-bundle): water, sensor, bands, "
                        "models, exposure, tone map, sun, waves, render scale (default: on)")
    p.add_argument("--offscreen", action="store_true",
                   help="draw offscreen (no display needed; needs --frames)")
    p.add_argument("--script", default=None, metavar="FLIGHT.json",
                   help="a flight script: camera keyframes (position or depth_m, yaw_deg, "
                        "pitch_deg) and changes (water, auto_exposure) over time; format in "
                        "docs/live-view.md")
    p.add_argument("--frames", type=int, default=None, metavar="N",
                   help="stop after N frames (required with --offscreen)")
    p.add_argument("--record", default=None, metavar="OUTDIR",
                   help="write every frame as OUTDIR/frame_NNNNN.png and the run's "
                        "parameters, poses and frame rate as OUTDIR/run.json")
    p.add_argument("--save-dir", default=".", metavar="DIR",
                   help="where the P key saves the current frame: PNG, JSON sidecar (as "
                        "render's, camera pose included) and linear EXR (default: the "
                        "current folder)")
    p.add_argument("--mp4", action="store_true",
                   help="with --record: also OUTDIR/flight.mp4 (imageio-ffmpeg)")
    p.set_defaults(func=run, command="view")


def _photo_size(path) -> str:
    """``WxH`` of an image file (its header read)."""
    # deferred: Pillow only when a photograph is shown
    from PIL import Image
    try:
        with Image.open(path) as im:
            return f"{im.width}x{im.height}"
    except Exception as exc:         # Pillow raises many types for unreadable files
        raise AquaspecError(f"could not read image file {str(path)!r} ({exc})") from None


def run(args):
    # deferred: the live view loads wgpu and rendercanvas; `aquaspec --help` need not
    from aquaspec.apps.settings import ViewSettings
    from aquaspec.apps.view import run_view  # deferred: as above
    rgbd = rgbd_from(args)
    if rgbd is not None and args.mesh:
        raise AquaspecError("--rgbd and --mesh: a view shows one of them")
    w, h = parse_size(args.size or (_photo_size(rgbd[0]) if rgbd else DEFAULT_SIZE))
    elevation, azimuth = sun_from(args)
    settings = ViewSettings(
        width=w, height=h, water=args.water, depth_m=args.depth, bands=args.bands,
        sensor=args.sensor, camspec=check_camspec(args.camspec), ms_model=args.ms_model,
        cone_spread=args.cone_spread, spread_scattering=args.spread_scattering,
        sun_elevation_deg=elevation if args.light == "sun-sky" else _OVERCAST_ELEVATION,
        sun_azimuth_deg=azimuth, wind=args.wind, mesh=args.mesh, rgbd=rgbd,
        surface=args.surface,
        albedo=comma_floats(args.albedo, 3, "--albedo") if args.albedo else None,
        seabed=None if args.seabed is None else parse_depth_albedo(
            args.seabed, "--seabed", "DEPTH[,ALBEDO] in metres (> 0) and [0, 1], e.g. 12 or "
            "12,0.3"))
    summary = run_view(settings, offscreen=args.offscreen, script=args.script,
                       frames=args.frames, record=args.record, mp4=args.mp4,
                       save_dir=args.save_dir, scale=args.scale, target_fps=args.target_fps,
                       panel=args.panel, progress=lambda m: print(m, file=sys.stderr),
                       camera_model=args.camera_model, marine_snow=args.marine_snow)
    final = summary["final"]
    fps = "-" if summary["fps"] is None else f"{summary['fps']:.1f}"
    size = "x".join(str(v) for v in summary["render_size"])
    print(f"{summary['frames_drawn']} frames ({summary['mode']}), median {fps} fps, rendering "
          f"{size} at the end (scale {summary['render_scale']:g}); camera at "
          f"depth {final['depth_m']:.2f} m, position "
          f"({', '.join(f'{v:.2f}' for v in final['position_m'])}) m"
          + ("" if args.record is None else f"; recorded in {args.record}"))
    if summary["slowest_second_fps"] is not None:
        print(f"slowest second: {summary['slowest_second_fps']:.0f} frames")
    if summary["pass_ms"]:
        print("last frame timed pass by pass (ms): "
              + ", ".join(f"{k} {v:.1f}" for k, v in summary["pass_ms"].items()))
    return 0
