"""``aquaspec spectra``: a water's a, b, c, Kd and a sensor's curves, as a table and a plot."""

from __future__ import annotations

from aquaspec.cli.common import (add_band_options, add_water_options, bands_from, check_camspec,
                                water_from)
from aquaspec.colour.sensors import get_sensor
from aquaspec.io.atomic import check_writable
from aquaspec.io.png import write_figure


def register(sub):
    p = sub.add_parser(
        "spectra", help="table and plot of a water's coefficients and a sensor's curves",
        description="Print a water's absorption a, scattering b, extinction c = a + b and diffuse "
                    "attenuation Kd (1/m) per wavelength band, and plot them with the sensor's "
                    "response curves.")
    add_water_options(p)
    p.add_argument("--sensor", default=None, metavar="NAME|FILE.csv",
                   help="also show this sensor's response curves (see `aquaspec list sensors`)")
    p.add_argument("--camspec", metavar="PATH",
                   help="camspec_database.txt (Jiang et al. 2013; not shipped) whose cameras "
                        "--sensor can name")
    add_band_options(p, default=31)
    p.add_argument("--plot", metavar="OUT.png", help="write a plot (PNG)")
    p.set_defaults(func=run, command="spectra")


def table(water, bands):
    bw = water.on_bands(bands)
    rows = [f"{'band_nm':>13s} {'a':>9s} {'b':>9s} {'c':>9s} {'Kd':>9s}"]
    for lo, hi, a, b, c, kd in zip(bands.edges_nm[:-1], bands.edges_nm[1:], bw.a, bw.b, bw.c, bw.kd):
        rows.append(f"{lo:6.1f}-{hi:6.1f} {a:9.5f} {b:9.5f} {c:9.5f} {kd:9.5f}")
    return "\n".join(rows)


def plot(path, water, sensor, bands):
    import matplotlib  # deferred: matplotlib takes 0.3 s to import; only --plot needs it
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # deferred: as matplotlib
    check_writable(path, suffixes=(".png",))
    n_ax = 2 if sensor is not None else 1
    fig, axes = plt.subplots(1, n_ax, figsize=(6 * n_ax, 4), squeeze=False)
    ax = axes[0, 0]
    sel = (water.wavelength_nm >= bands.lo_nm) & (water.wavelength_nm <= bands.hi_nm)
    wl = water.wavelength_nm[sel]
    bw = water.on_bands(bands)
    for name, data, band in (("a", water.a, bw.a), ("b", water.b, bw.b), ("c", water.c, bw.c),
                             ("Kd" + (" (derived)" if water.kd_derived else ""), water.kd, bw.kd)):
        line, = ax.plot(wl, data[sel], label=name)
        ax.stairs(band, bands.edges_nm, color=line.get_color(), alpha=0.4)
    ax.set_yscale("log")
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("1/m")
    ax.set_title(f"Jerlov {water.name} ({water.source})" if not water.source.startswith("csv")
                 else water.name)
    ax.legend()
    if sensor is not None:
        ax2 = axes[0, 1]
        for k, col in enumerate("rgb"):
            ax2.plot(sensor.wavelength_nm, sensor.response[k], color=col)
        ax2.set_xlim(bands.lo_nm, bands.hi_nm)
        ax2.set_xlabel("wavelength (nm)")
        ax2.set_ylabel("response")
        ax2.set_title(sensor.name)
    fig.tight_layout()
    write_figure(path, fig, dpi=110)


def run(args):
    if args.plot:
        check_writable(args.plot, suffixes=(".png",))
    water, bands = water_from(args), bands_from(args)
    sensor = get_sensor(args.sensor, check_camspec(args.camspec)) if args.sensor else None
    print(f"water {water.name}, source {water.source}" + (" (Kd derived)" if water.kd_derived else ""))
    print(f"  {water.citation}")
    for line in water.filled:
        print(f"  filled: {line}")
    print(table(water, bands))
    if sensor is not None:
        w = sensor.on_bands(bands)
        print(f"sensor {sensor.name}: band-averaged response (R, G, B)")
        for c, (r, g, b) in zip(bands.centers_nm, w):
            print(f"{c:8.1f} {r:8.4f} {g:8.4f} {b:8.4f}")
    if args.plot:
        plot(args.plot, water, sensor, bands)
        print(f"wrote {args.plot}")
    return 0
