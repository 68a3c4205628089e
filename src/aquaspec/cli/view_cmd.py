"""``aquaspec view``: the interactive window."""

from __future__ import annotations

import argparse

from aquaspec.cli.common import (DEFAULT_SUN_ELEVATION_DEG, MAX_OCEAN_DEPTH_M,
                                 add_camspec_option, add_spread_scattering_option,
                                 band_count, check_camspec, depth_metres,
                                 finite_float, sun_from)
from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG
from aquaspec.scene.camera import parse_size
from aquaspec.transport.models import DEFAULT_MS_MODEL, MS_MODEL_CHOICES

#: The viewer's sun slider at 0 is its overcast sky.
_OVERCAST_ELEVATION = 0.0


def register(sub):
    p = sub.add_parser("view", help="interactive window with live controls",
                       description="Open a window showing the built-in scene, with sliders for "
                                   "depth, bands, exposure, the sun and the wind (caustics) and "
                                   "choices of water, sensor and multiple-scattering model. "
                                   "Needs a display and a matplotlib GUI backend. The options "
                                   "set where the controls start.")
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
                   help="light at the surface to start with, as for render (default overcast; "
                        "the window's sun slider at 0 is the overcast sky)")
    p.add_argument("--sun-elevation", type=finite_float, default=None, metavar="DEG",
                   help=f"--light sun-sky: the sun's elevation, 1-90 (default "
                        f"{DEFAULT_SUN_ELEVATION_DEG:g})")
    p.add_argument("--sun-azimuth", type=finite_float, default=None, metavar="DEG",
                   help="--light sun-sky: the sun's compass angle, as for render (default "
                        f"{DEFAULT_SUN_AZIMUTH_DEG:g})")
    p.add_argument("--wind", type=finite_float, default=0.0, metavar="M_S",
                   help="start the wind slider here: a wind sea's caustics under the sun "
                        "(0 = a flat surface; default 0)")
    p.add_argument("--size", default="640x360", metavar="WxH",
                   help="size of the rendered image (default 640x360)")
    p.set_defaults(func=run, command="view")


def run(args):
    # deferred: the viewer loads wgpu, rendercanvas and matplotlib; `aquaspec --help` need not
    from aquaspec.apps.viewer import run_viewer
    w, h = parse_size(args.size)
    elevation, azimuth = sun_from(args)
    run_viewer(width=w, height=h, water=args.water, depth_m=args.depth, bands=args.bands,
               sensor=args.sensor, ms_model=args.ms_model, cone_spread=args.cone_spread,
               camspec=check_camspec(args.camspec), spread_scattering=args.spread_scattering,
               sun_elevation_deg=elevation if args.light == "sun-sky" else _OVERCAST_ELEVATION,
               sun_azimuth_deg=azimuth, wind=args.wind)
    return 0
