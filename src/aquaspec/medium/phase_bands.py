"""Per-band quantities of the water's phase function: pure water mixed with the particles.

The b of a water type includes pure water's own scattering, ``b = b_w + b_p``.
For the phase functions measured on the particles alone
(:data:`MIXED_WITH_WATER`: ``"petzold"``) each band's phase function is the
mixture

    p_band = (b_w p_w + b_p p) / b = f_w p_w + (1 - f_w) p,
    f_w = min(b_w(lambda), b) / b   (:func:`pure_water_fraction`),

with ``p_w`` pure water's function (:class:`aquaspec.medium.phase.PureWaterPhase`)
and ``b_w`` from ``jerlov.pure_water_scattering`` at the band centres; other
phase functions apply to the whole b, the same in every band. The mixture is
written once, :func:`mix_with_pure_water`; :func:`band_mixture` applies it to
any quantity linear in the phase function, and the per-band values
(:func:`band_phase_values`), Legendre moments (:func:`band_moments`), forward
cone fractions (:func:`band_cone_fraction`) and cone offset distributions
(:func:`band_cone_offset_cdf`) are built on it.
:func:`redistribution_matrix` turns band moments into the discrete-ordinates
solver's redistribution.
"""

from __future__ import annotations

import jerlov
import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.medium.phase import PhaseFunction, PureWaterPhase, TabulatedPhase, get_phase
from aquaspec.numerics import legendre_table

#: Methods whose particle phase is mixed with pure water by the b_w / b_p split.
MIXED_WITH_WATER = frozenset({"petzold"})


def mix_with_pure_water(particle, water, fraction):
    """The band phase function's quantity ``f_w q_w + (1 - f_w) q``: ``particle``
    (``q``, of the particles' function), ``water`` (``q_w``, of pure water's) and
    ``fraction`` (``f_w``, pure water's share of b) broadcast."""
    return fraction * water + (1.0 - fraction) * particle


def band_mixture(phase: PhaseFunction, quantity, b, wavelength_nm=None) -> np.ndarray:
    """``quantity`` of each band's phase function, shape ``(n_bands,) + q.shape``.

    ``quantity(ph)`` is linear in the phase function ``ph`` (its values at
    angles, its moments, a cone's mass): for the functions mixed with pure
    water it is :func:`mix_with_pure_water` of the particles' and pure
    water's, with :func:`pure_water_fraction` at the band centres
    ``wavelength_nm``; for the others ``quantity(phase)`` in every band.
    ``b`` (1/m) sets the number of bands.
    """
    b_arr = np.atleast_1d(np.asarray(b, dtype=float))
    q = np.asarray(quantity(phase), dtype=float)
    if phase.name not in MIXED_WITH_WATER:
        return np.broadcast_to(q, (b_arr.size,) + q.shape).copy()
    frac_w = pure_water_fraction(phase, b_arr, wavelength_nm).reshape((-1,) + (1,) * q.ndim)
    return mix_with_pure_water(q, np.asarray(quantity(PureWaterPhase()), dtype=float), frac_w)


def band_phase_values(method, cos_theta, *, b, wavelength_nm, **params) -> np.ndarray:
    """The band phase functions at ``cos_theta`` (...), shape ``(..., n_bands)`` (1/sr)."""
    ph = method if isinstance(method, PhaseFunction) else get_phase(method, **params)
    mu = np.clip(np.asarray(cos_theta, dtype=float), -1.0, 1.0)
    return np.moveaxis(band_mixture(ph, lambda p: p.value(mu), b, wavelength_nm), 0, -1)


