"""The forward cone's light spread over the image with an image pyramid (NumPy reference).

In forward-peaked water a camera ray towards a target also receives the
target's light scattered by small angles on the way: light that left the
target at an angular offset ``alpha`` from the pixel's own direction
(:func:`aquaspec.medium.phase_bands.band_cone_offset_cdf`). The light-field model first
gives every pixel its own cone term (``LightfieldTables.pixel_radiance(...,
split_cone=True)``: what the cone adds if the target filled the whole cone);
this module moves it to where it is seen, a convolution of the cone image
with the radially symmetric kernel of ``alpha``
(:func:`aquaspec.transport.lightfield.cone.cone_spread_kernel` is that kernel exactly,
:func:`aquaspec.transport.lightfield.cone.spread_cone_light` the exact convolution).

The kernel reaches tens of degrees (hundreds of pixels) and its mass is
spread over decades of radius, so the renderer convolves with a pyramid
instead, the same on the GPU (``gpu/passes/conespread.wgsl``) and here:

- level 0 is the image; level ``l`` halves level ``l - 1`` (rounding up)
  with the weights ``[1, 3, 3, 1] / 8`` along each axis over the fine pixels
  ``2i - 1 .. 2i + 2`` (indices clamped to the image): centred on the coarse
  pixel, four bilinear samples on the GPU;
- ``U_L = alpha_L P_L``, ``U_l = alpha_l P_l + up(U_{l + 1})`` with ``up`` the
  bilinear interpolation at ``(x + 0.5) / 2 - 0.5`` (clamped to the edge);
- the spread image is ``alpha_0 P_0 + up(U_1)``.

With ``spread_scattering="multiple"`` (NumPy and GPU) the cone's
light is taken as scattered ``N >= 1`` times inside the cone, ``N`` Poisson
with mean ``lambda = f b S`` per band and pixel, the offsets adding as 2-D
vectors (:func:`multiple_scattering_cdf`); kernels are made at the
:data:`LAMBDA_NODES` and each pixel's cone term is split between the two
nearest (:func:`lambda_node_weights`), one pyramid per node
(:func:`spread_by_lambda`). Over 3 m of Jerlov II or 3C most of the cone's
light is scattered more than once, and the single-scattering kernel keeps
too much of a bright target's light on it.

Each level on its own is a bump of width about ``2^l`` pixels; the weights
``alpha_l >= 0`` (summing to 1, so no light is made or lost) are fitted to
the kernel's radial distribution (:func:`fit_weights`). Measured against the
exact convolution on a blocky target: mean error about 1.3 % of the cone
term on the target (``tests/transport/lightfield/test_conespread.py``).
"""

from __future__ import annotations

import sys
from functools import lru_cache
from math import lgamma

import numpy as np

from aquaspec.cache import cached_arrays, code_digest
from aquaspec.errors import AquaspecError
from aquaspec.numerics import bilinear_grid
from aquaspec.transport.lightfield.tables import ConeTables

#: Radius (pixels) of the responses measured per level before the scale law takes over.
_MEASURED_LEVELS = 6


