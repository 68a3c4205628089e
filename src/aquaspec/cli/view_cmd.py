"""``aquaspec view``: the interactive window."""

from __future__ import annotations


def register(sub):
    p = sub.add_parser("view", help="interactive window with live controls",
                       description="Open a window showing the built-in scene, with sliders for "
                                   "depth, bands and exposure and choices of water and sensor. "
                                   "Needs a display and a matplotlib GUI backend.")
    p.add_argument("--water", default="IB")
    p.add_argument("--depth", type=float, default=5.0)
    p.add_argument("--bands", type=int, default=8)
    p.add_argument("--sensor", default="human")
    p.add_argument("--camspec", metavar="PATH")
    p.add_argument("--size", default="640x360", metavar="WxH")
    p.set_defaults(func=run, command="view")


def run(args):
    from ..renderer import parse_size
    from ..viewer import run_viewer
    w, h = parse_size(args.size)
    run_viewer(width=w, height=h, water=args.water, depth_m=args.depth, bands=args.bands,
               sensor=args.sensor, camspec=args.camspec)
    return 0
