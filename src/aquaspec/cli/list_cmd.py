"""``aquaspec list waters|sensors``."""

from __future__ import annotations

import jerlov

from aquaspec.cli.common import check_camspec
from aquaspec.colour.sensors import builtin_sensors, load_camspec
from aquaspec.medium.water import DEFAULT_SOURCE, list_waters


def register(sub):
    p = sub.add_parser("list", help="list water types or sensors",
                       description="List the built-in water types (by data source) or sensors.")
    p.add_argument("what", choices=("waters", "sensors"), help="what to list")
    p.add_argument("--camspec", metavar="PATH",
                   help="also list the cameras of this camspec_database.txt (Jiang et al. "
                        "2013; not shipped with aquaspec)")
    p.set_defaults(func=run)


def run(args):
    if args.what == "waters":
        by_source = {}
        for source, wtype in list_waters():
            by_source.setdefault(source, []).append(wtype)
        for source, types in by_source.items():
            mark = " (default)" if source == DEFAULT_SOURCE else ""
            print(f"{source}{mark}: {' '.join(types)}")
            print(f"    {jerlov.get_source(source).citation}")
        print("or your own: --water FILE.csv with columns wavelength_nm,a,b[,Kd]")
    else:
        # The camspec file is read before anything is printed: a bad file is
        # one error, not half a list.
        cameras = load_camspec(check_camspec(args.camspec)) if args.camspec else {}
        for name, s in {**builtin_sensors(), **cameras}.items():
            print(f"{name:24s} {s.range_nm[0]:g}-{s.range_nm[1]:g} nm  {s.source}")
        if not args.camspec:
            print("(add --camspec PATH to list the cameras of a camspec_database.txt)")
    return 0