def downsample(x: np.ndarray) -> np.ndarray:
    """One pyramid step: ``(h, w, ...)`` -> ``(ceil(h/2), ceil(w/2), ...)``, weights [1,3,3,1]/8."""
    out = np.asarray(x, dtype=float)
    for ax in (0, 1):
        n = out.shape[ax]
        base = 2 * np.arange((n + 1) // 2)
        acc = 0.0
        for off, wgt in ((-1, 1.0), (0, 3.0), (1, 3.0), (2, 1.0)):
            acc = acc + wgt * np.take(out, np.clip(base + off, 0, n - 1), axis=ax)
        out = acc / 8.0
    return out


def upsample(x: np.ndarray, shape) -> np.ndarray:
    """Bilinear interpolation of a coarse level at the fine pixels of ``shape`` (h, w)."""
    return upsample_by(x, 2, shape)


def upsample_by(x: np.ndarray, factor: int, shape) -> np.ndarray:
    """Bilinear interpolation of a level ``factor`` times coarser at the fine
    pixels of ``shape`` (h, w): coarse index coordinates ``(p + 0.5) / factor - 0.5``
    (clamped), one bilinear sample on the GPU (for ``factor`` 2, :func:`upsample`)."""
    return bilinear_grid(x, (np.arange(shape[0]) + 0.5) / factor - 0.5,
                         (np.arange(shape[1]) + 0.5) / factor - 0.5)


def level_count(height: int, width: int, radius_px: float) -> int:
    """Levels below the image: enough for the kernel's radius, at most until 1 pixel."""
    want = max(1, int(np.ceil(np.log2(max(radius_px, 2.0)))))
    have = max(1, int(np.ceil(np.log2(max(height, width, 2)))))
    return min(want, have)


def level_shapes(height: int, width: int, levels: int) -> list:
    """(h, w) of levels 0 .. levels."""
    shapes = [(int(height), int(width))]
    for _ in range(levels):
        h, w = shapes[-1]
        shapes.append(((h + 1) // 2, (w + 1) // 2))
    return shapes


def spread(image: np.ndarray, weights) -> np.ndarray:
    """The pyramid convolution of ``image`` (h, w, ...) with level weights (levels + 1,)."""
    a = np.asarray(weights, dtype=float)
    img = np.asarray(image, dtype=float)
    levels = a.size - 1
    if levels < 1:
        raise AquaspecError(f"{a.size} pyramid weights; accepted: at least 2")
    pyr = [img]
    for _ in range(levels):
        pyr.append(downsample(pyr[-1]))
    u = a[levels] * pyr[levels]
    for lev in range(levels - 1, 0, -1):
        u = a[lev] * pyr[lev] + upsample(u, pyr[lev].shape)
    return a[0] * img + upsample(u, img.shape[:2])


@lru_cache(maxsize=None)
def _measured_level_cdf(level: int) -> tuple:
    """Radial CDF of level ``level``'s response to a point, averaged over four
    positions in a coarse pixel; radii in pixels at 2^(k/4), k = -4 .. 4 (level + 3).

    The CDF is the response accumulated over pixels sorted by distance
    (ties in row order) and interpolated linearly between them, out to the
    farthest pixel the response reaches (beyond it the CDF is 1). The
    response is computed on a canvas of 2^(level + 3) pixels square, which
    holds it (it reaches 2.5 2^level pixels from the point at most), and
    only the pixels within its reach are sorted.
    """
    size = 2 ** (level + 3)
    radii = 2.0 ** (np.arange(-4, 4 * (level + 3) + 1) / 4.0)
    half = 2 ** max(level - 1, 0)
    w = np.zeros(level + 1)
    w[level] = 1.0
    cdfs = []
    for dy, dx in ((0, 0), (half, 0), (0, half), (half, half)):
        py, px = size // 2 + dy, size // 2 + dx
        img = np.zeros((size, size))
        img[py, px] = 1.0
        k = spread(img, w)
        if k[[0, -1], :].any() or k[:, [0, -1]].any():
            raise AssertionError(f"level {level}'s response reaches the canvas's edge")
        ys, xs = np.nonzero(k)
        reach = np.hypot(ys - py, xs - px).max()
        # Every pixel within the reach, on the canvas or not (off it the
        # response is 0), in row order.
        m = int(np.ceil(reach))
        near = np.pad(k, m)[py:py + 2 * m + 1, px:px + 2 * m + 1]
        oy, ox = np.mgrid[-m:m + 1, -m:m + 1]
        r = np.hypot(oy, ox)
        inside = r <= reach
        r, near = r[inside], near[inside]
        order = np.argsort(r, kind="stable")
        cdfs.append(np.interp(radii, r[order], np.cumsum(near[order]), left=0.0))
    return tuple(radii), tuple(np.mean(cdfs, axis=0))


def level_cdf(level: int, radii_px) -> np.ndarray:
    """Radial CDF of one level's point response at ``radii_px``.

    Level 0 is the identity (all within half a pixel). Levels up to
    :data:`_MEASURED_LEVELS` are measured (:func:`_measured_level_cdf`);
    beyond, a level is the last measured one scaled by ``2^(level - last)``.
    """
    r = np.asarray(radii_px, dtype=float)
    if level == 0:
        return np.where(r >= 0.5, 1.0, 0.0)
    base = min(level, _MEASURED_LEVELS)
    radii, cdf = _measured_level_cdf(base)
    scale = 2.0 ** (level - base)
    return np.interp(r / scale, radii, cdf, left=0.0, right=1.0)


def fit_weights(offsets_rad, cdf, pixels_per_radian: float, levels: int) -> np.ndarray:
    """Level weights (levels + 1,) >= 0 summing to 1 whose pyramid's radial
    distribution matches ``cdf`` (``P(alpha <= offsets_rad)``) turned into
    pixels with ``pixels_per_radian``: non-negative least squares on the CDF
    at radii 2^(k/4) pixels, from half a pixel to beyond the kernel."""
    off = np.asarray(offsets_rad, dtype=float) * float(pixels_per_radian)
    f = np.asarray(cdf, dtype=float)
    if not (pixels_per_radian > 0 and np.all(np.diff(off) > 0)):
        raise AquaspecError(f"pixels_per_radian={pixels_per_radian!r}; accepted: > 0")
    radii = 2.0 ** (np.arange(-4, 4 * (levels + 2) + 1) / 4.0)
    target = np.interp(radii, off, f, left=0.0, right=1.0)
    basis = np.stack([level_cdf(lev, radii) for lev in range(levels + 1)], axis=1)
    heavy = 100.0
    a = nnls(np.vstack([basis, np.full((1, levels + 1), heavy)]),
             np.concatenate([target, [heavy]]))
    return a / a.sum()


def nnls(a, b) -> np.ndarray:
    """``x >= 0`` minimising ``|a x - b|``: Lawson and Hanson's active-set method.

    Lawson & Hanson, Solving Least Squares Problems (1974), ch. 23. Written
    here for the pyramid's few weights so that rendering does not import
    ``scipy.optimize`` (0.3 s); tested against SciPy's ``nnls``.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    n = a.shape[1]
    tol = 10.0 * np.finfo(float).eps * np.abs(a).sum(axis=0).max() * max(a.shape)
    x = np.zeros(n)
    free = np.zeros(n, dtype=bool)       # the passive set: x_j > 0
    for _ in range(3 * n + 1):
        grad = a.T @ (b - a @ x)
        if free.all() or grad[~free].max() <= tol:
            return x
        free[np.argmax(np.where(free, -np.inf, grad))] = True
        while True:
            z = np.zeros(n)
            z[free] = np.linalg.lstsq(a[:, free], b, rcond=None)[0]
            if not free.any() or z[free].min() > 0:
                x = z
                break
            # Back along x -> z until the first weight reaches 0; it leaves.
            out = free & (z <= 0)
            step = np.min(x[out] / (x[out] - z[out]))
            x = x + step * (z - x)
            free &= x > tol
            x[~free] = 0.0
    raise AquaspecError(f"non-negative least squares did not converge for a {a.shape} matrix")


def cone_cdf(cone: ConeTables) -> tuple:
    """One kernel for all bands: ``(offsets_rad, cdf)`` from the cone's tables,
    the bands' CDFs weighted by their cone share ``f b`` (equal for every band
    but with Petzold's water-particle mix)."""
    cdf = np.asarray(cone.offset_cdf, dtype=float)
    wgt = np.asarray(cone.weight, dtype=float)
    wgt = wgt / wgt.sum() if wgt.sum() > 0 else np.full(cdf.shape[0], 1.0 / cdf.shape[0])
    return np.asarray(cone.offset_rad, dtype=float), wgt @ cdf


def pyramid_weights(cone: ConeTables, pixels_per_radian: float, height: int,
                    width: int) -> np.ndarray:
    """The weights the renderer uses for an image of this size and camera
    (levels up to the last with a weight above zero); ``cone``: the light-field
    tables' :attr:`~aquaspec.transport.lightfield.tables.LightfieldTables.cone`."""
    offsets, cdf = cone_cdf(cone)
    levels = level_count(height, width, offsets[-1] * pixels_per_radian)
    w = fit_weights(offsets, cdf, pixels_per_radian, levels)
    # Coarsest levels the fit left at zero would cost work in the pyramid's
    # dispatch for nothing.
    last = max(1, int(np.flatnonzero(w > 0)[-1])) if np.any(w[1:] > 0) else 1
    return w[:last + 1]


#: Mean numbers of scatterings inside the cone, ``lambda = f b S``, that get a
#: kernel of their own: hat functions in ``x = log3(1 + 2 lambda)`` are the
#: nodes ``x = 0 .. 5``. In a prototype on the built-in scene at 320x180
#: (Jerlov IB, II, 3C, S from 2.5 to 120 m), five nodes from 0.25 to 18
#: (geometric) put the spread term within 0.5-2.8 % of the exact per-pixel
#: mixture on average, three nodes within 1.7-3.2 %, one kernel for the whole
#: image 6-24 % off; these nodes start at single scattering (0) and reach the
#: far seabed of turbid water (lambda up to about 100). Not measured
#: against the exact mixture themselves.
LAMBDA_NODES = (0.0, 1.0, 4.0, 13.0, 40.0, 121.0)
#: Offset vectors drawn per node by :func:`multiple_scattering_cdf`.
MULTIPLE_SAMPLES = 100_000


def _lambda_coordinate(lam):
    return np.log1p(2.0 * np.maximum(np.asarray(lam, dtype=float), 0.0)) / np.log(3.0)


def lambda_node_weights(lam, nodes=LAMBDA_NODES) -> np.ndarray:
    """Hat weights ``(len(nodes), *lam.shape)`` of ``lam`` on the nodes
    (linear in ``log3(1 + 2 lambda)``, summing to 1; clamped at the ends)."""
    x = _lambda_coordinate(lam)
    xn = _lambda_coordinate(np.asarray(nodes, dtype=float))
    if xn.size < 2 or np.any(np.diff(xn) <= 0):
        raise AquaspecError(f"lambda nodes {list(nodes)!r}; accepted: at least two, ascending")
    x = np.clip(x, xn[0], xn[-1])
    j = np.clip(np.searchsorted(xn, x, side="right") - 1, 0, xn.size - 2)
    f = (x - xn[j]) / (xn[j + 1] - xn[j])
    out = np.zeros((xn.size,) + x.shape)
    np.put_along_axis(out, j[None], (1.0 - f)[None], axis=0)
    hi = np.take_along_axis(out, (j + 1)[None], axis=0) + f[None]
    np.put_along_axis(out, (j + 1)[None], hi, axis=0)
    return out


def multiple_scattering_cdf(offsets_rad, cdf, lam: float, *, samples: int = MULTIPLE_SAMPLES,
                            seed: int = 0) -> np.ndarray:
    """CDF at ``offsets_rad`` of the apparent offset of light scattered ``N >= 1``
    times inside the cone.

    ``N`` is Poisson with mean ``lam`` given ``N >= 1``; each scattering moves
    the light by an independent 2-D offset, isotropic in azimuth, with radial
    CDF ``cdf`` (at ``offsets_rad``; :func:`aquaspec.medium.phase_bands.band_cone_offset_cdf`),
    and the offsets add as vectors. Monte Carlo with ``samples`` stratified
    single offsets (deterministic for a ``seed``); ``lam = 0`` returns ``cdf``.
    Offsets past the last one count at the last (the CDF ends at 1).
    """
    off = np.asarray(offsets_rad, dtype=float)
    f1 = np.maximum.accumulate(np.clip(np.asarray(cdf, dtype=float), 0.0, 1.0))
    if off.ndim != 1 or off.shape != f1.shape or np.any(np.diff(off) <= 0):
        raise AquaspecError("offsets_rad and cdf must be 1-D, the same length, offsets ascending")
    if not (np.isfinite(lam) and lam >= 0):
        raise AquaspecError(f"lam={lam!r}; accepted: a finite number >= 0")
    if lam == 0:
        return f1.copy()
    # (Cached in the process, as the validation makes the same tables for
    # several band counts, and on disk, as a data set renders the same water
    # image after image: 0.1-0.9 s per node.)
    return _multiple_cdf(off.tobytes(), f1.tobytes(), float(lam), int(samples), int(seed)).copy()


@lru_cache(maxsize=64)
def _multiple_cdf(off_bytes, f1_bytes, lam, samples, seed):
    # (The key holds the code that computes it: a changed module is not
    # answered from an old file; without its source, no file.)
    key = code_digest([sys.modules[__name__]], off_bytes, f1_bytes, lam, samples, seed)
    return cached_arrays("spread-cdf", key, lambda: {"cdf": _multiple_cdf_monte_carlo(
        off_bytes, f1_bytes, lam, samples, seed)})["cdf"]


def _multiple_cdf_monte_carlo(off_bytes, f1_bytes, lam, samples, seed):
    off = np.frombuffer(off_bytes, dtype=float)
    f1 = np.frombuffer(f1_bytes, dtype=float)
    rng = np.random.default_rng(seed)
    u = (np.arange(samples) + 0.5) / samples
    # The CDF's flat steps have many offsets for one value: the inverse takes
    # the first offset where the CDF reaches u.
    idx = np.clip(np.searchsorted(f1, u, side="left"), 1, off.size - 1)
    lo, hi = f1[idx - 1], f1[idx]
    t = np.where(hi > lo, (u - lo) / np.where(hi > lo, hi - lo, 1.0), 1.0)
    r = off[idx - 1] + t * (off[idx] - off[idx - 1])
    phi = 2.0 * np.pi * ((np.arange(samples) * 0.6180339887498949) % 1.0)
    v1 = np.stack([r * np.cos(phi), r * np.sin(phi)], axis=1)
    n_max = int(np.ceil(lam + 8.0 * np.sqrt(lam) + 8.0))
    ns = np.arange(1, n_max + 1)
    log_p = ns * np.log(lam) - lam - np.array([lgamma(k + 1.0) for k in ns])
    p = np.exp(log_p - log_p.max())
    p /= p.sum()
    out = np.zeros(off.size)
    acc = np.zeros_like(v1)
    for k, pk in zip(ns, p):
        acc += v1 if k == 1 else v1[rng.permutation(samples)]
        if pk < 1e-9:
            continue
        # Cumulative counts of r < off_k: j = #(off <= r) is below k + 1
        # exactly when r < off_k (the last, r <= off_K, is set to 1 below).
        j = np.searchsorted(off, np.hypot(acc[:, 0], acc[:, 1]), side="right")
        out += pk * np.cumsum(np.bincount(j, minlength=off.size + 1)[:off.size]) / samples
    out[-1] = 1.0
    return np.minimum(np.maximum.accumulate(out), 1.0)


def node_pyramid_weights(cone: ConeTables, pixels_per_radian: float, height: int,
                         width: int) -> list:
    """Pyramid weights of each lambda node (``cone.offset_cdf_nodes``),
    all with the same number of levels (zeros where a node needs fewer)."""
    offsets = np.asarray(cone.offset_rad, dtype=float)
    cdfs = np.asarray(cone.offset_cdf_nodes, dtype=float)
    levels = level_count(height, width, offsets[-1] * pixels_per_radian)
    return [fit_weights(offsets, c, pixels_per_radian, levels) for c in cdfs]


def spread_by_lambda(cone, lam, nodes, weights) -> np.ndarray:
    """The cone image ``(h, w, n)`` spread with each pixel's and band's kernel:
    ``lam`` (h, w, n) split between the nodes (:func:`lambda_node_weights`),
    one pyramid per node with its ``weights`` (:func:`node_pyramid_weights`)."""
    cone = np.asarray(cone, dtype=float)
    hw = lambda_node_weights(lam, nodes)
    out = np.zeros_like(cone)
    for k, w in enumerate(weights):
        part = cone * hw[k]
        if np.any(part):
            out += spread(part, w)
    return out


# ------------------------------------------------- the renderer's form of it
# The renderer (the GPU and its NumPy twin, aquaspec.transport.lightfield.compiled)
# splits each band's cone term between the nodes as spread_by_lambda does and
# runs one pyramid whose texels hold every node's camera RGB (3 K values):
# the levels are linear, so only the weights at which the levels are summed
# differ by node. (A single pyramid with one lambda coordinate per texel,
# carried down as a weighted mean, was tried first: cone terms carry the
# target's contrast against the water behind it and have both signs, and
# where bands or pixels of opposite sign mix, one kernel for their net light
# was 8-14 % off the node pyramids on the spread term, Jerlov II, built-in
# scene at 96x54, against 1.8 % with a coordinate per band.)


def node_coordinates_are_integers(nodes=LAMBDA_NODES) -> bool:
    """Whether the nodes sit at ``z = 0, 1, 2, ..`` (the renderer's hat weights assume it)."""
    z = _lambda_coordinate(np.asarray(nodes, dtype=float))
    return bool(np.allclose(z, np.arange(z.size), atol=1e-9))


def lambda_coordinate(lam) -> np.ndarray:
    """``z = log3(1 + 2 lambda)``: the nodes :data:`LAMBDA_NODES` are at ``z = 0 .. 5``."""
    return _lambda_coordinate(lam)


def interp_nodes(values, z) -> np.ndarray:
    """Piecewise-linear interpolation of node values ``(..., K)`` (nodes at
    ``z = 0 .. K - 1``) at ``z`` (clamped): shape ``z.shape + values.shape[:-1]``."""
    v = np.asarray(values, dtype=float)
    k = v.shape[-1]
    zz = np.clip(np.asarray(z, dtype=float), 0.0, k - 1.0)
    j = np.minimum(np.floor(zz).astype(int), k - 2)
    f = (zz - j).reshape(zz.shape + (1,) * (v.ndim - 1))
    vv = np.moveaxis(v, -1, 0)                        # (K, ...)
    lo, hi = vv[j], vv[j + 1]                         # z.shape + (...)
    return lo + (hi - lo) * f


def node_level_tables(node_weights, start: int) -> dict:
    """What the renderer needs of the nodes' pyramid weights ``(K, L + 1)``
    (:func:`node_pyramid_weights`) when the pyramid starts at level ``start``:
    ``alpha`` (K,) each node's share below ``start`` (kept by the pixel) and
    ``a`` (K, L + 1 - start) its weights from there (summing to ``1 - alpha``)."""
    w = np.asarray(node_weights, dtype=float)
    if w.ndim != 2 or w.shape[1] < 1 or not 0 <= start < w.shape[1]:
        raise AquaspecError(f"node weights of shape {w.shape} with start level {start}; "
                            "accepted: (nodes, levels + 1) and 0 <= start <= levels")
    return {"alpha": w[:, :start].sum(axis=1), "a": w[:, start:].copy()}


def spread_nodes(cone_nodes, a) -> np.ndarray:
    """``sum_k spread(cone_nodes[..., k, :], a[k])``: the node images ``(h, w, K, c)``
    each spread with its weights ``a`` (K, levels + 1) and summed (one weight
    per node: the level itself)."""
    cone_nodes = np.asarray(cone_nodes, dtype=float)
    a = np.asarray(a, dtype=float)
    if a.shape[1] == 1:
        return np.einsum("hwkc,k->hwc", cone_nodes, a[:, 0])
    return sum(spread(cone_nodes[..., k, :], a[k]) for k in range(a.shape[0]))
