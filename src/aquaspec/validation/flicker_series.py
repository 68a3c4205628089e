"""The flicker at fixed points in time, under a moving sea (issue 34, item 4).

Darecki et al.'s CV (:mod:`aquaspec.validation.fluctuations`) is of a time
series at one point; that check takes the spread over the tile at one
instant instead. This one follows the sea in time: the same water, sun,
wind, collector and depths, the sea :class:`aquaspec.light.waves.Waves` at
``t = 0, dt, 2 dt, ...`` (its own dispersion ``omega^2 = g k``, not the
renderer's 2 s loop), a caustic map per instant
(:func:`aquaspec.light.caustics.caustic_map`, carried into the scattered
light by the wavelength's transfer, :mod:`aquaspec.light.caustic_scatter`)
read by the renderer's lookup over the collector at ``points x points``
fixed places, and the plate's irradiance ``E = E_beam C + E_diffuse``
(:func:`aquaspec.validation.fluctuations.plate_terms`). Per depth:

- the CV in time at each place, pooled over the places
  (``sqrt(mean var_t) / mean E``), beside the CV over the places at each
  instant, pooled over the instants (the fluctuation check's statistic);
- the dominant period: the peak of the places' mean power spectrum of
  ``E(t)`` (its mean removed, a Hann window), and the spectrum's mean
  frequency.

Units: metres, seconds, Hz, nm.
"""

from __future__ import annotations

import time
from dataclasses import replace

import jerlov
import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.light import caustics
from aquaspec.light.caustic_scatter import scatter_slices
from aquaspec.light.waves import Waves
from aquaspec.validation import fluctuations as fl


def power_spectrum(series, dt_s: float):
    """``(f, P)``: the power spectra of ``series`` (..., T) sampled every
    ``dt_s`` s (each mean removed, a Hann window), ``f`` (T // 2 + 1,) Hz;
    a series (S, P, T) gives ``P`` (S, T // 2 + 1), the mean over its P places."""
    x = np.asarray(series, dtype=float)
    if x.shape[-1] < 4 or not (np.isfinite(dt_s) and dt_s > 0):
        raise AquaspecError(f"a series of {x.shape[-1]} samples every {dt_s!r} s; accepted: "
                            "at least 4 samples, dt > 0")
    x = (x - x.mean(axis=-1, keepdims=True)) * np.hanning(x.shape[-1])
    p = np.abs(np.fft.rfft(x, axis=-1)) ** 2
    if p.ndim > 2:
        p = p.mean(axis=tuple(range(1, p.ndim - 1)))
    return np.fft.rfftfreq(x.shape[-1], dt_s), p


def dominant_period(f, p) -> tuple:
    """``(period_s, mean_frequency_hz)`` (each (...,)) of spectra ``p`` (..., F)
    at ``f`` (F,) Hz: the peak's period (the zero frequency left out) and the
    power-weighted mean frequency."""
    p = np.asarray(p, dtype=float)[..., 1:]
    f = np.asarray(f, dtype=float)[1:]
    peak = f[np.argmax(p, axis=-1)]
    mean_f = np.sum(p * f, axis=-1) / np.maximum(np.sum(p, axis=-1), 1e-300)
    return 1.0 / peak, mean_f


def flicker_series(*, wavelengths_nm=(443.0, 532.0, 670.0), depths=None,
                   duration_s: float = 6.4, dt_s: float = 0.05, seed: int = 0,
                   points: int = 16, tile_m: float = 8.0, grid: int = 256,
                   progress=None) -> dict:
    """The time statistics of the flicker (see the module docstring) at
    ``depths`` (m; Darecki et al.'s by default) and ``wavelengths_nm`` (W,),
    one sea (``seed``) over ``duration_s`` every ``dt_s``; ``points``: places
    per side (spread over the tile). Returns a JSON-ready dict (arrays (D, W))."""
    t0 = time.perf_counter()
    n_t = int(round(duration_s / dt_s))
    if n_t < 4 or points < 1:
        raise AquaspecError(f"duration {duration_s!r} s every {dt_s!r} s with {points!r} "
                            "places a side; accepted: at least 4 instants, 1 place")
    if depths is None:
        depths = jerlov.darecki2011_irradiance_cv().depth_m
    depths = np.asarray(depths, dtype=float)
    wls = np.atleast_1d(np.asarray(wavelengths_nm, dtype=float))
    water = fl.darecki_water()
    light = fl.darecki_light()
    sun = light.sun
    terms = [fl.plate_terms(water, light, float(wl), depths)[:3] for wl in wls]
    g = (np.arange(points) + 0.25) * tile_m / points
    x, z = np.meshgrid(g, g)
    series = np.zeros((wls.size, depths.size, points * points, n_t))
    for i in range(n_t):
        sea = Waves(fl.WIND_M_S, wind_azimuth_deg=sun.azimuth_deg, seed=int(seed),
                    tile_m=tile_m, grid=grid, time_s=i * dt_s)
        raw = caustics.caustic_map(sea, sun.elevation_deg, sun.azimuth_deg,
                                   n_water=sun.n_water)
        for j, (beam, diffuse, scatter) in enumerate(terms):
            cmap = replace(raw, levels=caustics.mip_levels(
                scatter_slices(raw.levels[0], raw.depths, tile_m, scatter)), scatter=scatter)
            for k, d in enumerate(depths):
                c = caustics.sample(cmap, np.stack([x, np.full_like(x, -d), z], axis=-1),
                                    fl.COLLECTOR_M)
                series[j, k, :, i] = beam[k] * c.ravel() + diffuse[k]
        if progress is not None:
            progress(i + 1, n_t)
    mean = series.mean(axis=(2, 3))
    cv_time = np.sqrt(series.var(axis=3).mean(axis=2)) / mean
    cv_space = np.sqrt(series.var(axis=2).mean(axis=2)) / mean
    f, p = power_spectrum(series.reshape(-1, points * points, n_t), dt_s)
    period, mean_f = dominant_period(f, p)
    shape = (wls.size, depths.size)
    return {"wavelength_nm": wls.tolist(), "depth_m": depths.tolist(),
            "seed": int(seed), "duration_s": n_t * dt_s, "dt_s": float(dt_s),
            "places": points * points, "tile_m": float(tile_m), "grid": int(grid),
            "cv_time": cv_time.T.tolist(), "cv_space": cv_space.T.tolist(),
            "dominant_period_s": period.reshape(shape).T.tolist(),
            "mean_frequency_hz": mean_f.reshape(shape).T.tolist(),
            "frequency_hz": f.tolist(), "power": p.reshape(shape + (-1,)).tolist(),
            "seconds": time.perf_counter() - t0}
