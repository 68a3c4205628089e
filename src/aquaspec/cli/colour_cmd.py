"""``aquaspec colour``: the camera RGB of a water at a depth."""

from __future__ import annotations

import json

from .common import (add_band_options, add_light_options, add_sensor_options,
                     add_water_options, bands_from, light_from, sensor_from, water_from)


def register(sub):
    p = sub.add_parser(
        "colour", aliases=["color"], help="camera RGB of open water and of a grey card",
        description="What colour is water X at depth Y for camera Z? Prints the linear camera "
                    "RGB of open water seen horizontally (water_rgb) and of an 18%% grey card "
                    "facing the camera at --distance (grey_card_rgb).")
    add_water_options(p)
    p.add_argument("--depth", type=float, required=True, metavar="M",
                   help="camera depth below the surface, metres")
    p.add_argument("--distance", type=float, default=3.0, metavar="M",
                   help="distance to the grey card, metres (default 3)")
    add_sensor_options(p)
    add_band_options(p)
    add_light_options(p)
    p.add_argument("--json", action="store_true", help="print JSON with every parameter")
    p.set_defaults(func=run, command="colour")


def run(args):
    from ..appearance import water_colour
    from ..lightfield import forward_cone
    res = water_colour(water_from(args), sensor_from(args), bands_from(args),
                       depth_m=args.depth, distance_m=args.distance, light=light_from(args),
                       ambient=args.ambient, outside="zero" if args.outside_zero else "error",
                       ms_model=args.ms_model, phase=args.phase,
                       forward_cone_deg=forward_cone(args.forward_cone, False))
    if args.json:
        print(json.dumps(res, indent=2))
    else:
        fmt = lambda v: " ".join(f"{x:.6g}" for x in v)  # noqa: E731
        model = ("seeds' model" if res["ms_model"] == "seeds"
                 else f"light field ({res['phase']} phase function)")
        print(f"water {res['water']['name']} ({res['water']['source']}), depth {res['depth_m']:g} m, "
              f"sensor {res['sensor']['name']}, {res['bands']['n']} bands, {model}")
        print(f"water_rgb      {fmt(res['water_rgb'])}")
        print(f"grey_card_rgb  {fmt(res['grey_card_rgb'])}  (at {res['distance_m']:g} m)")
    return 0