def band_moments(method: str | PhaseFunction, lmax: int, b=None, wavelength_nm=None,
                 **params) -> np.ndarray:
    """Legendre moments per band, shape ``(n_bands, lmax + 1)``.

    For ``"petzold"`` the band phase function is the mixture
    ``(b_w p_w + b_p p_p) / b``, ``b_w = jerlov.pure_water_scattering(lambda)``
    at the band centres ``wavelength_nm``, ``b_p = max(b - b_w, 0)``; other
    methods apply to the whole b. ``b`` (1/m) sets the number of bands.
    """
    b_arr = np.atleast_1d(np.asarray(1.0 if b is None else b, dtype=float))
    phase = method if isinstance(method, PhaseFunction) else get_phase(method, **params)
    if phase.name in MIXED_WITH_WATER:
        if wavelength_nm is None:
            raise AquaspecError(f"phase {phase.name!r} mixes pure water by wavelength: "
                                "give wavelength_nm (band centres)")
        wl = np.atleast_1d(np.asarray(wavelength_nm, dtype=float))
        if wl.shape != b_arr.shape:
            raise AquaspecError(f"wavelength_nm has shape {wl.shape}; expected {b_arr.shape} "
                                "(one per band)")
    return band_mixture(phase, lambda ph: ph.legendre_moments(lmax), b_arr, wavelength_nm)


def band_cone_fraction(method, half_angle_deg: float, b=None, wavelength_nm=None,
                       **params) -> np.ndarray:
    """Fraction of scattering within ``half_angle_deg`` of forward, per band.

    ``f = 2 pi int_{cos theta_c}^1 p(mu) dmu`` for the band phase function
    (mixed with pure water by band for ``"petzold"``, as in
    :func:`band_moments`). Integrated over the angle on a grid that is
    geometric towards 0 degrees, where forward-peaked functions live.
    """
    if not 0.0 <= half_angle_deg < 90.0:
        raise AquaspecError(f"forward cone half-angle {half_angle_deg!r} deg; accepted: 0 to 90")
    b_arr = np.atleast_1d(np.asarray(1.0 if b is None else b, dtype=float))
    if half_angle_deg == 0.0:
        return np.zeros(b_arr.size)
    phase = method if isinstance(method, PhaseFunction) else get_phase(method, **params)
    theta_c = np.radians(half_angle_deg)
    theta = np.concatenate([[0.0], np.geomspace(1e-7, theta_c, 4000)])

    def cone(ph):
        if isinstance(ph, TabulatedPhase):
            return ph.cone_fraction(theta_c)
        y = 2 * np.pi * ph.value(np.cos(theta)) * np.sin(theta)
        return float(np.trapezoid(y, theta))

    return band_mixture(phase, cone, b_arr, wavelength_nm)


def pure_water_fraction(phase: PhaseFunction, b, wavelength_nm=None) -> np.ndarray:
    """Share of ``b`` that scatters with pure water's phase function, per band:
    ``min(b_w(lambda), b) / b`` for the phase functions mixed with pure water
    (:data:`MIXED_WITH_WATER`, at the band centres ``wavelength_nm``), else 0."""
    b_arr = np.atleast_1d(np.asarray(b, dtype=float))
    if phase.name not in MIXED_WITH_WATER:
        return np.zeros(b_arr.size)
    wl = np.atleast_1d(np.asarray(wavelength_nm, dtype=float))
    bw = np.minimum(np.asarray(jerlov.pure_water_scattering(wl), dtype=float), b_arr)
    return np.where(b_arr > 0, bw / np.where(b_arr > 0, b_arr, 1.0), 1.0)


def _cone_offset_cdf_one(ph, theta_c, offsets):
    """Cone mass and the CDF of ``alpha = theta U`` at ``offsets`` for one phase function."""
    theta = np.concatenate([[0.0], np.geomspace(1e-7, theta_c, 4000)])
    g = 2 * np.pi * ph.value(np.cos(theta)) * np.sin(theta)
    # Cumulative int_0^theta g and int_0^theta g / theta (g / theta -> 2 pi p(1) at 0).
    g_over = np.concatenate([[2 * np.pi * float(ph.value(1.0))], g[1:] / theta[1:]])
    dt = np.diff(theta)
    cum_g = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * dt)])
    cum_go = np.concatenate([[0.0], np.cumsum(0.5 * (g_over[1:] + g_over[:-1]) * dt)])
    a = np.clip(offsets, 0.0, theta_c)
    mass = cum_g[-1]
    below = np.interp(a, theta, cum_g)
    beyond = cum_go[-1] - np.interp(a, theta, cum_go)
    return mass, (below + a * beyond) / mass


