"""Numerical building blocks shared by the physics: each written once here.

Nothing in this module knows about water, light or cameras; it imports only
NumPy and :mod:`aquaspec.errors`.
"""

from __future__ import annotations

import numpy as np

#: Below this ``|k L|`` the integral of :func:`decay_integral` is taken as ``L``.
DECAY_SMALL = 1e-8


def decay_integral(k, length, small: float = DECAY_SMALL):
    """``int_0^L exp(-k t) dt``, elementwise (arrays broadcast).

    In closed form ``(1 - e^-x) / k = L (1 - e^-x) / x`` with ``x = k L``,
    computed as ``-expm1(-x) / k`` (no cancellation for small ``x``) and taken
    as ``L`` where ``|x| < small`` (the limit at ``k = 0``; relative error
    ``|x| / 2``). ``small=0`` keeps the closed form wherever ``k != 0``
    (the caller then keeps ``k`` away from 0).
    Valid for either sign of ``k``; the caller keeps ``-x`` small enough not
    to overflow (for ``k < 0`` in log space, see :func:`log_exprel`).
    """
    k = np.asarray(k, dtype=float)
    length = np.asarray(length, dtype=float)
    x = k * length
    tiny = np.abs(x) < small
    return np.where(tiny, length, -np.expm1(-x) / np.where(tiny, 1.0, k))


def log_exprel(y):
    """``log((e^y - 1) / y)`` for ``y >= 0``, without overflow (``y / 2`` near 0).

    The logarithm of :func:`decay_integral`'s ``(1 - e^-x) / x`` at ``x = -y``:
    the growing exponential's integral, to be combined with a decaying factor
    in log space.
    """
    y = np.asarray(y, dtype=float)
    small = y < DECAY_SMALL
    safe = np.where(small, 1.0, y)
    big = np.where(safe > 1.0, safe + np.log1p(-np.exp(-safe)) - np.log(safe),
                   np.log(np.expm1(np.minimum(safe, 1.0)) / np.minimum(safe, 1.0)))
    return np.where(small, 0.5 * y, big)


# ---- bilinear lookups ------------------------------------------------------
# A GPU sampler's linear filtering, in NumPy: every table and image lookup of
# the models goes through these (the light field's tables, the water table, the
# shadow's phase tables, the cone spread's pyramid).


def bilinear_blend(v00, v01, v10, v11, fx, fy):
    """``(1 - fx) ((1 - fy) v00 + fy v01) + fx ((1 - fy) v10 + fy v11)``.

    The four texels ``v[i + di, j + dj]`` around a point and its weights
    ``fx`` (along the first index) and ``fy`` (along the second), in this
    order of operations (the tables' NumPy twins rely on it to the last bit).
    """
    return (1 - fx) * ((1 - fy) * v00 + fy * v01) + fx * ((1 - fy) * v10 + fy * v11)


def clamped_cell(x, n: int):
    """Lower texel ``i`` in ``[0, n - 2]`` and weight ``f`` in ``[0, 1]`` of the
    fractional index ``x`` on an axis of ``n >= 2`` texels (clamped to the edge)."""
    i = np.clip(np.floor(x).astype(int), 0, n - 2)
    return i, np.clip(x - i, 0.0, 1.0)


def repeat_cell(x, n: int):
    """Texels ``i0``, ``i1 = i0 + 1`` (wrapped onto ``[0, n)``) and weight ``f``
    in ``[0, 1)`` of the fractional index ``x`` on a repeating axis of ``n`` texels."""
    i = np.floor(x)
    f = x - i
    i0 = i.astype(np.int64) % n
    return i0, (i0 + 1) % n, f


def bilinear(table, x, y) -> np.ndarray:
    """Bilinear values of ``table`` (X, Y, ...) at fractional indices ``x``
    (first axis) and ``y`` (second), clamped to the edges: shape
    ``broadcast(x, y).shape + table.shape[2:]``."""
    table = np.asarray(table)
    nx, ny = table.shape[:2]
    i, fx = clamped_cell(np.asarray(x), nx)
    j, fy = clamped_cell(np.asarray(y), ny)
    rest = table.shape[2:]
    fx = fx.reshape(fx.shape + (1,) * len(rest))
    fy = fy.reshape(fy.shape + (1,) * len(rest))
    flat = table.reshape(nx * ny, -1)
    k = i * ny + j                                              # (flat indices: np.take)

    def at(kk):
        return np.take(flat, kk, axis=0).reshape(kk.shape + rest)
    return bilinear_blend(at(k), at(k + 1), at(k + ny), at(k + ny + 1), fx, fy)


def bilinear_grid(image, rows, cols) -> np.ndarray:
    """Bilinear values of ``image`` (h, w, ...) on the grid of index coordinates
    ``rows`` (along axis 0) x ``cols`` (axis 1), clamped to the edge: a GPU
    sampler's linear filtering at ``(c + 0.5) / size``. Separable (one axis,
    then the other), so cheaper than :func:`bilinear` on a grid but not
    equal to it in the last bit."""
    out = np.asarray(image, dtype=float)
    for ax, c in ((0, rows), (1, cols)):
        m = out.shape[ax]
        c = np.clip(np.asarray(c, dtype=float), 0.0, m - 1.0)
        i0 = np.floor(c).astype(int)
        i1 = np.minimum(i0 + 1, m - 1)
        f = (c - i0).reshape([c.size if k == ax else 1 for k in range(out.ndim)])
        out = np.take(out, i0, axis=ax) * (1.0 - f) + np.take(out, i1, axis=ax) * f
    return out


def legendre_table(lmax: int, x):
    """``P_l(x)`` for ``l = 0..lmax``: shape ``(lmax + 1,) + x.shape``."""
    x = np.asarray(x, dtype=float)
    out = np.empty((lmax + 1,) + x.shape)
    out[0] = 1.0
    if lmax >= 1:
        out[1] = x
    for l in range(1, lmax):
        out[l + 1] = ((2 * l + 1) * x * out[l] - l * out[l - 1]) / (l + 1)
    return out
