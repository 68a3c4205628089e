"""Froxels: the sun's single scattering integrated once per column of pixels.

The renderer does not march each pixel's ray (the march,
:func:`aquaspec.transport.sun_scattering.single_scattering_marched`, is the
reference it is measured against): the
image is cut into square columns of :func:`froxel_tile` pixels a side
(:data:`FROXEL_TILE` per :data:`FROXEL_TILE_WIDTH` pixels of width, so the
columns keep their angle as the image grows),
each column's central ray is integrated front to back over
:data:`FROXEL_SLICES` slices (:func:`froxel_grid`), and each pixel reads its
column and its neighbours' at its own ray length as a share of its own march
length (:func:`froxel_lookup`: one trilinear sample on the GPU). The
phase function is divided by the bands' mean at the column's angle
(:func:`aquaspec.transport.sun_scattering.band_mean_log_phase`) and each pixel
multiplies it back at its own angle, so the forward peak follows the pixel.
Under waves the caustic factor is the mean of :data:`CAUSTIC_SUBSAMPLES` reads
along each slice (:func:`froxel_caustics`), each band's
(:func:`aquaspec.light.caustics.band_factor`) at the slice's middle depth.
The GPU twin is the froxel pass of :mod:`aquaspec.gpu.passes.sun`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.light import caustics
from aquaspec.numerics import decay_integral
from aquaspec.scene.camera import camera_depth
from aquaspec.transport.sun_scattering import (TAIL, SunInputs, band_mean_phase_at, march_length,
                                               phase_from_log_table)

#: Froxels: columns of ``FROXEL_TILE`` x ``FROXEL_TILE`` pixels per
#: ``FROXEL_TILE_WIDTH`` pixels of image width (:func:`froxel_tile`),
#: ``FROXEL_SLICES`` slices deep.
FROXEL_TILE = 8
FROXEL_TILE_WIDTH = 640
FROXEL_SLICES = 64
#: Caustic reads per froxel slice, spread evenly along it (each filtered over
#: its share of the slice).
CAUSTIC_SUBSAMPLES = 2


def froxel_tile(width: int) -> int:
    """The side of a froxel column in pixels for an image ``width`` pixels wide:
    :data:`FROXEL_TILE` up to :data:`FROXEL_TILE_WIDTH` pixels, then that many
    per ``FROXEL_TILE_WIDTH`` (16 at 1280, 24 at 1920): at least 80 columns
    across, each no wider than 8 pixels of a 640-pixel image. (The froxels'
    error against each pixel's march depends on the columns' angle: 16-pixel
    columns at 320x180 measured as 8-pixel ones at 160x90.)"""
    return FROXEL_TILE * max(1, -(-int(width) // FROXEL_TILE_WIDTH))


def caustic_foot_speed(v, to_sun) -> np.ndarray:
    """How fast a ray ``x(t) = o + t v`` (..., 3) moves in caustic foot
    coordinates (:func:`aquaspec.light.caustics.foot`), m per m along the ray."""
    v = np.asarray(v, dtype=float)
    s = np.asarray(to_sun, dtype=float)
    dx = v[..., 0] - v[..., 1] / s[1] * s[0]
    dz = v[..., 2] - v[..., 1] / s[1] * s[2]
    return np.hypot(dx, dz)


def froxel_caustics(camera, cmap: caustics.CausticMap, dirs, t_a, t_b, *,
                    tile: int | None = None, n_sub: int = CAUSTIC_SUBSAMPLES) -> np.ndarray:
    """The mean caustic factor over each froxel slice [t_a, t_b] of the rays
    ``dirs`` (..., 3): :data:`CAUSTIC_SUBSAMPLES` reads at the middles of equal
    parts, each averaged over the larger of the column's width
    (``tile t / fx``, ``tile`` by default :func:`froxel_tile`) and its part's
    length in foot coordinates."""
    tile = froxel_tile(camera.width) if tile is None else tile
    speed = caustic_foot_speed(dirs, cmap.to_sun)[..., None]
    dt = t_b - t_a
    out = np.zeros(np.shape(t_a))
    for j in range(n_sub):
        t = t_a + (j + 0.5) / n_sub * dt
        fp = np.maximum(tile * t / camera.fx, speed * dt / n_sub)
        out += caustics.sample(cmap, camera.position + dirs[..., None, :] * t[..., None], fp)
    return out / n_sub


def column_directions(camera, tile: int | None = None) -> np.ndarray:
    """Unit rays through the centres of the froxel columns' tiles, (ch, cw, 3):
    column ``(b, a)`` covers pixels ``tile a ... tile a + tile - 1`` (and rows
    alike); its ray goes through pixel coordinates ``(tile a + tile/2, tile b + tile/2)``
    (``tile`` by default :func:`froxel_tile`)."""
    tile = froxel_tile(camera.width) if tile is None else tile
    cw, ch = -(-camera.width // tile), -(-camera.height // tile)
    px = tile * np.arange(cw) + tile / 2.0
    py = tile * np.arange(ch) + tile / 2.0
    x = ((px - camera.cx) / camera.fx)[None, :, None]
    y = ((py - camera.cy) / camera.fy)[:, None, None]
    d = camera.right * x - camera.true_up * y + camera.forward
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


@dataclass(frozen=True)
class FroxelGrid:
    """The froxels of one frame (:func:`froxel_grid`): ``length`` (ch, cw), each
    column's march length, m; ``cum`` (ch, cw, K + 1, n), the single scattering
    accumulated up to each slice boundary, before the pixel's own phase factor."""

    length: np.ndarray
    cum: np.ndarray


