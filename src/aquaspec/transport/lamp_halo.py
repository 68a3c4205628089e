"""A lamp's light scattered more than once: its diffuse glow (NumPy reference).

Conventions as in :mod:`aquaspec.transport.lamp_scattering`: metres, y up,
the water surface at y = 0, coefficients in 1/m, per band.

**Splitting the phase function.** The lamps' light already counts scattering
into the forward cone as no scattering at all (``c_lamp = c - f b``, ``f`` the
share of the band's phase function within the light field's forward cone;
``f = 0`` with the thesis's model). What is left is the scattering
``b* = (1 - f) b`` with the phase function outside the cone, of asymmetry
``g* = (g - f) / (1 - f)`` (the cone's light taken as going straight on,
``g`` the band phase function's mean cosine, :func:`phase_asymmetry`), and
absorption ``a = c_lamp - b*``.

**The glow.** The light scattered at least once by ``b*`` is taken as
diffuse and given by the diffusion approximation (P1) in an infinite
medium: fluence ``phi`` and net flux ``F = -D grad phi``, with
``D = 1 / (3 (a + b* (1 - g*)))`` and ``kappa = sqrt(a / D)``, its source the
unscattered light's first scattering, ``b* I exp(-c_lamp rho) / rho^2`` at
distance ``rho`` from a lamp of intensity ``I`` in every direction. The
source convolved with the diffusion Green function
``exp(-kappa s) / (4 pi D s)`` is one-dimensional for a point source; with
``alpha = c_lamp - kappa``, ``beta = c_lamp + kappa`` it is, in closed form
(:func:`halo_fluence`),

    phi(r) = b* I / (2 D kappa r) [exp(-kappa r) (Ein(beta r) - Ein(alpha r))
                                   + 2 sinh(kappa r) E1(beta r)]

with ``E1`` the exponential integral and ``Ein(z) = int_0^z (1 - e^-t) / t dt``
(entire; ``alpha`` may be negative). Far from the lamp it tends to a point
source of the scattered power, ``b* / c_lamp`` of the lamp's for
``kappa << c_lamp``; near it, it grows as ``ln(1 / r)``.

A spot lamp's source is its own first scattering, ``b* I0 f(alpha) exp(-c_lamp rho)
/ rho^2``: its glow is the point source's of the same power (``I = I0
iso_fraction``, ``iso_fraction = int f dOmega / 4 pi``) times the spot factor
``A(r, alpha)`` (:func:`spot_factor`), from the Legendre expansion of the
Green function and of the beam's profile (exact within diffusion, up to
:data:`SPOT_ORDERS`; 2.3-3.8 on the axis 2 m from a 40-degree spot in Jerlov
II and 3C, below 1 outside the cone). The flux is kept radial, scaled by the
same factor (its sideways part, out of the beam, is left out).

**What it adds** (the diffuse radiance of P1, ``L(w) = phi / 4 pi + 3 F . w / 4 pi``,
with ``|F|`` cut at ``phi / 3`` near the lamp so that ``L`` is nowhere negative):

- on a surface with normal ``n`` at ``r`` from the lamp, ``l`` towards it:
  ``E = max(0, phi / 4 + |F| (n . l) / 2)``, unshadowed (the glow comes from
  all around); :func:`halo_irradiance`;
- along a camera ray ``v``, the glow scattered towards the camera per metre:
  ``b* (phi / 4 pi - 3 g* F (rhat . v) / 4 pi)``, ``rhat`` from the lamp to
  the point, carried to the camera by ``exp(-c_view t)``; integrated in the
  veil's columns (:mod:`aquaspec.transport.lamp_froxels`) over their depths,
  one midpoint each (:func:`halo_source`).

The light scattered once towards the camera stays the veil's single
scattering; the glow's own scattering towards the camera is second order and
up, and on surfaces the glow is all the scattered light (the direct term
has none): nothing is counted twice.

The functions of ``r`` are tabulated per band (:func:`halo_table`, the GPU's
table): ``r phi / 4``, ``r |F| / 2``, ``r b* phi / 4 pi``,
``r 3 b* g* |F| / 4 pi`` per unit ``I`` at the distances of
:func:`aquaspec.transport.lamp_depths.depth_boundaries`, read linearly
(:func:`halo_lookup`) and divided by ``r``; the spot factor per band at the
same distances and :data:`SPOT_ANGLES` angles, read bilinearly (:func:`spot_lookup`).

References
----------
.. [Ishimaru1978] A. Ishimaru, "Wave Propagation and Scattering in Random
   Media", vol. 1, ch. 9 (Academic Press, 1978): the diffusion approximation,
   its Green function and the collimated source.
.. [Joseph1976] J. H. Joseph, W. J. Wiscombe, J. A. Weinman, "The delta-Eddington
   approximation for radiative flux transfer", J. Atmos. Sci. 33, 2452-2459
   (1976): the forward peak counted as unscattered, ``g* = (g - f) / (1 - f)``.
"""

