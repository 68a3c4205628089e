"""A lamp's light on surfaces and scattered once towards the camera (NumPy reference).

Conventions as in :mod:`aquaspec.light.lamp`: metres, y up, the surface at
y = 0, coefficients in 1/m, wavelengths in nm. A lamp at ``q`` with axis
``d`` sends ``I(alpha) = I0 f(alpha)`` (W sr^-1 nm^-1 per band) at the angle
``alpha`` from its axis; the light travelling a distance ``r`` keeps
``exp(-c_lamp r)`` of itself.

**On a surface** at ``x`` with normal ``n``, ``r = |q - x|``, ``l = (q - x) / r``:

    E = I0 f(alpha) V(x) max(0, n . l) exp(-c_lamp r) / r^2         (W m^-2 nm^-1)

(:func:`lamp_irradiance`; ``V`` the lamp's visibility, its shadow). A
Lambertian surface of reflectance ``rho`` sends ``rho E / pi`` towards the
camera, which keeps ``exp(-c_view S)`` of it.

**In the water**, along the camera ray ``x(t) = o + t v`` up to ``S``:

    L_SS = b int_0^S p(cos psi) I0 f(alpha(t)) V(x(t)) exp(-c_lamp r(t)) / r(t)^2 exp(-c_view t) dt

with ``p`` the band's phase function at the scattering angle ``psi``
between the lamp's light at ``x`` and the direction to the camera. The
``1/r^2`` peak near the lamp is what a march along ``t`` resolves badly.
Equiangular sampling (Kulla & Fajardo 2012) removes it: with ``t*`` the
ray's closest approach to the lamp and ``D`` its distance there,
``t = t* + D tan(theta)`` gives ``r = D / cos(theta)`` and
``dt / r^2 = dtheta / D``, so

    L_SS = (b / D) int_{theta_a}^{theta_b} p(-sin theta) I0 f(alpha) V
                                           exp(-c_lamp r - c_view t) dtheta

where ``theta_a = atan((t_0 - t*) / D)``, ``theta_b = atan((t_1 - t*) / D)``
(pi/2 for an open-water ray, ``t_1 = inf``). The scattering cosine is
``cos psi = -sin theta`` (the light at ``x`` travels along ``(x - q) / r``,
whose component along ``v`` is ``sin theta``): the scattering angle is
``psi = pi/2 + theta``. What remains under the integral is bounded and
smooth but for the beam's edge and the phase function's forward peak,
which a ray passing close to a lamp ahead of it crosses near
``theta_a = -pi/2``. The ray is first cut to the part inside the lamp's
cone (:func:`cone_interval`, exact for cones up to 90 degrees), so every
sample lies in the beam, and the integral is the midpoint rule on
``n_samples`` equal steps of ``u = sqrt(psi / pi)`` (``dtheta = 2 pi u du``;
:func:`single_scattering`): samples graded towards forward scattering as the
phase function's tables are (:func:`aquaspec.transport.sun_scattering.log_phase_table`),
and nearly equal steps in ``psi`` for the angles a lamp beside the camera
scatters at (90-180 degrees). Looking 0.5-2 degrees past a point lamp 3 m
ahead in Jerlov II with Petzold's phase function, 32 equal steps of
``theta`` were 23-57 % low. For an isotropic point lamp in clear water
(``p = 1 / 4 pi``, ``c = 0``, ``V = 1``) the integrand in ``u`` is linear
and the rule exact: ``L_SS = b I0 (theta_b - theta_a) / (4 pi D)``.

Which extinctions: the renderer gives a lamp's light the extinction the
surfaces' light has on its way to the camera, from the lamp and towards the
camera alike (:meth:`aquaspec.rendering.setup.SpectralSetup.lamp_inputs`):
``c - f b`` with the light field's forward cone (scattering within it stays
in the beam), ``c`` with the thesis's model. The light scattered more than
once (the halo, the diffuse glow) is not here.

References
----------
.. [Kulla2012] C. Kulla, M. Fajardo, "Importance sampling techniques for
   path tracing in participating media", Computer Graphics Forum 31(4),
   1519-1528 (2012): equiangular sampling for point lights.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.light.lamp import Lamp
from aquaspec.transport.sun_scattering import phase_from_log_table

#: Equiangular samples along a camera ray per lamp (the GPU's; see docs/model.md).
DEFAULT_SAMPLES = 32
#: Rays closer to a lamp than this (m) are taken at this distance (the
#: integral goes as 1/D for a ray through the lamp).
MIN_DISTANCE_M = 1e-4
#: Surfaces closer to a lamp than this (m) are lit as at this distance.
MIN_RANGE_M = 1e-3
#: Rays per chunk of :func:`single_scattering` (memory: chunk x samples x bands).
_CHUNK_RAYS = 4096


@dataclass(frozen=True, eq=False)
class LampInputs:
    """What a lamp's terms need per band.

    ``lamp``: the lamp placed in the world (:meth:`aquaspec.light.lamp.Lamp.placed`);
    ``intensity`` (n,): ``I0`` per band, W sr^-1 nm^-1
    (:meth:`aquaspec.light.lamp.Lamp.intensity_on`); ``c_lamp``, ``c_view``,
    ``b`` (n,) in 1/m; ``log_phase`` (n, K): the band phase functions'
    :func:`aquaspec.transport.sun_scattering.log_phase_table`; ``forward``
    (n,): the share ``f`` of scattering counted as none in ``c_lamp = c - f b``
    (None: 0); ``halo``: whether the light scattered more than once is added
    (:mod:`aquaspec.transport.lamp_halo`).
    """

    lamp: Lamp
    intensity: np.ndarray
    c_lamp: np.ndarray
    c_view: np.ndarray
    b: np.ndarray
    log_phase: np.ndarray
    forward: np.ndarray | None = None
    halo: bool = True

    @property
    def forward_share(self) -> np.ndarray:
        """``f`` per band (zeros when not given)."""
        return (np.zeros(np.asarray(self.b).shape) if self.forward is None
                else np.asarray(self.forward, dtype=float))

    @property
    def iso_fraction(self) -> float:
        """The lamp's mean intensity over the sphere over its on-axis one,
        ``int f dOmega / 4 pi`` (1 for a point light)."""
        return float(self.lamp.solid_angle_sr() / (4.0 * np.pi))

    def phase(self, cos_psi) -> np.ndarray:
        """The band phase functions at ``cos_psi`` (...), (..., n), from the table."""
        return phase_from_log_table(self.log_phase, cos_psi)


def _angle_from_axis(lamp: Lamp, to_point, r):
    """``alpha`` of points at ``to_point = x - q`` (..., 3), ``r = |x - q|``."""
    cos_a = np.einsum("...k,k->...", to_point, lamp.direction) / np.maximum(r, 1e-300)
    return np.arccos(np.clip(cos_a, -1.0, 1.0))


def lamp_irradiance(inp: LampInputs, points, normals, visibility=1.0) -> np.ndarray:
    """``E`` on surfaces at ``points`` (..., 3) with unit ``normals`` (..., 3),
    shape (..., n), W m^-2 nm^-1; ``visibility`` (...) broadcasts."""
    lamp = inp.lamp
    to_lamp = lamp.position - np.asarray(points, dtype=float)
    r = np.linalg.norm(to_lamp, axis=-1)
    rc = np.maximum(r, MIN_RANGE_M)
    cos_n = np.maximum(np.einsum("...k,...k->...", np.asarray(normals, dtype=float), to_lamp)
                       / rc, 0.0)
    f = lamp.relative_intensity(_angle_from_axis(lamp, -to_lamp, r))
    geo = (f * cos_n * np.asarray(visibility, dtype=float) / rc ** 2)[..., None]
    return geo * np.asarray(inp.intensity) * np.exp(-np.asarray(inp.c_lamp) * rc[..., None])


def cone_interval(origin, dirs, lamp: Lamp):
    """Where the rays ``origin + t dirs`` (dirs (..., 3), unit) are inside the
    lamp's cone: ``(lo, hi)`` (...) with ``lo > hi`` where they never are;
    ``(-inf, inf)`` for cones of 90 degrees and more (not convex: the whole ray).

    Inside means ``(x - q) . d >= cos(cone) |x - q|``; squared, a quadratic
    ``A t^2 + B t + C >= 0`` (the double cone) on the forward nappe
    ``(x - q) . d >= 0``. A line meets a convex cone in one interval.
    """
    dirs = np.asarray(dirs, dtype=float)
    shape = dirs.shape[:-1]
    if lamp.cone_deg >= 90.0:
        return np.full(shape, -np.inf), np.full(shape, np.inf)
    q, d = lamp.position, lamp.direction
    w = np.asarray(origin, dtype=float) - q
    cc = np.cos(lamp.cone_rad) ** 2
    vd = dirs @ d
    wd = float(w @ d)
    vw = dirs @ w
    a = vd * vd - cc
    b = 2.0 * (vd * wd - cc * vw)
    c = wd * wd - cc * float(w @ w)
    disc = np.maximum(b * b - 4.0 * a * c, 0.0)
    sq = np.sqrt(disc)
    safe_a = np.where(np.abs(a) > 1e-12, a, 1.0)
    r1 = (-b - np.sign(safe_a) * sq) / (2.0 * safe_a)    # the smaller root
    r2 = (-b + np.sign(safe_a) * sq) / (2.0 * safe_a)
    lo = np.full(shape, -np.inf)
    hi = np.full(shape, np.inf)
    # Ray direction inside the cone's angle (A > 0): one end runs to infinity.
    opening = a > 1e-12
    ahead = opening & (vd > 0)
    lo = np.where(ahead, r2, lo)
    hi = np.where(opening & (vd <= 0), r1, hi)
    # Crossing the cone (A < 0): between the roots, if that part is on the forward nappe.
    crossing = a < -1e-12
    mid = 0.5 * (r1 + r2)
    forward = (wd + mid * vd) >= 0.0
    real = (b * b - 4.0 * a * c) >= 0.0
    lo = np.where(crossing, np.where(real & forward, r1, np.inf), lo)
    hi = np.where(crossing, np.where(real & forward, r2, -np.inf), hi)
    return lo, hi


def ray_angles(origin, dirs, s, lamp: Lamp, clip: bool = True):
    """The equiangular variables of rays (dirs (..., 3), lengths ``s`` (...)):
    ``(t_star, dist, theta_a, theta_b)``; ``theta_a >= theta_b`` where the
    ray holds no part of the beam. ``clip``: cut to :func:`cone_interval`."""
    dirs = np.asarray(dirs, dtype=float)
    s = np.asarray(s, dtype=float)
    rel = lamp.position - np.asarray(origin, dtype=float)
    t_star = dirs @ rel
    closest = rel - t_star[..., None] * dirs
    dist = np.maximum(np.linalg.norm(closest, axis=-1), MIN_DISTANCE_M)
    t0, t1 = np.zeros_like(s), s
    if clip:
        lo, hi = cone_interval(origin, dirs, lamp)
        t0, t1 = np.maximum(t0, lo), np.minimum(t1, hi)
    theta_a = np.arctan2(t0 - t_star, dist)
    theta_b = np.where(t1 > t0, np.arctan2(t1 - t_star, dist), theta_a)
    return t_star, dist, theta_a, theta_b


def equiangular_range(ta, tb):
    """``(u_a, du)``: the ray's range in ``u = sqrt(psi / pi)`` (``psi = pi/2 + theta``)
    from :func:`ray_angles`' ``theta_a, theta_b``; ``du = 0`` where it holds no beam."""
    ua = np.sqrt(np.clip(ta + 0.5 * np.pi, 0.0, np.pi) / np.pi)
    du = np.maximum(np.sqrt(np.clip(tb + 0.5 * np.pi, 0.0, np.pi) / np.pi) - ua, 0.0)
    return ua, du