def froxel_grid(camera, sun: SunInputs, visibility=None, *, tile: int | None = None,
                slices: int = FROXEL_SLICES, tail: float = TAIL) -> FroxelGrid:
    """The beam's single scattering integrated front to back along each froxel column.

    Column rays ``v`` (:func:`column_directions`); slice boundaries
    ``t_k = L (k / K)^2``, ``k = 0 ... K``, with ``L`` the column's march
    length (:func:`aquaspec.transport.sun_scattering.march_length` of an
    open-water ray); ``V`` at each slice's middle (``visibility(points)`` ->
    (...), or 1). Per band, with the
    phase function divided by the bands' mean at the column's angle:

        cum_k = sum_{m <= k} b beam0 exp(-c_sun d_o / mu0) p / p_ref
                V_m int_{t_{m-1}}^{t_m} exp(-k_band t) dt

    Returns the :class:`FroxelGrid` (``cum[..., 0, :] = 0``). ``tile``: by
    default :func:`froxel_tile`.
    """
    tile = froxel_tile(camera.width) if tile is None else tile
    d_o = camera_depth(camera)
    dirs = column_directions(camera, tile)
    mu0 = sun.mu0
    v_y = dirs[..., 1]
    length = march_length(sun.c_sun, sun.c_view, np.full(v_y.shape, d_o), v_y,
                          np.full(v_y.shape, np.inf), mu0, tail)
    frac = (np.arange(slices + 1) / slices) ** 2
    t = length[..., None] * frac                                        # (ch, cw, K+1)
    t_a, t_b = t[..., :-1], t[..., 1:]
    dt = t_b - t_a
    if visibility is None:
        vis = np.ones(t_a.shape)
    else:
        vis = visibility(camera.position + dirs[..., None, :] * (0.5 * (t_a + t_b))[..., None])
    vis = vis[..., None]
    if sun.caustics is not None:        # each band's at the slice's middle depth
        fc = froxel_caustics(camera, sun.caustics, dirs, t_a, t_b, tile=tile)
        mid = -(camera.position[1] + dirs[..., 1:2] * (0.5 * (t_a + t_b)))
        vis = vis * caustics.band_factor(sun.caustics, fc, mid)
    k = np.asarray(sun.c_view) - np.asarray(sun.c_sun) * v_y[..., None] / mu0   # (ch, cw, n)
    kk = k[..., None, :]
    seg = np.exp(-kk * t_a[..., None]) * decay_integral(kk, dt[..., None])   # (ch, cw, K, n)
    cos = dirs @ sun.to_sun
    p = phase_from_log_table(sun.log_phase, cos)                             # (ch, cw, n)
    ref = band_mean_phase_at(sun.log_phase, cos)
    start = (np.asarray(sun.b) * np.asarray(sun.beam0) * np.exp(-np.asarray(sun.c_sun) * d_o / mu0)
             * p / ref[..., None])
    inc = start[..., None, :] * vis * seg
    cum = np.concatenate([np.zeros(inc.shape[:2] + (1, inc.shape[-1])),
                          np.cumsum(inc, axis=2)], axis=2)
    return FroxelGrid(length, cum)


