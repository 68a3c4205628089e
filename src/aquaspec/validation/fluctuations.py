"""The flicker of the light under waves against the sea: Darecki et al. 2011.

Darecki, Stramski & Sokolski (2011, "Measurements of high-frequency light
fluctuations induced by sea surface waves with an Underwater Porcupine
Radiometer System", J. Geophys. Res. 116, C00H09, doi:10.1029/2011JC007338)
measured the coefficient of variation (CV, standard deviation over mean) of
the downwelling irradiance under a wind sea in the Santa Barbara Channel:
wind 4.1-6.4 m/s, sun zenith 30-33 deg, beam attenuation c(555) = 0.68 1/m,
a 2.5 mm collector, six depths from 0.86 to 9.58 m at 443, 532 and 670 nm
(their Fig. 13a, through the PyPI package ``jerlov``,
``darecki2011_irradiance_cv()``, read off the figure's drawing commands:
jerlov's DATA.md section 24).

What aquaspec renders there, with nothing fitted to these data:

- the water: Jerlov 1C and 3C (Solonenko & Mobley 2015) mixed,
  ``(1 - x) 1C + x 3C`` in a, b and Kd, with ``x`` such that ``c(555) =
  0.68`` (:func:`darecki_water`);
- the light: the SPECTRL2 sun and sky (:func:`aquaspec.light.sky.surface_light`)
  at zenith :data:`SUN_ZENITH_DEG`, the middle of their range; the sea
  :class:`aquaspec.light.waves.Waves` at :data:`WIND_M_S` (the mean of
  their range), the wind blowing towards the sun's azimuth;
- per wavelength a one-band setup (:data:`BAND_WIDTH_NM` wide) of the
  renderer (:class:`aquaspec.rendering.setup.SpectralSetup`, light-field
  model, Petzold's phase function mixed with pure water): its light field's
  tables give the beam (``sun_fraction exp(-c* d / mu0)``) and the diffuse
  irradiance on an upward plate (``irradiance_per_e0`` at ``n_y = 1``), its
  caustic map (:func:`aquaspec.light.caustics.cached_caustic_map`, with the
  setup's transfer into the scattered light,
  :mod:`aquaspec.light.caustic_scatter`) the factor ``C`` on the beam;
- the plate: ``C`` read with :func:`aquaspec.light.caustics.sample` (the
  renderer's lookup, linear between depth slices) over the collector's
  size at a grid of points over the whole tile, and

      CV = std(E_beam C) / (E_beam mean(C) + E_diffuse).

Each wavelength's factor is carried by its own band's transfer (``rendered``:
what a one-band render gives). A default render (:data:`RENDER_BANDS`
bands) holds one factor for all its bands, carried by their mean transfer
(``rendered_shared``: that factor read as it is); each band reads it scaled
by its contrast scale (``rendered_scaled``: the band holding the
wavelength, as the renderer reads it, :func:`aquaspec.light.caustics.band_factor`).

Darecki's CV is of a time series at one point; this is the spread over the
tile at one instant (the same statistics for a stationary, homogeneous sea),
pooled over several independent seas (:data:`DEFAULT_SEEDS`,
:func:`pooled_cv`): one 8 m tile holds only a handful of the longer waves
that make the flicker at depth.
"""

from __future__ import annotations

import time
import warnings

import jerlov
import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.io.png import write_figure
from aquaspec.light import caustics
from aquaspec.light.caustic_sample import scale_at, scale_polynomial
from aquaspec.light.caustic_scatter import ScatterTransfer
from aquaspec.light.sky import surface_light
from aquaspec.light.waves import Waves
from aquaspec.medium.water import Water, get_water
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.transport.lightfield.tables import band_last_table, table_lookup

