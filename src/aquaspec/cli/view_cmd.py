"""``aquaspec view``: the interactive window."""

from __future__ import annotations

import argparse

from aquaspec.cli.common import add_spread_scattering_option
from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG
from aquaspec.scene.camera import parse_size
from aquaspec.transport.models import DEFAULT_MS_MODEL, MS_MODEL_CHOICES


def register(sub):
    p = sub.add_parser("view", help="interactive window with live controls",
                       description="Open a window showing the built-in scene, with sliders for "
                                   "depth, bands, exposure, the sun and the wind (caustics) and "
                                   "choices of water, sensor and multiple-scattering model. "
                                   "Needs a display and a matplotlib GUI backend.")
    p.add_argument("--water", default="IB")
    p.add_argument("--depth", type=float, default=5.0)
    p.add_argument("--bands", type=int, default=8)
    p.add_argument("--sensor", default="human")
    p.add_argument("--ms-model", default=DEFAULT_MS_MODEL, choices=list(MS_MODEL_CHOICES),
                   help=f"multiple-scattering model to start with (default {DEFAULT_MS_MODEL})")
    p.add_argument("--cone-spread", action=argparse.BooleanOptionalAction, default=None,
                   help="start with the light field's forward cone spread over the image "
                        "(default: on)")
    add_spread_scattering_option(p)
    p.add_argument("--sun-elevation", type=float, default=0.0, metavar="DEG",
                   help="start with the sun at DEG (0 = an overcast sky; default 0)")
    p.add_argument("--sun-azimuth", type=float, default=DEFAULT_SUN_AZIMUTH_DEG, metavar="DEG",
                   help="the sun's compass angle, as for render (default "
                        f"{DEFAULT_SUN_AZIMUTH_DEG:g})")
    p.add_argument("--wind", type=float, default=0.0, metavar="M_S",
                   help="start with a wind sea's caustics (0 = a flat surface; default 0)")
    p.add_argument("--camspec", metavar="PATH")
    p.add_argument("--size", default="640x360", metavar="WxH")
    p.set_defaults(func=run, command="view")


def run(args):
    # deferred: the viewer loads wgpu, rendercanvas and matplotlib; `aquaspec --help` need not
    from aquaspec.apps.viewer import run_viewer
    w, h = parse_size(args.size)
    run_viewer(width=w, height=h, water=args.water, depth_m=args.depth, bands=args.bands,
               sensor=args.sensor, ms_model=args.ms_model, cone_spread=args.cone_spread,
               camspec=args.camspec, spread_scattering=args.spread_scattering,
               sun_elevation_deg=args.sun_elevation, sun_azimuth_deg=args.sun_azimuth,
               wind=args.wind)
    return 0