from __future__ import annotations

import numpy as np
from scipy.special import exp1, expi, ive, kve

from aquaspec.transport.lamp_depths import DEPTH_MAX_M, depth_boundaries, depth_coordinate
from aquaspec.transport.sun_scattering import phase_from_log_table

_EULER = 0.5772156649015329
#: Smallest absorption (1/m) the diffusion length is computed with.
MIN_ABSORPTION = 1e-6
#: Smallest distance (m) the glow is read at (it grows as ln(1/r) at the lamp).
MIN_HALO_RANGE_M = 1e-3


def ein(z) -> np.ndarray:
    """``Ein(z) = int_0^z (1 - exp(-t)) / t dt`` for real ``z`` (either sign)."""
    z = np.asarray(z, dtype=float)
    small = np.abs(z) < 1e-6
    zz = np.where(small, 1.0, z)
    with np.errstate(over="ignore"):
        big = _EULER + np.log(np.abs(zz)) - expi(-zz)
    return np.where(small, z - z * z / 4.0, big)


def phase_asymmetry(log_phase) -> np.ndarray:
    """``g``, the mean cosine of each band's phase function from its table
    (:func:`aquaspec.transport.sun_scattering.log_phase_table`), (n,): the
    integral of ``p cos psi`` over the sphere, by the trapezoid rule on a fine
    grid of ``sqrt(psi / pi)``, normalised by that of ``p``."""
    u = np.linspace(0.0, 1.0, 4097)
    psi = np.pi * u * u
    p = phase_from_log_table(np.asarray(log_phase), np.cos(psi))          # (K, n)
    w = (2.0 * np.pi * np.sin(psi) * 2.0 * np.pi * u)[:, None]           # dOmega / du
    def trapezoid(y):
        return np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(u)[:, None], axis=0)
    return trapezoid(p * w * np.cos(psi)[:, None]) / trapezoid(p * w)


def reduced_medium(b, c_lamp, forward, g):
    """``(a, b*, g*, D, kappa)`` per band (module docstring)."""
    b = np.asarray(b, dtype=float)
    f = np.asarray(forward, dtype=float)
    bs = (1.0 - f) * b
    a = np.maximum(np.asarray(c_lamp, dtype=float) - bs, MIN_ABSORPTION)
    gs = np.where(f < 1.0, (np.asarray(g, dtype=float) - f) / np.maximum(1.0 - f, 1e-12), 0.0)
    d = 1.0 / (3.0 * (a + bs * (1.0 - gs)))
    return a, bs, gs, d, np.sqrt(a / d)


def halo_fluence(r, b_star, c_lamp, d, kappa) -> np.ndarray:
    """``phi(r)`` per unit intensity (module docstring's closed form), r (...)
    broadcast against the bands' (n,) coefficients; W m^-2 nm^-1 per W sr^-1 nm^-1."""
    r = np.maximum(np.asarray(r, dtype=float), MIN_HALO_RANGE_M)[..., None]
    c = np.asarray(c_lamp, dtype=float)
    alpha, beta = (c - kappa) * r, (c + kappa) * r
    with np.errstate(over="ignore", invalid="ignore"):
        near = np.exp(-kappa * r) * (ein(beta) - ein(alpha))
        far = np.where(beta < 700.0, 2.0 * np.sinh(kappa * r) * exp1(np.minimum(beta, 700.0)), 0.0)
    return np.nan_to_num(b_star / (2.0 * d * kappa * r) * (near + far))