def pixel_lengths(camera, sun: SunInputs, *, tail: float = TAIL) -> np.ndarray:
    """Each pixel's own march length of open water, (H, W), m
    (:func:`aquaspec.transport.sun_scattering.march_length`, as the columns'):
    where :func:`froxel_lookup` reads the froxels' slices from."""
    v_y = camera.ray_directions().astype(float)[..., 1]
    return march_length(sun.c_sun, sun.c_view, np.full(v_y.shape, camera_depth(camera)), v_y,
                        np.full(v_y.shape, np.inf), sun.mu0, tail)


def froxel_lookup(grid: FroxelGrid, camera, s, pixel_length, *,
                  tile: int | None = None) -> np.ndarray:
    """Each pixel's single scattering from the froxels, (H, W, n) before the
    pixel's own phase factor: bilinear between the four nearest columns (their
    weights clamped at the image's border), each read linearly between slice
    boundaries at the pixel's own ``w = sqrt(min(S, L_px) / L_px)`` (slices are
    uniform in ``sqrt(t / L)`` of each column's own ``L``; 0 where
    ``L_px = 0``): the trilinear sample of a 3-D texture, as the GPU reads it.
    ``s`` (H, W): the pixel's ray length (inf: open water); ``pixel_length``
    (H, W): its own march length (:func:`pixel_lengths`); ``tile`` as the
    grid's (by default :func:`froxel_tile`)."""
    tile = froxel_tile(camera.width) if tile is None else tile
    length, cum = grid.length, grid.cum
    ch, cw = length.shape
    slices = cum.shape[2] - 1
    hgt, wid = camera.height, camera.width

    def axis(n_px, n_col):
        u = (np.arange(n_px) + 0.5 - tile / 2.0) / tile
        a0 = np.clip(np.floor(u), 0, n_col - 1).astype(np.int64)
        a1 = np.minimum(a0 + 1, n_col - 1)
        f = np.clip(u - a0, 0.0, 1.0)
        return a0, a1, f

    a0, a1, fu = axis(wid, cw)
    b0, b1, fv = axis(hgt, ch)
    lp = np.asarray(pixel_length, dtype=float)
    s = np.asarray(s, dtype=float)
    empty = lp <= 0                          # a camera at the surface, looking up
    ll = np.where(empty, 1.0, lp)
    x = np.where(empty, 0.0, np.sqrt(np.minimum(s, ll) / ll) * slices)
    k0 = np.minimum(np.floor(x), slices - 1).astype(np.int64)
    f = (x - k0)[..., None]
    out = np.zeros((hgt, wid, cum.shape[-1]))
    for bi, wv in ((b0, 1.0 - fv), (b1, fv)):
        for ai, wu in ((a0, 1.0 - fu), (a1, fu)):
            bb, aa = np.broadcast_arrays(bi[:, None], ai[None, :])
            lo, hi = cum[bb, aa, k0], cum[bb, aa, k0 + 1]                # (H, W, n)
            out += (wv[:, None] * wu[None, :])[..., None] * ((1.0 - f) * lo + f * hi)
    return out


def froxel_description(width: int | None = None) -> str:
    """The froxels in words (for a render's or a benchmark's metadata)."""
    tile = (f"{froxel_tile(width)}x{froxel_tile(width)} pixels" if width is not None else
            f"{FROXEL_TILE}x{FROXEL_TILE} pixels per {FROXEL_TILE_WIDTH} pixels of width")
    return f"froxels of {tile}, {FROXEL_SLICES} slices"
