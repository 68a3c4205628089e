"""``aquaspec validate --surface``: the flat sea surface against the path tracer.

Two checks of :mod:`aquaspec.validation.window_check` and
:mod:`aquaspec.validation.above_check`, both with Mitsuba's smooth
``dielectric`` as the surface and an overcast sky above it:

- from below: Jerlov IB at 5 m looking straight up, the brightness and hue
  inside Snell's window, outside it and at the zenith, and the window's edge
  on the centre row against Snell's;
- level: IB at 5 m looking level, the mean colour of the top, middle and
  bottom quarters of the rows;
- from above: each water of ``waters`` over deep water and grey seabeds at 3
  and 10 m, the image's mean colour (relative error and hue); under the
  overcast sky against Mitsuba, and with the sun at each elevation of
  ``suns`` against :mod:`aquaspec.validation.slab_mc` (Mitsuba's
  ``volpathmis`` cannot bring a directional sun through its dielectric).

:func:`format_surface_study` tabulates them (markdown).
"""

from __future__ import annotations

from aquaspec.colour.bands import Bands
from aquaspec.io.metadata import to_jsonable
from aquaspec.validation.above_check import MC_PATHS, compare_above
from aquaspec.validation.reference import REFERENCE_BANDS
from aquaspec.validation.window_check import compare_level, compare_window

#: The seabeds the view from above is checked over (None: deep water).
SEABEDS = (None, 3.0, 10.0)
#: The sun's elevations (degrees) of the checks from above with a sun.
SUNS = (30.0, 60.0)


def run_surface_study(*, waters=("I", "IB", "II", "3C"), phase: str = "isotropic",
                      size: int = 48, spp: int = 256, sensors=("nikon-5100-npl",),
                      bands: Bands = REFERENCE_BANDS, progress=None, suns=SUNS,
                      paths: int = MC_PATHS) -> dict:
    """Both checks (module docstring); the images are left out of the result."""
    say = progress or (lambda m: None)
    say(f"Snell's window from below: IB, 5 m, {phase}, {size} px, {spp} spp")
    win = compare_window("IB", phase=phase, size=size, spp=spp, sensors=sensors, bands=bands)
    below = {"edge_px": win["edge_px"], "reference_seconds": win["reference_seconds"],
             "regions": {name: {k: v for k, v in reg.items() if k != "band_ratio"}
                         for name, reg in win["regions"].items()}}
    say(f"the level view: IB, 5 m, {phase}, {size} px, {spp} spp")
    level = compare_level("IB", phase=phase, size=size, spp=spp, sensors=sensors, bands=bands)
    above = []
    for water in waters:
        for bed in SEABEDS:
            say(f"the sea from above: {water}, seabed {bed or 'none (deep)'}, {phase}")
            r = compare_above(water, seabed_depth_m=bed, phase=phase, size=size, spp=spp,
                              sensors=sensors, bands=bands)
            above.append({"water": water, "seabed_depth_m": bed,
                          "reference_seconds": r["reference_seconds"],
                          **{s: r[s] for s in r if isinstance(r[s], dict)}})
    sun = []
    for water in waters:
        for bed in SEABEDS:
            for elevation in suns:
                say(f"the sea from above in the sun at {elevation:g} deg: {water}, seabed "
                    f"{bed or 'none (deep)'}, {phase}, {paths} Monte Carlo paths per band")
                r = compare_above(water, seabed_depth_m=bed, phase=phase, size=size,
                                  sensors=sensors, bands=bands, sun_elevation_deg=elevation,
                                  paths=paths)
                se = r["reference_standard_error"] / r["reference_image"].reshape(-1)
                sun.append({"water": water, "seabed_depth_m": bed, "sun_elevation_deg": elevation,
                            "reference_seconds": r["reference_seconds"],
                            "reference_standard_error_max": float(se.max()),
                            **{s: r[s] for s in r if isinstance(r[s], dict)}})
    return to_jsonable({"phase": phase, "size": size, "spp": spp, "bands": bands.describe(),
                        "paths": paths, "below": below, "level": level["rows"], "above": above,
                        "above_sun": sun}, "surface study")


def format_surface_study(res: dict) -> str:
    """Markdown tables of :func:`run_surface_study`'s result."""
    lines = [f"Phase function {res['phase']}, {res['size']} px, {res['spp']} spp, overcast sky.",
             "", "From below (Jerlov IB, 5 m, looking up): aquaspec / Mitsuba brightness and "
             "hue difference", "", "| region | sensor | brightness | hue (deg) |", "|---|---|---|---|"]
    for name, reg in res["below"]["regions"].items():
        for sensor, m in reg.items():
            if isinstance(m, dict):
                lines.append(f"| {name} ({reg['pixels']} px) | {sensor} | "
                             f"{m['brightness_ratio']:.3f} | {m['hue_deg']:.2f} |")
    e = res["below"]["edge_px"]
    lines += ["", f"Window's edge on the centre row: Snell {e['snell']:.2f} px, aquaspec "
                  f"{e['aquaspec']:.1f}, Mitsuba {e['reference']:.1f}.", "",
              "Level view (Jerlov IB, 5 m, open water): aquaspec / Mitsuba camera RGB", "",
              "| rows | sensor | RGB ratio |", "|---|---|---|"]
    for name, per in res["level"].items():
        for sensor, ratio in per.items():
            lines.append(f"| {name} | {sensor} | {' '.join(f'{x:.3f}' for x in ratio)} |")
    lines += ["",
              "From above (camera 5 m up, 60 degrees down): mean colour, relative error and hue",
              "", "| water | seabed | sensor | RGB ratio | error | hue (deg) |",
              "|---|---|---|---|---|---|"]
    lines += _above_rows(res["above"])
    if res.get("above_sun"):
        lines += ["", "From above in the sun (SPECTRL2 sun and sky, the glint left out) against "
                      f"the slab Monte Carlo ({res['paths']} paths per band): mean colour, "
                      "relative error and hue", "",
                  "| water | seabed | sun (deg) | sensor | RGB ratio | error | hue (deg) | MC s.e. |",
                  "|---|---|---|---|---|---|---|---|"]
        lines += _above_rows(res["above_sun"], sun=True)
    return "\n".join(lines)


def _above_rows(rows, sun: bool = False) -> list:
    """Table rows of the view from above: per case and sensor the RGB ratio,
    error and hue (with ``sun``: the elevation and the reference's error too)."""
    out = []
    for row in rows:
        bed = "deep" if row["seabed_depth_m"] is None else f"{row['seabed_depth_m']:g} m"
        for sensor, m in row.items():
            if isinstance(m, dict):
                ratio = " ".join(f"{x:.3f}" for x in m["ratio_rgb"])
                cells = [row["water"], bed] + ([f"{row['sun_elevation_deg']:g}"] if sun else [])
                cells += [sensor, ratio, f"{100 * m['rgb_error']:.1f} %", f"{m['hue_deg']:.2f}"]
                if sun:
                    cells.append(f"{100 * row['reference_standard_error_max']:.1f} %")
                out.append("| " + " | ".join(cells) + " |")
    return out