def halo_flux(r, b_star, c_lamp, d, kappa, h: float = 1e-4) -> np.ndarray:
    """``|F(r)| = -D dphi/dr`` per unit intensity, by a central difference of
    :func:`halo_fluence` (relative step ``h``)."""
    r = np.maximum(np.asarray(r, dtype=float), MIN_HALO_RANGE_M)
    dr = h * r
    dphi = (halo_fluence(r + dr, b_star, c_lamp, d, kappa)
            - halo_fluence(r - dr, b_star, c_lamp, d, kappa)) / (2.0 * dr[..., None])
    return np.maximum(-d * dphi, 0.0)


def halo_table(b, c_lamp, forward, log_phase, distances) -> np.ndarray:
    """The glow's table (n, J, 4) at ``distances`` (J,), m (the first may be 0):
    ``r phi / 4``, ``r |F| / 2``, ``r b* phi / 4 pi``, ``r 3 b* g* |F| / 4 pi``
    per unit intensity (module docstring)."""
    _, bs, gs, d, kappa = reduced_medium(b, c_lamp, forward, phase_asymmetry(log_phase))
    r = np.maximum(np.asarray(distances, dtype=float), MIN_HALO_RANGE_M)
    phi = halo_fluence(r, bs, c_lamp, d, kappa)                          # (J, n)
    # A P1 radiance phi / 4 pi + 3 F . w / 4 pi is nowhere negative only while
    # |F| <= phi / 3: near the lamp diffusion's flux is more, and is cut there.
    flux = np.minimum(halo_flux(r, bs, c_lamp, d, kappa), phi / 3.0)
    rr = r[:, None]
    out = np.stack([rr * phi / 4.0, rr * flux / 2.0, rr * bs * phi / (4.0 * np.pi),
                    rr * 3.0 * bs * gs * flux / (4.0 * np.pi)], axis=-1)  # (J, n, 4)
    return np.ascontiguousarray(np.swapaxes(out, 0, 1))


def halo_lookup(table, r, coordinate) -> np.ndarray:
    """The table's four quantities at distances ``r`` (...), divided by ``r``:
    (..., n, 4). ``coordinate(r)`` maps distances to the table's fractional
    index (:func:`aquaspec.transport.lamp_froxels.depth_coordinate`)."""
    table = np.asarray(table)
    j1 = table.shape[1]
    r = np.maximum(np.asarray(r, dtype=float), MIN_HALO_RANGE_M)
    x = np.clip(coordinate(r), 0.0, j1 - 1)
    k0 = np.minimum(np.floor(x), j1 - 2).astype(np.int64)
    f = (x - k0)[..., None, None]
    lo = np.moveaxis(table[:, k0], 0, -2)                                # (..., n, 4)
    hi = np.moveaxis(table[:, k0 + 1], 0, -2)
    return ((1.0 - f) * lo + f * hi) / r[..., None, None]


def halo_irradiance(values, cos_l) -> np.ndarray:
    """``E`` on surfaces from :func:`halo_lookup`'s ``values`` (..., n, 4) and the
    cosine ``n . l`` (...) of their normals with the direction to the lamp,
    per unit intensity: ``max(0, phi / 4 + |F| (n . l) / 2)``, (..., n)."""
    v = np.asarray(values)
    return np.maximum(v[..., 0] + v[..., 1] * np.asarray(cos_l, dtype=float)[..., None], 0.0)


def halo_source(values, rhat_dot_v) -> np.ndarray:
    """The glow scattered towards the camera per metre of a ray ``v`` at points
    whose direction from the lamp is ``rhat`` (``rhat . v`` (...)), per unit
    intensity: ``b* phi / 4 pi - 3 b* g* |F| (rhat . v) / 4 pi``, (..., n)."""
    v = np.asarray(values)
    return np.maximum(v[..., 2] - v[..., 3] * np.asarray(rhat_dot_v, dtype=float)[..., None], 0.0)


def lamp_halo_table(inp) -> np.ndarray:
    """:func:`halo_table` of a lamp's inputs (:class:`aquaspec.transport.lamp_scattering.LampInputs`)
    at :func:`aquaspec.transport.lamp_depths.depth_boundaries` (the last, infinite, left
    out), (n, LAMP_DEPTHS, 4), per unit intensity."""
    return halo_table(inp.b, inp.c_lamp, inp.forward_share, inp.log_phase,
                      depth_boundaries()[:-1])


