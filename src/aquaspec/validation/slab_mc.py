"""A Monte Carlo reference for the sea seen from above under the sun.

Why it exists: a directional sun cannot reach the water through a smooth
dielectric in Mitsuba's ``volpathmis`` (no path connects a delta light
through a delta surface; ../shared/SPEC.md, "Facts measured for the
path-traced references"), so the view from above with the sun has no
Mitsuba reference. For a flat surface over horizontally uniform water (deep,
or a flat Lambertian seabed) the radiance leaving the sea depends on the
direction alone, and the sun's refracted beam under the surface is known in
closed form, so a plain backward Monte Carlo in the plane-parallel slab can
connect every scattering vertex to the sun (next-event estimation through
the surface, analytically). This module is that estimator; the tests and
:mod:`aquaspec.validation.above_check` hold it against Mitsuba wherever
Mitsuba can render the same thing (the overcast sky through the dielectric,
and the sun through an index-matched surface).

Conventions: y up, the surface the plane ``y = 0``, depth ``z = -y >= 0``,
unit directions, coefficients in 1/m per band. The camera's rays ``v``
(going down) meet the surface at ``mu_i = -v_y``:

    L = R(mu_i) L_sky + T(mu_i) / n^2 L_w(t)

with ``t`` the refracted ray and ``L_w(t)`` the radiance arriving at the
surface from below against ``t``, estimated per path: a path starts at the
surface along ``t``, flies exponential distances of extinction ``c``, and at
each event

- in the water: the sun's next-event term ``w (b/c) p(cos theta) F0
  exp(-c z / mu0)`` (``F0`` the refracted beam's normal irradiance just
  below the surface, ``cos theta`` between the beam's way and the path's
  way back), then ``w *= b/c`` and a new way sampled from ``p``;
- on the seabed (depth ``H``, albedo ``rho``): ``w rho/pi mu0 F0 exp(-c H /
  mu0)``, then ``w *= rho`` and a cosine-weighted way up;
- at the surface from below (``mu = d_y > 0``): the sky through it, ``w
  T_out(mu) n^2 L_sky`` (``T_out = 0`` beyond the critical angle), and the
  path goes on mirrored with ``w *= 1 - T_out``.

Paths end by Russian roulette (unbiased) once ``w`` is small. No delta-M, no
truncation: the full phase function and ``c``. The sun's glint (the disc
mirrored in the surface) is a delta here and is left out; compare it
separately. The sky is uniform (radiance ``L_sky`` in air).
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import (FLAT_NORMAL, N_WATER, fresnel_transmittance,
                                       fresnel_transmittance_out, refract)

#: Weight below which a path plays Russian roulette, and its survival chance.
ROULETTE_WEIGHT, ROULETTE_SURVIVAL = 0.02, 0.25
#: Events after which a path is stopped whatever its weight (never reached in
#: practice: the roulette ends paths long before).
MAX_EVENTS = 10_000
#: Nodes of the inverse CDF of a tabulated phase function.
PHASE_SAMPLER_NODES = 1 << 18


class PhaseSampler:
    """Draw scattering cosines from a phase function (an
    :class:`aquaspec.medium.phase.PhaseFunction`) and evaluate it: exactly for
    the isotropic function, by an inverse CDF on :data:`PHASE_SAMPLER_NODES`
    cosines otherwise (fine near forward, where the measured functions
    peak).

    ``truncate_deg`` > 0 counts the scattering within that angle of forward
    as no scattering at all (its share ``f`` of ``p``: the water's ``c`` and
    ``b`` become ``c - f b`` and ``(1 - f) b``, :meth:`scaled`; ``p`` is zero
    inside the cone and renormalised outside). Why: the sun's next-event
    term is ``p`` at the angle between the beam and the path's way back, and
    a path climbing within a degree of the sun picks up Petzold's forward
    peak (``p(0.1 deg)`` is thousands of times ``p(5 deg)``), a rare, huge
    term that made a 3C estimate's standard error 30 %. Light scattered by
    under a degree is, for the radiance leaving the sea, still going the
    beam's way; the estimate's change between 0.5 and 2 degrees is measured
    in the tests."""

    def __init__(self, phase, truncate_deg: float = 0.0):
        self.phase = phase
        self.isotropic = type(phase).__name__ == "Isotropic"
        self.cut = np.cos(np.radians(float(truncate_deg))) if truncate_deg > 0 else 1.0
        self.forward_fraction = 0.0
        if not self.isotropic:
            # Nodes dense in theta near 0 (theta = pi x^2).
            x = np.linspace(0.0, 1.0, PHASE_SAMPLER_NODES)
            mu = np.cos(np.pi * x * x)[::-1]                      # ascending, -1 ... 1
            p = np.maximum(np.asarray(phase(mu), dtype=float), 0.0)
            cdf = np.concatenate([[0.0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(mu))])
            if not cdf[-1] > 0:
                raise AquaspecError("the phase function integrates to zero")
            cdf = cdf / cdf[-1]
            keep = np.interp(self.cut, mu, cdf)
            self.forward_fraction = 1.0 - float(keep)
            self._mu, self._cdf = mu, np.minimum(cdf / keep, 1.0)

    def scaled(self, c: float, b: float) -> tuple[float, float]:
        """``(c, b)`` of the water with the cone's scattering taken out."""
        f = self.forward_fraction
        return c - f * b, (1.0 - f) * b

    def value(self, mu):
        """``p(mu)`` in 1/sr (zero inside the cut cone, renormalised outside)."""
        if self.isotropic:
            return np.full(np.shape(mu), 1.0 / (4.0 * np.pi))
        mu = np.clip(mu, -1.0, 1.0)
        return np.where(mu < self.cut, np.asarray(self.phase(mu), dtype=float)
                        / (1.0 - self.forward_fraction), 0.0)

    def sample(self, rng, n: int) -> np.ndarray:
        """``n`` scattering cosines."""
        u = rng.random(n)
        if self.isotropic:
            return 2.0 * u - 1.0
        return np.minimum(np.interp(u, self._cdf, self._mu), self.cut)


