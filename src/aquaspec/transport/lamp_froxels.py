"""A lamp's single scattering integrated once per column of pixels (NumPy twin of the GPU's).

Conventions as in :mod:`aquaspec.transport.lamp_scattering`: metres, y up,
the water surface at y = 0, radiance in W m^-2 sr^-1 nm^-1 per band.

The per-pixel march (:func:`aquaspec.transport.lamp_scattering.single_scattering`,
the reference) costs a shadow lookup and a band loop at each of its samples
for every pixel. Here, as for the sun (:mod:`aquaspec.transport.froxels`),
the image is cut into square columns of :func:`lamp_tile` pixels a side, and
each column's central ray is integrated once, front to back:

- the column ray ``v`` is cut to the lamp's cone over its open-water length
  (up to the water surface going up, to infinity otherwise;
  :func:`aquaspec.transport.lamp_scattering.ray_angles`), which gives its
  range ``[u_a, u_b]`` of the equiangular variable ``u = sqrt(psi / pi)``
  (``psi = pi/2 + theta``, ``t = t* + D tan theta``);
- the range is cut into ``K`` slices equal in ``u`` (:data:`LAMP_SLICES`),
  each sampled at its middle with the lamp's visibility there: the midpoint
  rule of the march with ``K`` samples, so the column's total is the march's
  value on its central ray;
- the lamp's glow (its light scattered more than once, :mod:`aquaspec.transport.lamp_halo`)
  scattered towards the camera is added between the depths below, one
  midpoint each, up to DEPTH_MAX_M or the water surface;
- the sums up to each slice boundary, ``U_k`` (per band), are the column's
  single scattering up to the distances ``t(u_k)``; it is read at the
  :data:`LAMP_DEPTHS` + 1 distances of :func:`depth_boundaries` (0, then
  geometric from a few centimetres to :data:`DEPTH_MAX_M`, then infinity),
  linear in ``u`` between the ``U_k`` (0 before the beam, the total after it):
  ``cum[j]``.

The slices are the march's samples: equal steps of ``u``, equal steps in the
scattering angle for a lamp beside the camera, so they are densest where the
``1/r^2`` peak near the lamp is and none is spent outside the beam; the
column's sum up to any distance is as good as the march's there. A pixel
reads its four columns at its own ray length ``S`` (:func:`depth_coordinate`,
the geometric depths' index, one logarithm shared by every lamp), bilinear
between the columns and linear between depths (:func:`lamp_froxel_lookup`,
the trilinear read of a 3-D texture on the GPU). Rays in the beam's shadow
get the columns' shadows, blurred over a column; a surface a little beyond a
lamp that a ray passes within much less than the depths' spacing (14 % of
the distance) gets the sum's jump there spread over that spacing.

A column is no wider than :data:`LAMP_COLUMN_DEG` degrees at the image
centre, nor than the sun's froxel tile (:func:`aquaspec.transport.froxels.froxel_tile`):
1 pixel for images of a few dozen pixels (there the froxels are the
per-pixel march at the pixel's centre), 16 at 1280x720 with a 60-degree field.
The error against the per-pixel march is stated in docs/model.md (Lamps)
and tested (``tests/transport/test_lamp_froxels.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.scene.camera import camera_depth
from aquaspec.transport import monzon2022 as model
from aquaspec.transport.froxels import column_directions, froxel_tile
from aquaspec.transport.lamp_halo import halo_along_rays
from aquaspec.transport.lamp_depths import (DEPTH_M0, DEPTH_MAX_M, LAMP_DEPTHS,  # noqa: F401
                                            depth_boundaries, depth_coordinate, depth_step)
from aquaspec.transport.lamp_scattering import (LampInputs, cone_interval, equiangular_range,
                                                ray_angles, sample_terms)

#: Slices per column (the march's samples on the column's central ray).
LAMP_SLICES = 32
#: Widest column at the image's centre, degrees.
LAMP_COLUMN_DEG = 1.5


def lamp_tile(camera) -> int:
    """The side of a lamp column in pixels: as many pixels as
    :data:`LAMP_COLUMN_DEG` spans at the image centre, at least 1, at most
    :func:`aquaspec.transport.froxels.froxel_tile` of the width."""
    px = int(np.floor(min(camera.fx, camera.fy) * np.tan(np.radians(LAMP_COLUMN_DEG))))
    return int(np.clip(px, 1, froxel_tile(camera.width)))


def open_lengths(camera, dirs) -> np.ndarray:
    """The open-water length of rays ``dirs`` (..., 3) from the camera, m: to
    the water surface going up, ``inf`` otherwise."""
    v_y = np.asarray(dirs, dtype=float)[..., 1]
    return model.ray_length(np.full(v_y.shape, np.inf), np.full(v_y.shape, camera_depth(camera)),
                            v_y)


@dataclass(frozen=True)
class LampFroxels:
    """One lamp's columns (:func:`lamp_froxel_grid`): ``tile`` pixels a side;
    ``cum`` (ch, cw, LAMP_DEPTHS + 1, n) the single scattering up to each of
    :func:`depth_boundaries` (``cum[..., 0, :] = 0``), W m^-2 sr^-1 nm^-1."""

    tile: int
    cum: np.ndarray


def u_at(t, t_star, dist, t0, t1, ua, ub):
    """``u`` of the points at distances ``t`` (..., J) along rays (...) with
    beam range ``[t0, t1]``: ``ua`` before it, ``ub`` after it."""
    t = np.asarray(t, dtype=float)
    inside = (t > t0[..., None]) & (t < t1[..., None])
    with np.errstate(invalid="ignore"):
        theta = np.arctan2(np.where(inside, t, 0.0) - t_star[..., None], dist[..., None])
    u = np.sqrt(np.clip(theta + 0.5 * np.pi, 0.0, np.pi) / np.pi)
    u = np.where(inside, np.clip(u, ua[..., None], ub[..., None]), u)
    return np.where(t <= t0[..., None], ua[..., None], np.where(inside, u, ub[..., None]))


def lamp_froxel_grid(inp: LampInputs, camera, *, visibility=None, tile: int | None = None,
                     slices: int = LAMP_SLICES, depths: int = LAMP_DEPTHS,
                     phase=None, halo_tables=None) -> LampFroxels:
    """The lamp's single scattering integrated front to back along each column
    and read at :func:`depth_boundaries` (module docstring).
    ``visibility(points (..., 3)) -> (...)``: the lamp's visibility (None: 1);
    ``phase`` as for :func:`sample_terms`; ``tile``: by default :func:`lamp_tile`;
    ``halo_tables``: :func:`aquaspec.transport.lamp_halo.halo_tables` (None: made here)."""
    tile = lamp_tile(camera) if tile is None else int(tile)
    dirs = column_directions(camera, tile)
    shape = dirs.shape[:2]
    v = dirs.reshape(-1, 3)
    length = open_lengths(camera, v)
    lo, hi = cone_interval(camera.position, v, inp.lamp)
    t0, t1 = np.maximum(lo, 0.0), np.minimum(hi, length)
    t_star, dist, ta, tb = ray_angles(camera.position, v, length, inp.lamp)
    ua, du = equiangular_range(ta, tb)
    terms = sample_terms(inp, camera.position, v, t_star, dist, ua, du, slices,
                         visibility=visibility, phase=phase)             # (P, K, n)
    sums = np.concatenate([np.zeros((v.shape[0], 1, terms.shape[-1])),
                           np.cumsum(terms, axis=1)], axis=1)           # (P, K + 1, n)
    uj = u_at(depth_boundaries(depths)[None, :], t_star, dist, t0, t1, ua, ua + du)
    x = np.where(du[:, None] > 0, (uj - ua[:, None]) / np.where(du > 0, du, 1.0)[:, None], 0.0)
    x = np.clip(x, 0.0, 1.0) * slices
    k0 = np.minimum(np.floor(x), slices - 1).astype(np.int64)
    f = (x - k0)[..., None]
    rows = np.arange(v.shape[0])[:, None]
    cum = (1.0 - f) * sums[rows, k0] + f * sums[rows, k0 + 1]
    if inp.halo:
        # The glow scattered towards the camera, one midpoint per depth slice up to
        # DEPTH_MAX_M, cut at the water surface (lamp_halo.halo_along_rays).
        t = depth_boundaries(depths)[:-1]
        t = np.minimum(t[None, :], length[:, None])
        inc = halo_along_rays(inp, camera.position, v, t[:, :-1], t[:, 1:], halo_tables)
        glow = np.concatenate([np.zeros((v.shape[0], 1, inc.shape[-1])),
                               np.cumsum(inc, axis=1)], axis=1)           # (P, J, n)
        cum = cum + np.concatenate([glow, glow[:, -1:]], axis=1)
    return LampFroxels(tile, cum.reshape(shape + cum.shape[1:]))


def lamp_froxel_lookup(grid: LampFroxels, camera, s) -> np.ndarray:
    """Each pixel's single scattering from the lamp's columns, (H, W, n): bilinear
    between the four nearest columns (weights clamped at the image's border),
    linear between depths at the pixel's :func:`depth_coordinate`. ``s`` (H, W):
    the pixel's ray length (``inf``: open water; cut at the water surface here)."""
    tile, cum = grid.tile, grid.cum
    ch, cw, j1 = cum.shape[:3]
    depths = j1 - 1

    def axis(n_px, n_col):
        u = (np.arange(n_px) + 0.5 - tile / 2.0) / tile
        a0 = np.clip(np.floor(u), 0, n_col - 1).astype(np.int64)
        return a0, np.minimum(a0 + 1, n_col - 1), np.clip(u - a0, 0.0, 1.0)

    a0, a1, fu = axis(camera.width, cw)
    b0, b1, fv = axis(camera.height, ch)
    length = open_lengths(camera, camera.ray_directions().astype(float))
    x = depth_coordinate(np.minimum(np.asarray(s, dtype=float), length), depths)
    k0 = np.minimum(np.floor(x), depths - 1).astype(np.int64)
    f = (x - k0)[..., None]
    out = np.zeros((camera.height, camera.width, cum.shape[-1]))
    for bi, wv in ((b0, 1.0 - fv), (b1, fv)):
        for ai, wu in ((a0, 1.0 - fu), (a1, fu)):
            bb, aa = np.broadcast_arrays(bi[:, None], ai[None, :])
            lo, hi = cum[bb, aa, k0], cum[bb, aa, k0 + 1]
            out += (wv[:, None] * wu[None, :])[..., None] * ((1.0 - f) * lo + f * hi)
    return out