#: The last spot tables made, by their inputs (a lamp pair's second is the first's).
_SPOT_CACHE: dict = {}
_SPOT_CACHE_SIZE = 8


def lamp_spot_table(inp) -> np.ndarray:
    """:func:`spot_factor` at the glow table's distances and :data:`SPOT_ANGLES`
    angles over [0, pi], (n, LAMP_DEPTHS, SPOT_ANGLES); the last few kept by
    the lamp's profile and the water's per-band inputs."""
    moments = profile_moments(inp.lamp, np.arange(SPOT_ORDERS + 1))
    key = tuple(np.asarray(x, dtype=float).tobytes() for x in
                (moments, inp.b, inp.c_lamp, inp.forward_share, inp.log_phase))
    if key not in _SPOT_CACHE:
        if len(_SPOT_CACHE) >= _SPOT_CACHE_SIZE:
            _SPOT_CACHE.pop(next(iter(_SPOT_CACHE)))
        # Smooth in the distances' index: made at every other and the last, linear between.
        t = depth_boundaries()[:-1]
        coarse = np.unique(np.append(np.arange(0, t.size, 2), t.size - 1))
        made = spot_factor(inp, t[coarse], moments=moments)                # (n, C, A)
        idx = np.arange(t.size)
        _SPOT_CACHE[key] = np.stack([[np.interp(idx, coarse, made[i, :, j])
                                      for j in range(made.shape[2])]
                                     for i in range(made.shape[0])]).transpose(0, 2, 1)
    return _SPOT_CACHE[key].copy()


def halo_tables(inp) -> tuple:
    """``(lamp_halo_table(inp), lamp_spot_table(inp))``."""
    return lamp_halo_table(inp), lamp_spot_table(inp)


def spot_lookup(spot, r, cos_alpha) -> np.ndarray:
    """The spot factor (n, R, A) at distances ``r`` (...) and angles from the
    lamp's axis ``acos(cos_alpha)`` (...), (..., n): bilinear in the distances'
    index (:func:`aquaspec.transport.lamp_depths.depth_coordinate`) and the angle."""
    spot = np.asarray(spot)
    _, nr, na = spot.shape
    x = np.clip(depth_coordinate(np.maximum(np.asarray(r, dtype=float), MIN_HALO_RANGE_M)),
                0.0, nr - 1)
    y = np.arccos(np.clip(cos_alpha, -1.0, 1.0)) / np.pi * (na - 1)
    i0 = np.minimum(np.floor(x), nr - 2).astype(np.int64)
    j0 = np.minimum(np.floor(y), na - 2).astype(np.int64)
    fx, fy = (x - i0)[..., None], (y - j0)[..., None]
    v = lambda i, j: np.moveaxis(spot[:, i, j], 0, -1)
    return ((1 - fy) * ((1 - fx) * v(i0, j0) + fx * v(i0 + 1, j0))
            + fy * ((1 - fx) * v(i0, j0 + 1) + fx * v(i0 + 1, j0 + 1)))


def _glow_values(inp, rel, r, tables):
    """The glow table's values (..., n, 4) at points ``rel`` (..., 3) from the lamp
    (``r`` their distances), times the spot factor there."""
    table, spot = halo_tables(inp) if tables is None else tables
    cos_a = np.einsum("...k,k->...", rel, inp.lamp.direction) / r
    return halo_lookup(table, r, depth_coordinate) * spot_lookup(spot, r, cos_a)[..., None]


def halo_on_surfaces(inp, points, normals, tables=None) -> np.ndarray:
    """The glow's irradiance ``E`` (W m^-2 nm^-1) on surfaces at ``points`` (..., 3)
    with unit ``normals`` (..., 3), (..., n): :func:`halo_irradiance` times the
    spot factor and the lamp's mean intensity ``I0 iso_fraction`` per band;
    ``tables``: :func:`halo_tables` (None: made here)."""
    to_lamp = inp.lamp.position - np.asarray(points, dtype=float)
    r = np.maximum(np.linalg.norm(to_lamp, axis=-1), MIN_HALO_RANGE_M)
    cos_l = np.einsum("...k,...k->...", np.asarray(normals, dtype=float), to_lamp) / r
    values = _glow_values(inp, -to_lamp, r, tables)
    return halo_irradiance(values, cos_l) * np.asarray(inp.intensity) * inp.iso_fraction