def _turn(d, mu, rng):
    """Rotate unit directions ``d`` (N, 3) by polar cosines ``mu`` about
    themselves, at uniform azimuths."""
    phi = 2.0 * np.pi * rng.random(d.shape[0])
    sin = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))
    helper = np.where((np.abs(d[:, 1]) < 0.9)[:, None], [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    u = np.cross(d, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    w = np.cross(d, u)
    return (mu[:, None] * d + (sin * np.cos(phi))[:, None] * u
            + (sin * np.sin(phi))[:, None] * w)


def water_radiance(t, *, c, b, sampler: PhaseSampler, sky_radiance: float,
                   sun_dir=None, sun_beam: float = 0.0, seabed_depth_m=None,
                   seabed_albedo: float = 0.0, n_water: float = N_WATER, rng) -> np.ndarray:
    """One band: the radiance arriving at the surface from below against each
    path's start ``t`` (N, 3) (going down), one path each (N,) (module
    docstring). ``sun_dir``: the refracted beam's way (y < 0) and
    ``sun_beam`` its normal irradiance just below the surface."""
    c, b = sampler.scaled(c, b)
    d = np.array(t, dtype=float)
    n_paths = d.shape[0]
    z = np.zeros(n_paths)
    w = np.ones(n_paths)
    out = np.zeros(n_paths)
    alive = np.arange(n_paths)
    albedo = b / c
    bed = np.inf if seabed_depth_m is None else float(seabed_depth_m)
    sun = sun_dir is not None and sun_beam > 0
    mu0 = -float(sun_dir[1]) if sun else 1.0
    for _ in range(MAX_EVENTS):
        if alive.size == 0:
            break
        dd, zz, ww = d[alive], z[alive], w[alive]
        s = -np.log(1.0 - rng.random(alive.size)) / c
        dy = dd[:, 1]
        # Where the flight ends: the surface (going up), the seabed (going down), or in the water.
        s_top = np.where(dy > 0, zz / np.where(dy > 0, dy, 1.0), np.inf)
        s_bed = np.where(dy < 0, (bed - zz) / np.where(dy < 0, -dy, 1.0), np.inf)
        top = s_top <= np.minimum(s, s_bed)
        hit_bed = ~top & (s_bed <= s)
        water = ~top & ~hit_bed
        # Surface from below: the sky through it, then mirrored.
        if np.any(top):
            t_out = fresnel_transmittance_out(dy[top], n_water)
            out[alive[top]] += ww[top] * t_out * n_water * n_water * sky_radiance
            ww[top] *= 1.0 - t_out
            zz[top] = 0.0
            dd[top, 1] = -dd[top, 1]
        # Seabed: the sun on it, then a diffuse bounce up.
        if np.any(hit_bed):
            k = np.flatnonzero(hit_bed)
            if sun:
                out[alive[k]] += (ww[k] * seabed_albedo / np.pi * mu0 * sun_beam
                                  * np.exp(-c * bed / mu0))
            u1, u2 = rng.random(k.size), rng.random(k.size)
            r, phi = np.sqrt(u1), 2.0 * np.pi * u2
            dd[k] = np.stack([r * np.cos(phi), np.sqrt(1.0 - u1), r * np.sin(phi)], axis=1)
            zz[k] = bed
            ww[k] *= seabed_albedo
        # In the water: the sun's next event, then a scattering.
        if np.any(water):
            k = np.flatnonzero(water)
            zk = zz[k] - s[k] * dy[k]
            if sun:
                cos = -(dd[k] @ np.asarray(sun_dir, dtype=float))
                out[alive[k]] += (ww[k] * albedo * sampler.value(cos) * sun_beam
                                  * np.exp(-c * zk / mu0))
            dd[k] = _turn(dd[k], sampler.sample(rng, k.size), rng)
            zz[k] = zk
            ww[k] *= albedo
        # Russian roulette.
        low = ww < ROULETTE_WEIGHT
        survive = rng.random(alive.size) < ROULETTE_SURVIVAL
        ww = np.where(low, np.where(survive, ww / ROULETTE_SURVIVAL, 0.0), ww)
        d[alive], z[alive], w[alive] = dd, zz, ww
        alive = alive[ww > 0]
    return out


def sea_radiance_mc(view, *, a, b, phase, sky_radiance, sun_to_air=None, sun_beam_air=None,
                    seabed_depth_m=None, seabed_albedo: float = 0.0, n_water: float = N_WATER,
                    paths: int = 100_000, seed: int = 0, truncate_deg: float = 0.0,
                    sky_shape=None) -> dict:
    """The mean band radiance over camera rays ``view`` (R, 3) going down
    (e.g. every pixel of a camera above the sea), by the module's estimator.

    ``a``, ``b``, ``sky_radiance``, ``sun_beam_air``: per band (n,);
    ``phase``: a :class:`aquaspec.medium.phase.PhaseFunction` for every band;
    ``sun_to_air``: unit vector towards the sun in air (None: no sun) and
    ``sun_beam_air`` its normal irradiance in air; ``truncate_deg``: see
    :class:`PhaseSampler`; ``sky_shape``: the sky's radiance along unit
    directions (R, 3) relative to ``sky_radiance`` (None: uniform), for the
    sky the surface mirrors into the camera (the light entering the water
    stays the uniform sky's, as the light field takes it). Each path takes a ray of
    ``view`` at random. Returns ``{"mean": (n,), "standard_error": (n,),
    "sky_reflected": (n,)}`` (the last: the ``R L_sky`` part of the mean).
    """
    view = np.asarray(view, dtype=float).reshape(-1, 3)
    if np.any(view[:, 1] >= 0):
        raise AquaspecError("every ray of the view must go down to the sea (v_y < 0)")
    a, b = np.atleast_1d(np.asarray(a, float)), np.atleast_1d(np.asarray(b, float))
    sky = np.broadcast_to(np.asarray(sky_radiance, dtype=float), a.shape)
    sampler = PhaseSampler(phase, truncate_deg)
    sun_dir = beam = None
    if sun_to_air is not None:
        to_air = np.asarray(sun_to_air, dtype=float)
        cos_z = float(to_air[1])
        if not 0.0 < cos_z <= 1.0:
            raise AquaspecError(f"the sun must be above the horizon (to_sun y = {cos_z:g})")
        to_w = -refract(-to_air, FLAT_NORMAL, n_water)[0]
        sun_dir = -to_w
        beam = (np.asarray(sun_beam_air, dtype=float) * cos_z * fresnel_transmittance(cos_z, n_water)
                / to_w[1])
    rng = np.random.default_rng(seed)
    pick = view[rng.integers(0, view.shape[0], paths)]
    mu_i = -pick[:, 1]
    r = 1.0 - fresnel_transmittance(mu_i, n_water)
    r_sky = r if sky_shape is None else r * np.asarray(
        sky_shape(pick * np.array([1.0, -1.0, 1.0])), dtype=float)
    t, _ = refract(pick, FLAT_NORMAL, n_water)
    mean, se, refl = (np.zeros(a.size) for _ in range(3))
    for i in range(a.size):
        lw = water_radiance(t, c=a[i] + b[i], b=b[i], sampler=sampler,
                            sky_radiance=float(sky[i]), sun_dir=sun_dir,
                            sun_beam=0.0 if beam is None else float(beam[i]),
                            seabed_depth_m=seabed_depth_m, seabed_albedo=seabed_albedo,
                            n_water=n_water, rng=rng)
        sample = r_sky * sky[i] + (1.0 - r) / n_water ** 2 * lw
        mean[i] = sample.mean()
        se[i] = sample.std(ddof=1) / np.sqrt(paths)
        refl[i] = float(np.mean(r_sky)) * sky[i]
    return {"mean": mean, "standard_error": se, "sky_reflected": refl}