def sample_terms(inp: LampInputs, origin, v, t_star, dist, ua, du, n_samples: int, *,
                 visibility=None, phase=None) -> np.ndarray:
    """Each midpoint sample's share of ``L_SS``, (P, N, n): rays ``v`` (P, 3) with
    :func:`ray_angles`' ``t_star, dist`` and :func:`equiangular_range`'s
    ``ua, du`` (P,), ``n_samples`` equal steps of ``u``; summed over the samples
    it is :func:`single_scattering` (the froxels, :mod:`aquaspec.transport.lamp_froxels`,
    sum them up to each step)."""
    lamp = inp.lamp
    phase = phase or inp.phase
    frac = (np.arange(n_samples) + 0.5) / n_samples
    u = ua[:, None] + du[:, None] * frac[None, :]                   # (P, N)
    theta = np.pi * u * u - 0.5 * np.pi
    t = t_star[:, None] + dist[:, None] * np.tan(theta)
    r = dist[:, None] / np.cos(theta)
    x = np.asarray(origin, dtype=float) + t[..., None] * v[:, None, :]
    f = lamp.relative_intensity(_angle_from_axis(lamp, x - lamp.position, r))
    if visibility is not None:
        f = f * np.asarray(visibility(x), dtype=float)
    att = np.exp(-np.asarray(inp.c_lamp) * r[..., None]
                 - np.asarray(inp.c_view) * t[..., None])             # (P, N, n)
    weight = (2.0 * np.pi * du / n_samples / dist)[:, None, None]
    return (np.asarray(inp.b) * np.asarray(inp.intensity) * weight
            * phase(-np.sin(theta)) * (f * u)[..., None] * att)