#: Darecki et al.'s conditions (2011, Sec. 2 and Fig. 13a): the middle of
#: the wind's and the sun's ranges, c(555) and the collector's diameter.
WIND_M_S = 5.2
SUN_ZENITH_DEG = 31.5
C555_PER_M = 0.68
COLLECTOR_M = 0.0025
#: The seas (wave seeds) whose variances are pooled: one 8 m tile holds a
#: handful of the long waves that set the flicker at depth (single seas
#: differed by up to 0.5 in the ratio to Darecki's at 6.7-9.6 m).
DEFAULT_SEEDS = tuple(range(8))
#: The width of each rendered band around the measured wavelength, nm.
BAND_WIDTH_NM = 10.0
#: The renderer's default bands (:func:`aquaspec.rendering.api.render`): its
#: caustic texture holds one factor for them all, the transfer's band mean.
RENDER_BANDS, RENDER_RANGE_NM = 16, (400.0, 700.0)
#: The acceptance of issue 34: within 30 % at every depth and wavelength.
TOLERANCE = 0.30
SOURCE = ("Darecki, Stramski & Sokolski 2011, J. Geophys. Res. 116, C00H09, "
          "doi:10.1029/2011JC007338, Fig. 13a (jerlov.darecki2011_irradiance_cv, read "
          "off the figure: jerlov DATA.md section 24)")