def halo_along_rays(inp, origin, dirs, t_a, t_b, tables=None) -> np.ndarray:
    """The glow scattered towards the camera along rays ``origin + t dirs``
    (dirs (P, 3)) over the slices ``[t_a, t_b]`` (P, J), each by its midpoint
    (W m^-2 sr^-1 nm^-1 per slice), (P, J, n): :func:`halo_source` times the
    spot factor and the lamp's mean intensity, carried to the camera by
    ``exp(-c_view t)``."""
    dirs = np.asarray(dirs, dtype=float)
    t_a, t_b = np.asarray(t_a, dtype=float), np.asarray(t_b, dtype=float)
    tm = 0.5 * (t_a + t_b)
    dt = np.maximum(t_b - t_a, 0.0)
    x = np.asarray(origin, dtype=float) + tm[..., None] * dirs[:, None, :]
    rel = x - inp.lamp.position
    r = np.maximum(np.linalg.norm(rel, axis=-1), MIN_HALO_RANGE_M)
    rhat_v = np.einsum("pjk,pk->pj", rel, dirs) / r
    src = halo_source(_glow_values(inp, rel, r, tables), rhat_v)             # (P, J, n)
    att = np.exp(-np.asarray(inp.c_view) * tm[..., None])
    return (dt[..., None] * src * att * np.asarray(inp.intensity) * inp.iso_fraction)


def halo_veil(inp, origin, dirs, s, n_slices: int = 512, tables=None) -> np.ndarray:
    """The glow scattered towards the camera along rays (P, 3) up to ``s`` (P,)
    (``inf``: up to :data:`aquaspec.transport.lamp_depths.DEPTH_MAX_M`), (P, n):
    ``n_slices`` geometric slices to the ray's end, a reference for the
    columns' sums."""
    s = np.minimum(np.asarray(s, dtype=float).reshape(-1), DEPTH_MAX_M)
    dirs = np.asarray(dirs, dtype=float).reshape(-1, 3)
    tables = halo_tables(inp) if tables is None else tables
    frac = np.expm1(np.linspace(0.0, np.log(1e4), n_slices + 1)) / (1e4 - 1.0)
    out = np.zeros((s.size, np.asarray(inp.b).size))
    for r0 in range(0, s.size, 256):                 # memory: rays x slices x bands x 4
        t = s[r0:r0 + 256, None] * frac[None, :]
        out[r0:r0 + 256] = halo_along_rays(inp, origin, dirs[r0:r0 + 256], t[:, :-1],
                                           t[:, 1:], tables).sum(axis=1)
    return out


#: Legendre orders of a spot lamp's glow (:func:`spot_factor`), and its angles.
SPOT_ORDERS = 32
SPOT_ANGLES = 64
#: Panels (in units of r) of the radial integral of :func:`_radial_moments`.
_PANELS = (0.0, 0.5, 0.8, 0.95, 1.0, 1.05, 1.25, 2.0, 5.0, 20.0)


def _ik(order, a, b) -> np.ndarray:
    """``i_l(a) k_l(b)`` (modified spherical Bessel functions, scipy's
    ``spherical_in`` and ``spherical_kn``) for ``a <= b``, exponentially scaled."""
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        out = (np.pi / 2.0) / np.sqrt(a * b) * ive(order + 0.5, a) * kve(order + 0.5, b) \
            * np.exp(a - b)
    return np.nan_to_num(out, nan=0.0, posinf=0.0)


