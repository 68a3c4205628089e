"""A photon map on a periodic tile: points splatted bilinearly onto texels,
and the blurs a slice of caustics gets (the sun's disc, a Gaussian), in
Fourier space.

The tile ``L`` metres wide has ``n x n`` texels, texel ``[i, j]`` (row along
z, column along x) centred at ``((j + 1/2), (i + 1/2)) L / n``; in *texel
coordinates* that centre is at ``(j, i)``. :mod:`aquaspec.light.caustics`
builds its maps with these.

The splat (:func:`splat_texels`) costs about four ``np.bincount`` passes per
point set: each point is binned once at its cell's corner with four weights
(its moments ``w``, ``w f_x``, ``w f_z``, ``w f_x f_z``), and the corners'
shares are combined per texel afterwards, which is exact (the bilinear
weights are products of ``1 - f`` and ``f``).
"""

from __future__ import annotations

import numpy as np
import scipy.fft as sfft
from scipy.special import j1

from aquaspec.numerics import repeat_cell


def periodic_cell(u, n: int, tile_m: float):
    """The four texels around foot points ``u`` (..., 2) on ``n x n`` periodic
    texels of a tile (texel ``[i, j]`` centred at ``((j + 1/2), (i + 1/2)) L / n``):
    ``(i0, i1, j0, j1, fz, fx)``, rows along z and columns along x."""
    j0, j1, fx = repeat_cell(np.asarray(u[..., 0]) / tile_m * n - 0.5, n)
    i0, i1, fz = repeat_cell(np.asarray(u[..., 1]) / tile_m * n - 0.5, n)
    return i0, i1, j0, j1, fz, fx


def _wrap(i, n: int):
    """``i mod n``, in place (a power of two: by a mask)."""
    if n & (n - 1) == 0:
        return np.bitwise_and(i, n - 1, out=i)
    return np.mod(i, n, out=i)


def splat_texels(ux, uz, weights, n: int) -> np.ndarray:
    """Bilinear periodic splat of points at texel coordinates ``ux``, ``uz``
    (P,) (texel ``[i, j]`` centred at ``ux = j``, ``uz = i``; float32 or
    float64, the arithmetic is done in that precision) onto ``n x n``
    texels: the summed ``weights`` (P,) per texel, float64.

    Each point is binned once, at its cell's corner ``(i0, j0)`` on a grid
    one texel wider than the tile; the four moments ``sum w``, ``sum w f_x``,
    ``sum w f_z``, ``sum w f_x f_z`` per cell give the four corners' shares,
    added at their offsets, and the extra row and column wrap around.
    """
    fx, fz = np.floor(ux), np.floor(uz)
    base = _wrap(fz.astype(np.intp), n)
    base *= n + 1
    base += _wrap(fx.astype(np.intp), n)
    np.subtract(ux, fx, out=fx)
    np.subtract(uz, fz, out=fz)
    w = np.asarray(weights, dtype=float)
    wx = w * fx
    size = (n + 1) * (n + 1)
    m_1, m_x, m_z, m_xz = (np.bincount(base, weights=v, minlength=size)
                           for v in (w, wx, w * fz, wx * fz))
    grid = m_1 - m_x - m_z + m_xz                      # the corner (i0, j0)
    for shift, share in ((1, m_x - m_xz), (n + 1, m_z - m_xz), (n + 2, m_xz)):
        grid[shift:] += share[:-shift]
    grid = grid.reshape(n + 1, n + 1)
    grid[:, 0] += grid[:, n]
    grid[0, :n] += grid[n, :n]
    return grid[:n, :n]


def splat(u, weights, n: int, tile_m: float) -> np.ndarray:
    """Bilinear periodic splat of points ``u`` (P, 2) (x, z) onto ``n x n``
    texels of a tile (:func:`periodic_cell`'s texels; :func:`splat_texels`):
    the summed weights per texel."""
    u = np.asarray(u, dtype=float)
    return splat_texels(u[:, 0] * (n / tile_m) - 0.5, u[:, 1] * (n / tile_m) - 0.5,
                        weights, n)


def half_wavenumbers(n: int, tile_m: float):
    """``(kx, kz)`` (n, n/2 + 1) of a real FFT of the tile (x the last axis)."""
    kx = 2.0 * np.pi * np.fft.rfftfreq(n, tile_m / n)
    kz = 2.0 * np.pi * np.fft.fftfreq(n, tile_m / n)
    return np.meshgrid(kx, kz)


def _blur_transfer(kx, kz, radii, along, cov):
    """The Fourier transfer (None: none) at ``(kx, kz)`` of a uniform
    ellipse (radii ``(r_along, r_across)`` m, ``along`` the unit (x, z) of
    its first axis: ``2 J1(q) / q``) times a Gaussian of covariance ``cov``
    (2, 2) m^2 (``exp(-k^T cov k / 2)``)."""
    tf = None
    if radii[0] > 0 or radii[1] > 0:
        q = np.hypot((kx * along[0] + kz * along[1]) * radii[0],
                     (kz * along[0] - kx * along[1]) * radii[1])
        qs = np.where(q > 1e-8, q, 1.0)
        tf = np.where(q > 1e-8, 2.0 * j1(qs) / qs, 1.0)
    if cov is not None and np.any(np.asarray(cov) != 0):
        c = np.asarray(cov, dtype=float)
        g = np.exp(-0.5 * (c[0, 0] * kx * kx + 2.0 * c[0, 1] * kx * kz + c[1, 1] * kz * kz))
        tf = g if tf is None else tf * g
    return tf


def disc_blur(slice_, radii, along, tile_m: float, cov=None, *,
              wavenumbers=None) -> np.ndarray:
    """Convolve a periodic slice (n, n) with a uniform ellipse (radii
    ``(r_along, r_across)`` m, ``along`` the unit (x, z) of its first axis)
    and, with ``cov`` (2, 2) m^2, a Gaussian of that covariance (axes x, z).
    ``wavenumbers``: :func:`half_wavenumbers` of the tile, if at hand."""
    n = slice_.shape[0]
    kx, kz = half_wavenumbers(n, tile_m) if wavenumbers is None else wavenumbers
    tf = _blur_transfer(kx, kz, radii, along, cov)
    if tf is None:
        return slice_
    return sfft.irfft2(sfft.rfft2(slice_) * tf, s=slice_.shape)