def darecki_water(c555: float = C555_PER_M) -> Water:
    """Jerlov 1C and 3C mixed linearly (a, b, Kd) to ``c(555 nm) = c555``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # 3C's filled 675-700 nm (reported by load)
        w1, w3 = get_water("1C"), get_water("3C")
    c1 = float(np.interp(555.0, w1.wavelength_nm, w1.c))
    c3 = float(np.interp(555.0, w3.wavelength_nm, w3.c))
    x = (float(c555) - c1) / (c3 - c1)
    mix = [(1.0 - x) * getattr(w1, q) + x * getattr(w3, q) for q in ("a", "b", "kd")]
    return Water(f"{1 - x:.3f} 1C + {x:.3f} 3C", "solonenko2015 (mixed)", w1.wavelength_nm,
                 *mix, notes=(f"c(555) = {c555:g} 1/m (Darecki et al. 2011)",),
                 citation=w1.citation)


def _setup(water, light, wavelength_nm, waves):
    half = 0.5 * BAND_WIDTH_NM
    return SpectralSetup(water, get_sensor("human"), light,
                         Bands(1, wavelength_nm - half, wavelength_nm + half),
                         ms_model="lightfield", waves=waves)


def darecki_light():
    """The SPECTRL2 sun and sky at :data:`SUN_ZENITH_DEG` (azimuth 0)."""
    return surface_light("sun-sky", sun_elevation_deg=90.0 - SUN_ZENITH_DEG,
                         sun_azimuth_deg=0.0)


def plate_terms(water, light, wavelength_nm: float, depths):
    """``(beam, diffuse, transfer, band)`` of a one-band setup at
    ``wavelength_nm``: the beam's and the diffuse irradiance on an upward
    plate (D,) at ``depths`` (D,) m (per unit E0 above, the light field's
    tables), the band's transfer into the scattered light and its
    description (a dict: a, b, c, the beam's extinction)."""
    setup = _setup(water, light, float(wavelength_nm), None)
    tables = setup.lightfield_tables()
    inputs = setup.sun_inputs()
    bw = water.on_bands(setup.bands)
    sun = light.sun
    c_sun = float(inputs.c_sun[0])
    depths = np.asarray(depths, dtype=float)
    beam = float(tables.sun_fraction[0]) * np.exp(-c_sun * depths / sun.mu0)
    diffuse = table_lookup(band_last_table(tables.irradiance_per_e0), depths,
                           np.ones_like(depths), tables.max_depth_m, band_last=True)[:, 0]
    scatter = ScatterTransfer.for_beam(b=bw.b, c=bw.c, c_sun=inputs.c_sun,
                                       wavelength_nm=setup.bands.centers_nm,
                                       to_sun=sun.to_sun, phase=setup.phase)
    band = {"wavelength_nm": float(wavelength_nm), "a_per_m": float(bw.a[0]),
            "b_per_m": float(bw.b[0]), "c_per_m": float(bw.c[0]),
            "beam_extinction_per_m": c_sun,
            "delta_m_forward_fraction": float((bw.c[0] - c_sun) / bw.b[0])}
    return beam, diffuse, scatter, band


def render_transfer(water, light, sea) -> ScatterTransfer:
    """The transfer into the scattered light that a default render
    (:data:`RENDER_BANDS` bands) of ``water`` under ``light`` with ``sea``
    puts on its one caustic texture (the setup's own, the bands' mean)."""
    setup = SpectralSetup(water, get_sensor("human"), light, Bands(RENDER_BANDS, *RENDER_RANGE_NM),
                          ms_model="lightfield", waves=sea)
    return setup.sun_inputs().caustics.scatter


def factor_stats(cmap, depths, *, points: int, collector_m: float = COLLECTOR_M):
    """Mean and std (D,) of the factor ``C`` read from ``cmap`` over
    ``collector_m`` at ``points x points`` places over its tile, at ``depths``
    (D,) (the renderer's lookup, :func:`aquaspec.light.caustics.sample`)."""
    tile = cmap.waves.tile_m
    g = (np.arange(points) + 0.25) * tile / points
    x, z = np.meshgrid(g, g)
    mean, std = [], []
    for d in depths:
        c = caustics.sample(cmap, np.stack([x, np.full_like(x, -d), z], axis=-1), collector_m)
        mean.append(float(np.mean(c)))
        std.append(float(np.std(c)))
    return np.array(mean), np.array(std)


def plate_cv(cmap, depths, beam, diffuse, *, points: int, collector_m: float = COLLECTOR_M):
    """The CV of ``beam C + diffuse`` on upward plates at ``depths`` (D,), with
    ``beam`` and ``diffuse`` (D,) the mean irradiances (:func:`factor_stats`);
    and the factor's own std (D,)."""
    mean, std = factor_stats(cmap, depths, points=points, collector_m=collector_m)
    return beam * std / (beam * mean + diffuse), std


def pooled_cv(beam, diffuse, means, stds):
    """The CV over several independent seas (S, D) of the factor's ``means``
    and ``stds``: their variances pooled, ``sqrt(mean_s (beam std_s)^2) /
    mean_s(beam mean_s + diffuse)`` (a long time series at a point samples
    many seas)."""
    m, s = np.asarray(means), np.asarray(stds)
    return np.sqrt(np.mean((beam * s) ** 2, axis=0)) / np.mean(beam * m + diffuse, axis=0)


def fluctuation_check(*, tile_m: float = 8.0, grid: int = 256, seeds=DEFAULT_SEEDS,
                      progress=None, **map_kwargs) -> dict:
    """The rendered CV against Darecki et al.'s (see the module docstring);
    ``tile_m``, ``grid``: the sea's tile (the renderer's default 8 m, 256);
    ``seeds``: the seas pooled (:func:`pooled_cv`); ``map_kwargs``:
    :func:`aquaspec.light.caustics.caustic_map`'s options (texels, slices, ...)
    where they differ from the renderer's. Returns a JSON-ready dict."""
    t0 = time.perf_counter()
    data = jerlov.darecki2011_irradiance_cv()
    depths = np.asarray(data.depth_m, dtype=float)
    wls = np.asarray(data.wavelengths_nm, dtype=float)
    measured = np.asarray(data.cv, dtype=float)
    water = darecki_water()
    light = darecki_light()
    sun = light.sun
    seas = [Waves(WIND_M_S, wind_azimuth_deg=sun.azimuth_deg, seed=int(k), tile_m=tile_m,
                  grid=grid) for k in seeds]
    if not seas:
        raise AquaspecError(f"seeds {seeds!r}; accepted: at least one sea's seed")
    shape = (depths.size, wls.size)
    out = {k: np.zeros(shape) for k in ("rendered", "unscattered", "beam_share",
                                         "rendered_shared", "rendered_scaled")}
    per_seed = np.zeros((len(seas),) + shape)
    bands = []
    points = 2 * int(map_kwargs.get("texels") or grid)
    plain = {}
    # What a default render puts on its one texture (the bands' mean transfer),
    # read as it is and as the band holding each wavelength reads it (its scale).
    shared = render_transfer(water, light, seas[0])
    shared_maps = [caustics.cached_caustic_map(sea, sun.elevation_deg, sun.azimuth_deg,
                                               n_water=sun.n_water, scatter=shared,
                                               **map_kwargs) for sea in seas]
    shared_stats = [factor_stats(m, depths, points=points) for m in shared_maps]
    edges = np.linspace(*RENDER_RANGE_NM, RENDER_BANDS + 1)
    for j, wl in enumerate(wls):
        beam, diffuse, scatter, band_info = plate_terms(water, light, float(wl), depths)
        stats, stats_plain, stats_scaled = [], [], []
        for i, sea in enumerate(seas):
            cmap = caustics.cached_caustic_map(sea, sun.elevation_deg, sun.azimuth_deg,
                                               n_water=sun.n_water, scatter=scatter,
                                               **map_kwargs)
            if i not in plain:
                plain[i] = factor_stats(caustics.cached_caustic_map(
                    sea, sun.elevation_deg, sun.azimuth_deg, n_water=sun.n_water,
                    **map_kwargs), depths, points=points)
            stats.append(factor_stats(cmap, depths, points=points))
            stats_plain.append(plain[i])
            per_seed[i, :, j] = beam * stats[-1][1] / (beam * stats[-1][0] + diffuse)
            sm = shared_maps[i]
            band = min(int(np.searchsorted(edges, wl, side="right")) - 1, RENDER_BANDS - 1)
            scale = scale_at(scale_polynomial(sm.band_scale), depths, sm.max_depth)[:, band]
            m, sd = shared_stats[i]
            stats_scaled.append((1.0 + scale * (m - 1.0), scale * sd))
        out["rendered"][:, j] = pooled_cv(beam, diffuse, *zip(*stats))
        out["unscattered"][:, j] = pooled_cv(beam, diffuse, *zip(*stats_plain))
        out["rendered_shared"][:, j] = pooled_cv(beam, diffuse, *zip(*shared_stats))
        out["rendered_scaled"][:, j] = pooled_cv(beam, diffuse, *zip(*stats_scaled))
        out["beam_share"][:, j] = beam / (beam + diffuse)
        bands.append(band_info)
        if progress is not None:
            progress(f"{wl:g} nm: CV {np.round(out['rendered'][:, j], 3).tolist()}")
    out["rendered_seed_min"] = per_seed.min(axis=0)
    out["rendered_seed_max"] = per_seed.max(axis=0)
    desc = caustics.cached_caustic_map(seas[0], sun.elevation_deg, sun.azimuth_deg,
                                       n_water=sun.n_water, **map_kwargs).describe()
    ratio = out["rendered"] / measured
    return {
        "source": SOURCE, "jerlov_version": getattr(jerlov, "__version__", "?"),
        "conditions": {"wind_m_s": WIND_M_S, "sun_zenith_deg": SUN_ZENITH_DEG,
                       "c555_per_m": C555_PER_M, "collector_m": COLLECTOR_M,
                       "band_width_nm": BAND_WIDTH_NM, "water": water.name,
                       "phase": "petzold (mixed with pure water)", "ms_model": "lightfield"},
        "map": {**desc, "points_per_side": points, "options": dict(map_kwargs),
                "seeds": [int(k) for k in seeds]},
        "bands": bands, "depth_m": depths.tolist(), "wavelength_nm": wls.tolist(),
        "measured": measured.tolist(),
        **{k: v.tolist() for k, v in out.items()},
        "ratio": ratio.tolist(), "ratio_unscattered": (out["unscattered"] / measured).tolist(),
        "ratio_shared": (out["rendered_shared"] / measured).tolist(),
        "ratio_scaled": (out["rendered_scaled"] / measured).tolist(),
        "shared_transfer": shared.describe(),
        "tolerance": TOLERANCE,
        "within_tolerance": bool(np.all(np.abs(ratio - 1.0) <= TOLERANCE)),
        "seconds": time.perf_counter() - t0,
    }


def format_fluctuations(res: dict) -> str:
    """The CV table: per wavelength the measured row, the rendered one with
    the transfer into the scattered light, and the unscattered beam's; the
    ratios of a default render's one shared factor read as it is and as
    each band reads it (scaled, :func:`aquaspec.light.caustics.band_factor`)."""
    d = res["depth_m"]
    lines = [f"CV of downwelling irradiance vs {res['source']}",
             f"wind {res['conditions']['wind_m_s']} m/s, sun zenith "
             f"{res['conditions']['sun_zenith_deg']} deg, water {res['conditions']['water']}, "
             f"tile {res['map']['tile_m']:g} m / {res['map']['texels']} texels, seas (seeds) "
             f"{res['map']['seeds']} pooled",
             "", "| depth (m) | " + " | ".join(f"{x:.2f}" for x in d) + " |",
             "|---|" + "---|" * len(d)]
    for j, wl in enumerate(res["wavelength_nm"]):
        for key, label in (("measured", "measured"), ("rendered", "aquaspec"),
                           ("unscattered", "beam only"), ("ratio", "aquaspec / measured"),
                           ("ratio_shared", f"{RENDER_BANDS} bands, unscaled / measured"),
                           ("ratio_scaled", f"{RENDER_BANDS}-band render / measured")):
            if key not in res:
                continue
            row = [r[j] for r in res[key]]
            lines.append(f"| {label}, {wl:g} nm | " + " | ".join(f"{x:.3f}" for x in row) + " |")
            if key == "rendered" and len(res["map"]["seeds"]) > 1:
                lo, hi = ([r[j] for r in res[k]] for k in ("rendered_seed_min",
                                                             "rendered_seed_max"))
                lines.append(f"| one sea, {wl:g} nm | " + " | ".join(
                    f"{a:.3f}-{b:.3f}" for a, b in zip(lo, hi)) + " |")
    worst = np.max(np.abs(np.asarray(res["ratio"]) - 1.0))
    lines += ["", f"largest |aquaspec / measured - 1| = {worst:.2f} (acceptance "
              f"{res['tolerance']:.2f}): {'met' if res['within_tolerance'] else 'not met'}"]
    return "\n".join(lines)


_STYLES = (":", "-.", (0, (5, 1, 1, 1, 1, 1)))


def plot_fluctuations(res: dict, path, extra=None):
    """CV against depth, measured (markers) and rendered (lines; dashed: the
    unscattered beam alone); ``extra``: more results (other tiles) drawn
    dotted, dash-dotted, ..., labelled by their tile. Returns the path."""
    # deferred: matplotlib is heavy to import and only the figure needs it
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # deferred: as above

    colours = {443.0: "tab:blue", 532.0: "tab:green", 670.0: "tab:red"}
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    d = np.asarray(res["depth_m"])
    for j, wl in enumerate(res["wavelength_nm"]):
        col = colours.get(float(wl), None)
        ax.plot(d, [r[j] for r in res["measured"]], "o", color=col,
                label=f"Darecki et al. 2011, {wl:g} nm")
        ax.plot(d, [r[j] for r in res["rendered"]], "-", color=col,
                label=f"aquaspec, {wl:g} nm")
        ax.plot(d, [r[j] for r in res["unscattered"]], "--", color=col, lw=0.8)
        for other, style in zip(extra or (), _STYLES):
            ax.plot(d, [r[j] for r in other["rendered"]], linestyle=style, color=col, lw=1.0)
    ax.plot([], [], "k--", lw=0.8, label="beam only (before)")
    for other, style in zip(extra or (), _STYLES):
        ax.plot([], [], linestyle=style, color="k", label=f"tile {other['map']['tile_m']:g} m / "
                f"{other['map']['texels']}")
    ax.set_yscale("log")
    ax.set_xlabel("depth (m)")
    ax.set_ylabel("CV of downwelling irradiance")
    ax.set_title(f"wind {res['conditions']['wind_m_s']} m/s, sun zenith "
                 f"{res['conditions']['sun_zenith_deg']} deg, c(555) = "
                 f"{res['conditions']['c555_per_m']} 1/m; tile {res['map']['tile_m']:g} m / "
                 f"{res['map']['texels']}, {len(res['map'].get('seeds', [0]))} seas pooled; "
                 "others one sea", fontsize=8)
    ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    return write_figure(path, fig, dpi=100)
