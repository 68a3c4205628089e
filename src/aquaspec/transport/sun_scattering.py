"""The sun's beam scattered once towards the camera (NumPy reference).

Conventions as in :mod:`aquaspec.light.sun` (metres, y up, the surface at
y = 0, depth ``d = -p.y``; the beam's normal irradiance at depth ``d`` is
``E_b(d) = beam0 exp(-c_sun d / mu0)``, :func:`aquaspec.light.sun.beam_irradiance`).

Along a camera ray ``x(t) = o + t v`` (depth ``d(t) = d_o - t v_y``) the beam
scattered once towards the camera is

    L_SS = b p(cos theta) int_0^S V(x(t)) E_b(d(t)) exp(-c_view t) dt,
    cos theta = direction . (-v)

with ``p`` the band's phase function (for ``petzold`` mixed with pure water
by band, :func:`aquaspec.medium.phase_bands.band_phase_values`, as the light
field does) and ``c_view`` the extinction the renderer applies to a
surface's light on its way to the camera. Without shadows (``V = 1``) it is
closed form, ``b p E_b(0) ms_path_integral(c_view, c_sun / mu0, d_o, v_y, S)``
(:func:`single_scattering_open`, with
:func:`aquaspec.transport.monzon2022.ms_path_integral`, stable for every sign
of ``k = c_view - c_sun v_y / mu0``). With shadows the integral is taken over
``N`` equal steps up to ``S`` or a length beyond which the beam adds less
than :data:`TAIL` of the term, with ``V`` at each step's middle and each
step's exponential integrated exactly (:func:`march_weights`); the renderer
integrates it per froxel instead (:mod:`aquaspec.transport.froxels`), and the
GPU pass does the same with ``V`` read from a shadow map.

Under a wind-roughened surface (``SunInputs.caustics``,
:mod:`aquaspec.light.caustics`) ``V`` is multiplied by the caustic factor
``C(x)`` (mean about 1).

The phase function is tabulated per band as ``ln p`` on a grid fine towards
forward scattering (:func:`log_phase_table`, read by
:func:`phase_from_log_table`); :func:`band_mean_log_phase` is the bands' mean
on the same grid, by which the froxels divide.

The multiple scattering of the sun's light is not here: it is part of the
ambient term (the light field's diffuse field, or the ``Kd`` model of
:mod:`aquaspec.transport.monzon2022`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.light.caustics import CausticMap
from aquaspec.medium.phase_bands import band_phase_values
from aquaspec.numerics import decay_integral
from aquaspec.transport import monzon2022 as model

#: Steps along a camera ray for the shadowed single scattering.
DEFAULT_STEPS = 48
#: The march stops where the rest of the unshadowed integral is below this share.
TAIL = 1e-3


def scattering_cosine(direction, v):
    """``cos theta`` between the beam and light leaving towards the camera:
    ``direction . (-v)``."""
    return -(np.asarray(v, dtype=float) @ np.asarray(direction, dtype=float))


def single_scattering_open(*, b, phase_value, beam0, c_sun, c_view, depth_o, v_y, s, mu0):
    """``L_SS`` without shadows (closed form), shape ``(..., n_bands)``.

    ``phase_value`` (..., n_bands): the band phase function at each ray's
    scattering angle. Per-ray ``depth_o, v_y, s`` (...).
    """
    d = np.asarray(depth_o, dtype=float)[..., None]
    vy = np.asarray(v_y, dtype=float)[..., None]
    ss = np.asarray(s, dtype=float)[..., None]
    path = model.ms_path_integral(np.asarray(c_view), np.asarray(c_sun) / mu0, d, vy, ss)
    return np.asarray(b) * phase_value * np.asarray(beam0) * path


def march_length(c_sun, c_view, depth_o, v_y, s, mu0, tail: float = TAIL):
    """Where the march along a ray stops, m, per ray: ``S`` (cut at the surface),
    or earlier where the unshadowed integral's rest is below ``tail``.

    The slowest band sets it: the integrand is ``exp(-k t)`` with
    ``k = c_view - c_sun v_y / mu0``; for ``k > 0`` the rest beyond ``t`` is
    ``exp(-k t)`` of the whole, so ``t = -ln(tail) / k``.
    """
    s_cut = model.ray_length(np.asarray(s, dtype=float), np.asarray(depth_o, dtype=float),
                             np.asarray(v_y, dtype=float))
    k = np.asarray(c_view) - np.asarray(c_sun) * np.asarray(v_y, dtype=float)[..., None] / mu0
    k_min = np.min(k, axis=-1)
    t_tail = np.where(k_min > 0, -np.log(tail) / np.where(k_min > 0, k_min, 1.0), np.inf)
    out = np.minimum(s_cut, t_tail)
    if not np.all(np.isfinite(out)):
        raise AquaspecError("a camera ray has no end: open water with k <= 0 "
                            "(this cannot happen under water; please report it)")
    return out


def march_weights(k, length, n_steps: int):
    """Weights of the ``n_steps`` equal steps over ``[0, length]``:
    ``w_j = int_{t_j}^{t_j+1} exp(-k t) dt``, shape ``(..., n_steps, n_bands)``.

    ``k`` (..., n_bands), ``length`` (...). Exact per step for any sign of k
    (the exponent's caller guarantees it stays bounded under water).
    """
    k = np.asarray(k, dtype=float)
    dt = np.asarray(length, dtype=float)[..., None] / n_steps           # (..., 1)
    j = np.arange(n_steps)
    t0 = j[None, :] * dt                                               # (..., N)
    kk = k[..., None, :]                                               # (..., 1, n)
    return np.exp(-kk * t0[..., None]) * decay_integral(kk, dt[..., None])


def single_scattering_marched(*, b, phase_value, beam0, c_sun, c_view, depth_o, v_y, s, mu0,
                              visibility, n_steps: int = DEFAULT_STEPS, tail: float = TAIL):
    """``L_SS`` with shadows, shape ``(..., n_bands)``.

    ``visibility(t_mid)`` gets the steps' middles ``(..., n_steps)`` (m along
    each ray) and returns ``V`` there (same shape, 0 ... 1; or with a band
    axis, ``(..., n_steps, n_bands)``, a ``V`` per band).
    """
    d = np.asarray(depth_o, dtype=float)
    vy = np.asarray(v_y, dtype=float)
    length = march_length(c_sun, c_view, d, vy, s, mu0, tail)
    k = np.asarray(c_view) - np.asarray(c_sun) * vy[..., None] / mu0
    w = march_weights(k, length, n_steps)
    t_mid = (np.arange(n_steps) + 0.5) * (length[..., None] / n_steps)
    vis = np.asarray(visibility(t_mid), dtype=float)
    integral = (np.sum(vis * w, axis=-2) if vis.ndim == np.ndim(w)
                else np.einsum("...j,...jb->...b", vis, w))
    start = np.exp(-np.asarray(c_sun) * d[..., None] / mu0)
    return np.asarray(b) * phase_value * np.asarray(beam0) * start * integral


#: Entries of the per-band phase-function table, over ``sqrt(theta / pi)``.
PHASE_TABLE_SIZE = 512


def log_phase_table(phase, *, b, wavelength_nm, size: int = PHASE_TABLE_SIZE, **params):
    """``ln p`` of the band phase functions at ``theta_k = pi (k / (size - 1))^2``,
    (n_bands, size).

    The grid is fine towards forward scattering, where the measured phase
    functions change over orders of magnitude; the GPU interpolates ``ln p``
    linearly in ``sqrt(theta)``.
    """
    theta = np.pi * (np.arange(size) / (size - 1.0)) ** 2
    p = band_phase_values(phase, np.cos(theta), b=b, wavelength_nm=wavelength_nm, **params)
    return np.log(np.maximum(p, 1e-30)).T


def phase_from_log_table(table, cos_theta):
    """``p`` per band at ``cos_theta`` (...), (..., n_bands): :func:`log_phase_table`
    interpolated linearly (in ``ln p``, over ``sqrt(theta)``)."""
    size = table.shape[1]
    theta = np.arccos(np.clip(np.asarray(cos_theta, dtype=float), -1.0, 1.0))
    x = np.sqrt(theta / np.pi) * (size - 1)
    k0 = np.clip(np.floor(x).astype(np.int64), 0, size - 2)
    f = (x - k0)[..., None]
    t = np.asarray(table, dtype=float).T
    return np.exp((1.0 - f) * t[k0] + f * t[k0 + 1])


@dataclass(frozen=True)
class SunInputs:
    """Everything per band the sun's terms need (:mod:`aquaspec.light.sun` and this module).

    ``beam0`` (n,): normal irradiance just below the surface; ``c_sun`` (n,)
    the beam's extinction; ``c_view`` (n,) the extinction on the way to the
    camera; ``b`` (n,); ``log_phase`` (n, K): :func:`log_phase_table`;
    ``to_sun`` (3,); ``n_steps``: steps of the march; ``caustics``: a
    :class:`aquaspec.light.caustics.CausticMap` modulating the beam (None: a flat surface).
    """

    beam0: np.ndarray
    c_sun: np.ndarray
    c_view: np.ndarray
    b: np.ndarray
    log_phase: np.ndarray
    to_sun: np.ndarray
    n_steps: int = DEFAULT_STEPS
    caustics: CausticMap | None = None

    @property
    def mu0(self) -> float:
        return float(self.to_sun[1])


def band_mean_log_phase(log_phase) -> np.ndarray:
    """``ln`` of the bands' mean phase function on the table's grid (K,): the
    froxels store the single scattering divided by it at their column's
    angle, and each pixel multiplies it back at its own angle, so the sharp
    forward peak follows the pixel while only the bands' ratios to the mean
    (which change slowly with angle) come from the column."""
    return np.log(np.mean(np.exp(np.asarray(log_phase, dtype=float)), axis=0))


def band_mean_phase_at(log_phase, cos_theta):
    """The bands' mean phase function (:func:`band_mean_log_phase`) at ``cos_theta`` (...)."""
    return phase_from_log_table(band_mean_log_phase(log_phase)[None, :], cos_theta)[..., 0]
