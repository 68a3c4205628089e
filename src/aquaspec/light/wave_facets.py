"""The wind sea's facets where a view ray meets it, and the sun's glitter on them.

Conventions as in :mod:`aquaspec.light.waves` (metres, y up, the mean surface
the plane ``y = 0``, unit directions). A view ray meets the sea at the mean
plane (the waves' heights, tens of centimetres, are left out: they move where
a ray meets the surface by about its height over its slope, and what the ray
sees there changes with the facet's tilt, which is kept). There the wave
tile (:func:`aquaspec.light.waves.surface`, periodic) gives the slopes
``(dh/dx, dh/dz)`` read bilinearly, and the facet's unit normal is
``(-dh/dx, 1, -dh/dz)`` normalised (:meth:`SurfaceFacets.normals`).

The tile carries the waves between its size and its samples; Cox & Munk's
(1954) slope variance beyond them (the short waves, and the waves longer
than the tile), :func:`unresolved_variance`, cannot be drawn facet by facet.
It makes the sun's glitter: each pixel sees many small facets tilted about
the tile's facet with an isotropic Gaussian distribution of slopes of total
variance ``s2`` (Cox & Munk's clean-surface law, a sum of the two components'
variances), and the radiance of the sun mirrored by them is (Cox & Munk
1954, J. Opt. Soc. Am. 44, 838, their Eq. for the glitter radiance)

    L_g = E_sun R(w) p(zeta) / (4 mu_v cos^4 beta),   p(zeta) = exp(-tan^2 beta / s2) / (pi s2)

with ``E_sun`` the sun's irradiance normal to its beam, ``h`` the facet
normal that mirrors the view ray into the sun (``h`` along ``to_sun - v``),
``beta`` its tilt from the tile's facet, ``mu_v`` the view ray's cosine to the
tile's facet and ``R(w)`` the Fresnel reflectance at the angle ``w`` between
the ray and ``h`` (:func:`glitter`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.light.waves import (Waves, long_wave_slope_variance, surface,
                                  unresolved_slope_variance)
from aquaspec.medium.interface import N_WATER, fresnel_transmittance


def unresolved_variance(waves: Waves) -> float:
    """The slope variance a pixel's facets spread over about the tile's
    facet: Cox & Munk's beyond the tile's (short waves) plus the waves
    longer than the tile (module docstring)."""
    return unresolved_slope_variance(waves) + long_wave_slope_variance(waves)


@dataclass(frozen=True)
class SurfaceFacets:
    """The tile's slopes ``(M, M, 2)`` float32 (``dh/dx``, ``dh/dz``; point
    ``[i, j]`` at ``x = j L / M``, ``z = i L / M``), its width ``tile_m`` and
    the unresolved slope variance ``s2``."""

    slopes: np.ndarray
    tile_m: float
    s2: float

    def slopes_at(self, x, z) -> np.ndarray:
        """Slopes ``(..., 2)`` at points ``(x, z)`` on the mean plane, bilinear
        and periodic (as the GPU reads them)."""
        m = self.slopes.shape[0]
        u = np.mod(np.asarray(x, dtype=float) / self.tile_m * m, m)
        w = np.mod(np.asarray(z, dtype=float) / self.tile_m * m, m)
        j0, i0 = np.floor(u).astype(np.int64) % m, np.floor(w).astype(np.int64) % m
        fu, fw = (u - np.floor(u))[..., None], (w - np.floor(w))[..., None]
        j1, i1 = (j0 + 1) % m, (i0 + 1) % m
        s = self.slopes.astype(np.float64)
        top = (1 - fu) * s[i0, j0] + fu * s[i0, j1]
        bottom = (1 - fu) * s[i1, j0] + fu * s[i1, j1]
        return (1 - fw) * top + fw * bottom

    def slopes_for(self, grid: int, tile_m: float) -> np.ndarray:
        """The slopes as a GPU buffer takes them, ``(M * M, 2)`` float32, for a
        pass that holds a sea of ``grid`` samples over ``tile_m`` m (the same
        sea at another instant); an error naming both tiles otherwise."""
        m = self.slopes.shape[0]
        if m != int(grid) or float(self.tile_m) != float(tile_m):
            raise AquaspecError(f"facets of a {m}-sample, {self.tile_m:g} m tile; this pass has "
                                f"the sea of a {int(grid)}-sample, {float(tile_m):g} m tile "
                                "(set_medium for another sea)")
        return np.ascontiguousarray(self.slopes, dtype=np.float32).reshape(-1, 2)

    def normals(self, x, z) -> np.ndarray:
        """Unit facet normals ``(..., 3)`` at points ``(x, z)``."""
        s = self.slopes_at(x, z)
        n = np.stack([-s[..., 0], np.ones(s.shape[:-1]), -s[..., 1]], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)


@functools.lru_cache(maxsize=4)
def surface_facets(waves: Waves) -> SurfaceFacets:
    """The facets of ``waves``' tile at its instant (cached per sea)."""
    _, hx, hz = surface(waves)
    return SurfaceFacets(np.stack([hx, hz], axis=-1).astype(np.float32), float(waves.tile_m),
                         float(unresolved_variance(waves)))


def glitter(v, normals, to_sun, sun_irradiance, s2: float,
            n_water: float = N_WATER) -> np.ndarray:
    """The sun's glitter (module docstring) along view rays ``v`` (R, 3) going
    down, meeting facets of unit ``normals`` (R, 3): (R, n) for the sun's
    normal irradiance ``sun_irradiance`` (n,) in air, towards ``to_sun``.
    Zero where the mirroring facet would face away from the ray or the sun."""
    v = np.asarray(v, dtype=float)
    nr = np.asarray(normals, dtype=float)
    to_sun = np.asarray(to_sun, dtype=float)
    h = to_sun[None, :] - v
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    cos_w = -np.sum(v * h, axis=1)                  # the ray's incidence on h
    cos_b = np.sum(h * nr, axis=1)                  # h's tilt from the tile's facet
    mu_v = -np.sum(v * nr, axis=1)
    ok = (cos_w > 0) & (cos_b > 0) & (mu_v > 0)
    cb = np.where(ok, cos_b, 1.0)
    tan2 = (1.0 - cb * cb) / (cb * cb)
    p = np.exp(-tan2 / s2) / (np.pi * s2)
    r = 1.0 - fresnel_transmittance(np.where(ok, cos_w, 1.0), n_water)
    g = np.where(ok, r * p / (4.0 * np.where(ok, mu_v, 1.0) * cb ** 4), 0.0)
    return g[:, None] * np.asarray(sun_irradiance, dtype=float)[None, :]