def single_scattering(inp: LampInputs, origin, dirs, s, *, n_samples: int = DEFAULT_SAMPLES,
                      visibility=None, phase=None, clip: bool = True) -> np.ndarray:
    """``L_SS`` of the lamp along rays from ``origin`` along unit ``dirs`` (P, 3) to
    ``s`` (P,) (``inf``: open water), shape (P, n), W m^-2 sr^-1 nm^-1.

    The midpoint rule on ``n_samples`` equal steps of ``sqrt(psi / pi)`` over
    the equiangular variable's range (module docstring). ``visibility(points (..., 3)) -> (...)`` is the lamp's
    visibility (None: 1); ``phase(cos_psi (...)) -> (..., n)`` the band phase
    functions (None: :meth:`LampInputs.phase`, the table the GPU reads).
    """
    dirs = np.asarray(dirs, dtype=float).reshape(-1, 3)
    s = np.asarray(s, dtype=float).reshape(-1)
    n = np.asarray(inp.b).size
    out = np.zeros((dirs.shape[0], n))
    for r0 in range(0, dirs.shape[0], _CHUNK_RAYS):
        v = dirs[r0:r0 + _CHUNK_RAYS]
        t_star, dist, ta, tb = ray_angles(origin, v, s[r0:r0 + _CHUNK_RAYS], inp.lamp, clip)
        ua, du = equiangular_range(ta, tb)
        out[r0:r0 + v.shape[0]] = sample_terms(inp, origin, v, t_star, dist, ua, du, n_samples,
                                               visibility=visibility, phase=phase).sum(axis=1)
    return out