def band_cone_offset_cdf(method, half_angle_deg: float, offsets_rad, b=None,
                         wavelength_nm=None, **params) -> np.ndarray:
    """Where the forward cone's light appears to come from, seen from the camera, per band.

    Light that reaches the camera after one scattering by ``theta`` (within
    the cone ``half_angle_deg``) at a point a fraction ``1 - U`` of the way
    from the camera to a target left the target at an angular offset
    ``alpha = theta U`` from the pixel's own direction; along a ray of
    length S every point is equally likely (the path from the target to the
    camera has length S wherever the scattering happens), so ``U`` is
    uniform on [0, 1]. Returns ``P(alpha <= a)`` at ``offsets_rad`` (radians),
    shape ``(n_bands, len(offsets))``:
    ``F(a) = [int_0^a g + a int_a^theta_c g(theta)/theta dtheta] / int_0^theta_c g``,
    ``g = 2 pi p(cos theta) sin theta`` (the band phase function, mixed with
    pure water by band for ``"petzold"`` as :func:`band_cone_fraction`).
    """
    if not 0.0 < half_angle_deg < 90.0:
        raise AquaspecError(f"forward cone half-angle {half_angle_deg!r} deg; accepted: "
                            "above 0 and below 90")
    offsets = np.asarray(offsets_rad, dtype=float)
    b_arr = np.atleast_1d(np.asarray(1.0 if b is None else b, dtype=float))
    phase = method if isinstance(method, PhaseFunction) else get_phase(method, **params)
    theta_c = np.radians(half_angle_deg)
    mass, cdf = _cone_offset_cdf_one(phase, theta_c, offsets)
    out = np.tile(cdf, (b_arr.size, 1))
    if phase.name in MIXED_WITH_WATER:
        # The mixture's cone holds f_w m_w + (1 - f_w) m of b: its CDF mixes the
        # two functions' CDFs by pure water's share of that cone.
        mass_w, cdf_w = _cone_offset_cdf_one(PureWaterPhase(), theta_c, offsets)
        frac_w = pure_water_fraction(phase, b_arr, wavelength_nm)
        share_w = frac_w * mass_w / mix_with_pure_water(mass, mass_w, frac_w)
        out = mix_with_pure_water(cdf, cdf_w, share_w[:, None])
    return out

def redistribution_matrix(moments, mu_out, mu_in, weight_in):
    """Azimuthally averaged redistribution ``Q[..., i, j]`` for DO quadrature.

    ``Q_ij = w_j / 2 * sum_l (2l + 1) chi_l P_l(mu_i) P_l(mu_j)`` is the share of
    light from quadrature direction ``j`` (weight ``w_j``, weights summing to 2
    over the sphere) scattered into direction ``i``, times 2 pi per sr, so that
    the in-scattered radiance is ``b sum_j Q_ij L_j``. ``moments`` is
    ``(..., L)`` (truncated, e.g. delta-M scaled); rows sum to ``chi_0`` when
    the quadrature integrates ``P_l`` exactly.
    """
    chi = np.asarray(moments, dtype=float)
    lmax = chi.shape[-1] - 1
    p_out = legendre_table(lmax, mu_out)     # (L, I)
    p_in = legendre_table(lmax, mu_in)       # (L, J)
    coef = chi * (2.0 * np.arange(lmax + 1) + 1.0) * 0.5
    return ((coef[..., None, :] * p_out.T) @ p_in) * np.asarray(weight_in)
