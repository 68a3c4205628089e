"""The analytic underwater light model in NumPy (float64): the reference.

This module is the oracle the GPU passes are tested against. Everything is
vectorised: arrays broadcast against each other, with the band axis last.
Its WGSL twin is ``gpu/wgsl/common.wgsl``: the same formulas, rearranged for
speed (per-frame factors precomputed on the host, branches turned into
selects, four pixels per invocation) and held to this module by
``tests/gpu/passes/test_deferred_pass.py``; the G-buffer-level reference built on it is
:mod:`aquaspec.shading.shade`.

Conventions (also in ``docs`` of every function below)
------------------------------------------------------
- World units are metres, y is up, the water surface is the plane y = 0 and
  the depth of a point p is ``d(p) = -p.y`` (>= 0 under water).
- Coefficients are in 1/m: absorption ``a``, scattering ``b``, extinction
  ``c = a + b``, downwelling diffuse attenuation ``Kd``.
- A camera ray starts at depth ``d_o`` with unit direction ``v`` (camera into
  the scene; ``v_y`` its up component) and hits the first surface at distance
  ``S`` (``inf`` for open water). Rays going up end at the water surface:
  ``S <= d_o / v_y``.

Radiance reaching the camera, per wavelength band::

    L = T(S) * L_surf + L_MS,      T(S) = exp(-c S)

References
----------
.. [Monzon2022] N. Monzon, "Real-time underwater spectral rendering", master
   thesis, Universidad de Zaragoza, 2022, Eqs. 4.1-4.8.
.. [Monzon2022p] N. Monzon, D. Gutierrez, D. Akkaynak, A. Munoz, Eurographics
   2022 poster, Eq. 4.
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import surface_from_below
from aquaspec.numerics import decay_integral, log_exprel

_FOUR_PI = 4.0 * np.pi


def ray_length(s, depth_o, v_y):
    """Length of a camera ray under water.

    Rays going up (``v_y > 0``) end at the water surface, at distance
    ``d_o / v_y``; ``s`` may be ``inf`` (open water).
    """
    s = np.asarray(s, dtype=float)
    depth_o = np.asarray(depth_o, dtype=float)
    v_y = np.asarray(v_y, dtype=float)
    up = v_y > 0
    with np.errstate(over="ignore"):  # a grazing up-ray reaches the surface at inf
        to_surface = np.where(up, depth_o / np.where(up, v_y, 1.0), np.inf)
    return np.minimum(s, to_surface)


def hit_before_surface(s, v_y, depth_o):
    """Which hits count: a finite distance ``s`` the ray (up component ``v_y``)
    reaches before the water surface (camera depth ``depth_o``)."""
    to_surface = np.where(v_y > 0, depth_o / np.where(v_y > 0, v_y, 1.0), np.inf)
    return np.isfinite(s) & (s <= to_surface)


def transmittance(c, s):
    """Beer-Lambert transmittance ``exp(-c s)`` (0 for ``s = inf``)."""
    return np.exp(-np.asarray(c, dtype=float) * np.asarray(s, dtype=float))


def ms_path_integral(c, kd, depth_o, v_y, s):
    """``int_0^S exp(-c t) exp(-Kd d(t)) dt`` with ``d(t) = d_o - t v_y``.

    This is the factor of the seeds' multiple-scattering term that depends on
    the ray. Closed form ``exp(-Kd d_o) (1 - exp(-k S)) / k`` with
    ``k = c - Kd v_y``, evaluated stably for ``k -> 0`` (limit ``S``),
    ``k < 0`` (clear water looking up, no overflow) and ``S = inf`` (needs
    ``k > 0``; up-looking rays are first cut at the water surface).

    Per-ray arrays and per-band arrays broadcast as NumPy does: give per-ray
    quantities a trailing axis of length 1 to combine them with band arrays.
    ``c, kd`` in 1/m, ``depth_o`` in m (>= 0),
    ``v_y`` in [-1, 1], ``s`` in m (>= 0, may be inf).
    """
    c = np.asarray(c, dtype=float)
    kd = np.asarray(kd, dtype=float)
    depth_o = np.asarray(depth_o, dtype=float)
    v_y = np.asarray(v_y, dtype=float)
    s = ray_length(s, depth_o, v_y)
    k = c - kd * v_y
    finite = np.isfinite(s)
    s_f = np.where(finite, s, 0.0)
    with np.errstate(over="ignore"):  # k S may overflow for grazing up-rays: x = inf is fine
        x = k * s_f
    base = -kd * depth_o
    # x >= 0: exp(-Kd d_o) * (1 - e^-x) / k, i.e. S (1 - e^-x) / x, which is S at k = 0.
    k_safe = np.where(k > 0, k, 1.0)
    with np.errstate(over="ignore"):
        finite_part = np.exp(base) * np.where(k > 0, decay_integral(k_safe, s_f, small=0.0), s_f)
    # x < 0: exp(-Kd d_o) * S * (e^y - 1)/y with y = -x; the exponent
    # -Kd d_o + y = -Kd d(S) - c S stays <= 0 for rays that stay under water.
    # (Evaluated only there: few rays, and most of the cost when done everywhere.)
    neg = x < 0
    if np.any(neg):
        shape = finite_part.shape
        finite_part = np.asarray(finite_part)    # (a writable array also for 0-d input)
        finite_part[neg] = np.broadcast_to(s_f, shape)[neg] * np.exp(
            np.broadcast_to(base, shape)[neg] + log_exprel(-np.broadcast_to(x, shape)[neg]))
    k_pos = np.where(k > 0, k, 1.0)
    infinite_part = np.where(k > 0, np.exp(base) / k_pos, np.inf)
    return np.where(finite, finite_part, infinite_part)


def l_ms_seeds(b, c, kd, e0, depth_o, v_y, s):
    """Multiple-scattering radiance of the seeds (thesis Eq. 4.7).

    ``L_MS = b E0 / (4 pi) * exp(-Kd d_o) (1 - exp(-k S)) / k``,
    ``k = c - Kd v_y``, from the in-scattering ``j(d) = b / (4 pi) E0 exp(-Kd d)``
    of an isotropic medium lit by the downwelling irradiance ``E0 exp(-Kd d)``
    taken as if it arrived equally from all directions.

    ``e0`` is the downwelling irradiance just below the surface (W m^-2 nm^-1);
    the result is radiance in W m^-2 sr^-1 nm^-1.
    """
    return (np.asarray(b, dtype=float) * np.asarray(e0, dtype=float) / _FOUR_PI
            * ms_path_integral(c, kd, depth_o, v_y, s))


def downwelling_irradiance(e0, kd, depth):
    """``E_d(d) = E0 exp(-Kd d)`` (thesis Eq. 4.1), ``depth`` in m (>= 0)."""
    return np.asarray(e0, dtype=float) * np.exp(-np.asarray(kd, dtype=float)
                                               * np.asarray(depth, dtype=float))


#: Models of the ambient irradiance on a surface of normal n at depth d.
AMBIENT_MODELS = {
    # Thesis Eq. 4.2: the diffuse light is the same from every direction, so
    # every surface receives E_d(d) whatever its orientation.
    "uniform": lambda n_y: np.ones_like(n_y),
    # A surface sees the fraction (1 + n_y)/2 of a sphere of directions that
    # lies in the upper hemisphere; weighting E_d by it lights an upward face
    # fully, a vertical face half and a downward face not at all.
    "cosine": lambda n_y: 0.5 * (1.0 + n_y),
}
DEFAULT_AMBIENT = "cosine"


def ambient_irradiance(e0, kd, depth, n_y, model: str = DEFAULT_AMBIENT):
    """Irradiance on a surface at ``depth`` with unit normal of up component ``n_y``.

    ``E(d, n) = E_d(d) * g(n_y)`` with ``g`` from :data:`AMBIENT_MODELS`:
    ``"uniform"`` (thesis Eq. 4.2, g = 1) or ``"cosine"`` (g = (1 + n_y)/2,
    the default). The path-tracer validation decides between them.
    """
    try:
        g = AMBIENT_MODELS[model]
    except KeyError:
        raise AquaspecError(f"unknown ambient model {model!r}; known: "
                            f"{', '.join(AMBIENT_MODELS)}") from None
    n_y = np.clip(np.asarray(n_y, dtype=float), -1.0, 1.0)
    return downwelling_irradiance(e0, kd, depth) * g(n_y)


def lambertian_radiance(rho, irradiance):
    """Radiance leaving a Lambertian surface of reflectance ``rho``: ``rho E / pi``."""
    return np.asarray(rho, dtype=float) * np.asarray(irradiance, dtype=float) / np.pi


def pixel_radiance(*, a, b, kd, e0, depth_o, v_y, s, rho=None, surface_depth=None,
                   n_y=None, ambient: str = DEFAULT_AMBIENT):
    """Band radiance reaching the camera along one or many rays.

    ``L = T(S) L_surf + L_MS``. When ``rho`` is None (open water) the ray
    ends at infinity, or at the water surface when it goes up, where the sky
    is seen through Snell's window. Otherwise the ray hits a Lambertian
    surface of reflectance ``rho`` at ``surface_depth`` with normal ``n_y``,
    lit by :func:`ambient_irradiance`.
    """
    c = np.asarray(a, dtype=float) + np.asarray(b, dtype=float)
    s_eff = ray_length(s, depth_o, v_y)
    l_ms = l_ms_seeds(b, c, kd, e0, depth_o, v_y, s_eff)
    if rho is None:
        v = np.asarray(v_y, dtype=float)
        hits_surface = np.isfinite(s_eff) & (v > 0)
        l_surf = np.where(hits_surface, surface_from_below(e0, v), 0.0)
    else:
        l_surf = lambertian_radiance(
            rho, ambient_irradiance(e0, kd, surface_depth, n_y, ambient))
    t = transmittance(c, s_eff)
    return np.where(t > 0, t * l_surf, 0.0) + l_ms
