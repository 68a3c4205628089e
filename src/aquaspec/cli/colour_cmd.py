"""``aquaspec colour``: the camera RGB of a water at a depth."""

from __future__ import annotations

import json

from aquaspec.cli.common import (MAX_OCEAN_DEPTH_M, add_band_options, add_light_options,
                                add_sensor_options, add_water_options, bands_from, depth_metres,
                                finite_float, light_from, sensor_from, water_from)
from aquaspec.rendering.appearance import view_from_elevation, water_colour
from aquaspec.transport.lightfield.cone import forward_cone
from aquaspec.transport.models import MONZON2022


def register(sub):
    p = sub.add_parser(
        "colour", aliases=["color"], help="camera RGB of open water and of a grey card",
        description="What colour is water X at depth Y for camera Z? Prints the linear camera "
                    "RGB of open water (water_rgb) and of an 18 % grey card facing the camera "
                    "at --distance (grey_card_rgb), seen horizontally or --view-elevation "
                    "degrees up. With --light sun-sky the sun's beam is what the renderer "
                    "makes of it: scattered once along the view, and on the card.")
    add_water_options(p)
    p.add_argument("--depth", type=depth_metres, required=True, metavar="M",
                   help=f"camera depth below the surface, 0 to {MAX_OCEAN_DEPTH_M:g} metres")
    p.add_argument("--distance", type=finite_float, default=3.0, metavar="M",
                   help="distance to the grey card, metres (default 3)")
    p.add_argument("--view-elevation", type=finite_float, default=0.0, metavar="DEG",
                   help="view direction above the horizontal, -90 (down) to 90 (up), in the "
                        "vertical plane of -z, the direction --sun-azimuth is measured from "
                        "(default 0)")
    add_sensor_options(p)
    add_band_options(p)
    add_light_options(p)
    p.add_argument("--json", action="store_true", help="print JSON with every parameter")
    p.set_defaults(func=run, command="colour")


def run(args):
    res = water_colour(water_from(args), sensor_from(args), bands_from(args),
                       depth_m=args.depth, distance_m=args.distance, light=light_from(args),
                       ambient=args.ambient, outside="zero" if args.outside_zero else "error",
                       ms_model=args.ms_model, phase=args.phase,
                       forward_cone_deg=forward_cone(args.forward_cone, False),
                       view=view_from_elevation(args.view_elevation))
    if args.json:
        print(json.dumps(res, indent=2))
    else:
        fmt = lambda v: " ".join(f"{x:.6g}" for x in v)  # noqa: E731
        model = ("monzon2022 model (the seeds' model)" if res["ms_model"] == MONZON2022
                 else f"light field ({res['phase']} phase function)")
        elev = res["view_elevation_deg"]
        view = "horizontal view" if elev == 0 else f"view {elev:+g} deg"
        print(f"water {res['water']['name']} ({res['water']['source']}), depth {res['depth_m']:g} m, "
              f"{view}, sensor {res['sensor']['name']}, {res['bands']['n']} bands, {model}")
        print(f"water_rgb      {fmt(res['water_rgb'])}")
        print(f"grey_card_rgb  {fmt(res['grey_card_rgb'])}  (at {res['distance_m']:g} m, "
              f"depth {res['grey_card_depth_m']:g} m)")
        if "sun_part" in res:
            sun = res["light"]["sun"]
            print(f"of which the sun's beam (elevation {sun['elevation_deg']:g}, azimuth "
                  f"{sun['azimuth_deg']:g} deg):")
            print(f"  water        {fmt(res['sun_part']['water_rgb'])}  (scattered once)")
            print(f"  grey card    {fmt(res['sun_part']['grey_card_rgb'])}  (lit, and "
                  "scattered once on the way)")
    return 0