def _radial_moments(r, c, kappa, orders) -> np.ndarray:
    """``Q_l(r) = (kappa / 2 pi^2) (2l + 1) int_0^inf exp(-c rho) i_l(kappa r<) k_l(kappa r>) drho``
    (r (R,), scalars c, kappa; orders (L,)), (R, L): composite Gauss-Legendre
    on panels of ``rho / r`` dense at ``rho = r``, where ``e^{-kappa R} / 4 pi R``'s
    moments peak, and a last panel to where ``exp(-c rho)`` is below 1e-12."""
    x, w = np.polynomial.legendre.leggauss(12)
    r = np.asarray(r, dtype=float)[:, None]
    edges = [e * r for e in _PANELS] + [r * _PANELS[-1] + 28.0 / max(c, 1e-3)]
    out = np.zeros((r.shape[0], len(orders)))
    lo_ord = np.asarray(orders, dtype=float)[None, None, :]
    for a, b in zip(edges[:-1], edges[1:]):
        rho = 0.5 * (a + b) + 0.5 * (b - a) * x[None, :]                 # (R, 12)
        wt = 0.5 * (b - a) * w[None, :]
        small, big = np.minimum(rho, r), np.maximum(rho, r)
        ik = _ik(lo_ord, kappa * small[..., None], kappa * big[..., None])   # (R, 12, L)
        out += np.einsum("rq,rql->rl", wt * np.exp(-c * rho), ik)
    return out * kappa / (2.0 * np.pi ** 2) * (2.0 * np.asarray(orders) + 1.0)[None, :]


def profile_moments(lamp, orders) -> np.ndarray:
    """``f_l = 2 pi int_{-1}^{1} f(mu) P_l(mu) dmu`` of a lamp's profile about its axis, (L,)."""
    alpha = np.linspace(0.0, np.pi, 8193)
    mu = np.cos(alpha)
    f = lamp.relative_intensity(alpha) * np.sin(alpha)
    out = []
    for order in orders:
        y = f * np.polynomial.legendre.Legendre.basis(order)(mu)
        out.append(2.0 * np.pi * np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(alpha)))
    return np.asarray(out)


def spot_factor(inp, distances, angles=None, moments=None) -> np.ndarray:
    """How much more (or less) glow a spot lamp makes than the point source of
    its power: ``A(r, alpha) = phi_spot / (iso_fraction phi)`` per band, (n, R, A), at
    ``distances`` (R,) and angles from its axis ``angles`` (A,) (default
    :data:`SPOT_ANGLES` over [0, pi]).

    The diffusion source is the spot's own first scattering, ``b* I0 f(alpha)
    exp(-c rho) / rho^2``; expanding the Green function in Legendre polynomials
    (``exp(-kappa R) / 4 pi R = (kappa / 2 pi^2) sum (2l+1) i_l(kappa r<) k_l(kappa r>)
    P_l(cos gamma)``) and the profile in its moments ``f_l`` (Funk-Hecke),

        phi_spot(r, alpha) = (b* I0 / D) sum_l f_l Q_l(r) P_l(cos alpha) s_l

    (:func:`_radial_moments`), up to :data:`SPOT_ORDERS` with Lanczos' factors
    ``s_l = sinc(l / (L + 1))`` against ringing at the beam's edge; ``l = 0`` is
    the point source of the same power. A point lamp's factor is 1.
    ``moments``: :func:`profile_moments` of the lamp, if already made."""
    angles = np.linspace(0.0, np.pi, SPOT_ANGLES) if angles is None else np.asarray(angles)
    r = np.maximum(np.asarray(distances, dtype=float), MIN_HALO_RANGE_M)
    orders = np.arange(SPOT_ORDERS + 1)
    fl = profile_moments(inp.lamp, orders) if moments is None else np.asarray(moments)
    if np.allclose(fl[1:], 0.0, atol=1e-9 * fl[0]):
        return np.ones((np.asarray(inp.b).size, r.size, angles.size))
    sigma = np.sinc(orders / (SPOT_ORDERS + 1.0))
    pl = np.stack([np.polynomial.legendre.Legendre.basis(o)(np.cos(angles)) for o in orders])
    _, bs, _, d, kappa = reduced_medium(inp.b, inp.c_lamp, inp.forward_share,
                                        phase_asymmetry(inp.log_phase))
    c = np.asarray(inp.c_lamp, dtype=float)
    out = []
    for i in range(c.size):
        q = _radial_moments(r, c[i], max(kappa[i], 1e-3), orders)             # (R, L)
        spot = (q * (fl * sigma)[None, :]) @ pl                               # (R, A)
        out.append(np.maximum(spot / (q[:, :1] * fl[0]), 0.0))
    return np.stack(out)
