"""The compiled light-field model's share of the cone's light: the pixel's, the pyramid's.

With the cone spread (tables with a :class:`~aquaspec.transport.lightfield.tables.ConeTables`)
the renderer (:mod:`aquaspec.transport.lightfield.compiled` and its GPU
twin) keeps the pyramid's finer levels in the pixel and spreads the rest
from level ``L0`` (:func:`spread_plan`, :func:`multiple_plan`): the pixel
keeps the share ``alpha`` of its cone term and of the target's light
(:func:`kept_share`, with no term per band where :func:`kept_projection`
allows), the pyramid starts from two samples per coarse pixel
(:func:`coarse_sample_pixels`) and its result comes back with one bilinear
sample per group of four pixels (:func:`upsample_groups`). With the
multiple-scattering spread the shares are those of the lambda nodes
(:func:`node_alpha`, :func:`node_hats`).
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.numerics import bilinear_grid
from aquaspec.transport.lightfield.conespread import (LAMBDA_NODES, interp_nodes,
                                                      lambda_coordinate, lambda_node_weights,
                                                      level_shapes,
                                                      node_coordinates_are_integers,
                                                      node_level_tables)

#: Coarsest pyramid level at which the cone spread starts (:func:`spread_plan`),
#: and the largest angle its blocks may span, rad (0.77 degrees: level 3 at
#: 1280x720 and 1920x1080 with the built-in camera; level 0, the whole
#: pyramid, for the validation's 96x72 images). Measured on the built-in
#: scene at 1280x720 (Jerlov IB / II / 7C), starting at level 3 instead of 0
#: changed the image by 0.15-0.33 % on average, 2.6-5.5 % at the 99th
#: percentile (pixels along silhouettes), level 2 by 0.07-0.14 % / 1.1-2.5 %.
SPREAD_START_LEVEL = 3
SPREAD_BLOCK_RAD = 0.0135


def node_hats(lam, nodes: int) -> np.ndarray:
    """Hat weights ``(nodes, *lam.shape)`` of ``lambda = f b S`` on the first
    ``nodes`` of :data:`aquaspec.transport.lightfield.conespread.LAMBDA_NODES`: the model's
    :func:`aquaspec.transport.lightfield.conespread.lambda_node_weights`, which the GPU computes
    as ``max(0, 1 - |z - k|)`` with ``z = log3(1 + 2 lambda)`` (the nodes sit
    at ``z = 0 .. nodes - 1``, :func:`multiple_plan` checks)."""
    return lambda_node_weights(lam, LAMBDA_NODES[:nodes])


def node_alpha(comp, s) -> np.ndarray:
    """The multiple-scattering spread's share kept by a pixel at distance
    ``s``: ``comp.alpha_nodes`` interpolated at ``z = log3(1 + 2 mean(f b) s)``
    (:func:`aquaspec.transport.lightfield.compiled.surface_rgb`; the GPU's water
    table holds it in layer 0's fourth channel)."""
    return interp_nodes(comp.alpha_nodes, lambda_coordinate(np.mean(comp.fb)
                                                             * np.asarray(s, dtype=float)))


def multiple_plan(node_weights, pixels_per_radian: float, start_level: int | None = None):
    """``(L0, tables)`` of the multiple-scattering spread: the start level as
    :func:`spread_plan` chooses it, and :func:`aquaspec.transport.lightfield.conespread.node_level_tables`
    of the nodes' pyramid weights ``(K, L + 1)``
    (:func:`aquaspec.transport.lightfield.conespread.node_pyramid_weights`) from there."""
    w = np.asarray(node_weights, dtype=float)
    if not node_coordinates_are_integers():
        raise AquaspecError("the renderer's spread needs lambda nodes at z = 0, 1, 2, ..")
    start = spread_plan(w[0], pixels_per_radian, start_level)[0]
    return start, node_level_tables(w, start)


def spread_plan(weights, pixels_per_radian: float, start_level: int | None = None) -> tuple:
    """``(L0, alpha, coarse_weights)`` of the cone spread for pyramid weights
    ``a_0 .. a_L``: ``L0`` the largest level up to :data:`SPREAD_START_LEVEL`
    (and ``L``) whose blocks of ``2^L0`` pixels span at most
    :data:`SPREAD_BLOCK_RAD` (or ``start_level``), ``alpha = a_0 + .. +
    a_{L0-1}`` (kept by the pixel), the weights of levels ``L0 .. L``."""
    w = np.asarray(weights, dtype=float)
    if w.ndim != 1 or w.size < 2:
        raise AquaspecError(f"{w.size} pyramid weights; accepted: at least 2")
    if start_level is None:
        start_level = 0
        while (start_level < SPREAD_START_LEVEL
               and 2 ** (start_level + 1) <= SPREAD_BLOCK_RAD * pixels_per_radian):
            start_level += 1
    start = min(int(start_level), w.size - 1)
    return start, float(w[:start].sum()), w[start:]


def coarse_sample_pixels(height: int, width: int, level: int):
    """Pixels ``(ys, xs)`` (each (ch, cw, 2)) whose cone terms average to each
    coarse pixel of level ``level``: offsets ``(F // 4, F // 4)`` and
    ``(3 F // 4, 3 F // 4)`` in its ``F x F`` block (``F = 2^level``; the
    block's diagonal), clamped to the image.

    Two samples per block: at 1280x720 (start level 3, the built-in scene,
    Jerlov IB / II / 7C) the image differed from the whole pyramid's by a mean
    0.23 / 0.34 / 0.08 % with two samples and 0.23 / 0.33 / 0.08 % with the
    four of a 2x2 grid, whose coarse pass cost twice as much.
    """
    ch, cw = level_shapes(height, width, level)[-1]
    f = 2 ** level
    offs = np.array([f // 4, (3 * f) // 4])
    ys = np.minimum(f * np.arange(ch)[:, None, None] + offs, height - 1)
    xs = np.minimum(f * np.arange(cw)[None, :, None] + offs, width - 1)
    return np.broadcast_to(ys, (ch, cw, 2)), np.broadcast_to(xs, (ch, cw, 2))


def upsample_groups(coarse, factor: int, shape) -> np.ndarray:
    """The spread's result at full resolution as the GPU adds it: one bilinear
    value per group of four pixels of a row (columns ``4k .. 4k + 3``), at the
    group's centre, coarse index coordinates ``((4k + 2) / F - 0.5, (y + 0.5) / F - 0.5)``;
    with ``F < 4`` (small images) per pixel, :func:`aquaspec.transport.lightfield.conespread.upsample_by`."""
    h, w = shape
    centres = 4 * (np.arange(w) // 4) + 2.0 if factor >= 4 else np.arange(w) + 0.5
    return bilinear_grid(coarse, (np.arange(h) + 0.5) / factor - 0.5, centres / factor - 0.5)


def kept_share(fb_mean: float, alpha: float, s):
    """Per pixel ``(dk, slope)`` with ``alpha + (1 - alpha) exp(-x_i) ~ dk exp(slope
    (x_i - x))``, ``x_i = f_i b_i S``, ``x = fb_mean S``: the tangent of the
    share's logarithm at the bands' mean, ``dk`` the share there.

    The pixel keeps ``alpha`` of its forward cone, ``T' (alpha + (1 - alpha)
    exp(-f b S))`` of the target's light; one exponential per band remains
    when the logarithm is linear in ``f_i b_i``: a multiply-add in the band's
    exponent (``slope S (f_i b_i - fb_mean)``), and ``dk`` multiplies the
    sum over bands once per pixel. Exact for ``alpha = 0`` and where all bands
    have the same ``f b``; for the Jerlov waters (f b varies 2.4x over
    400-700 nm) the kept light is off by at most 3.5-9 %, 1.5-3.6 % of the
    cone term, which then goes to the pyramid instead (light is conserved:
    the spread takes the complement).
    """
    xb = np.asarray(s, dtype=float) * float(fb_mean)
    e = np.exp(-xb)
    # (alpha = 0 and exp(-x) underflowing: the share is 0 either way; the
    # floor keeps the slope finite, as the GPU's 1e-30 does in float32.)
    d = np.maximum(alpha + (1.0 - alpha) * e, 1e-30)
    return d, -(1.0 - alpha) * e / d


#: Largest error (in the logarithm of the kept light) that :func:`kept_projection`
#: may add to :func:`kept_share`'s tangent; beyond it the band keeps its
#: multiply-add.
KEPT_PROJECTION_TOLERANCE = 0.01
#: Fewest bands for which :func:`kept_projection` is used: it saves a
#: multiply-add per band and costs a shift of every pixel term and an
#: exponential per pixel. Measured on lavapipe (1280x720, Jerlov IB, rank 4-5):
#: 0.2 ms slower at 8 bands, 0.8-1.5 ms faster at 32.
KEPT_PROJECTION_MIN_BANDS = 16


def fb_projection(k_depth, c_beam, g, fb):
    """``f_i b_i - mean(f b)`` as a combination of the band's other coefficients.

    Least squares of ``delta_i = f_i b_i - mean(f b)`` on the columns ``[K_i,
    c'_i, G_i0 .. G_i,rank-1, 1]`` (the coefficients of the band's exponent,
    :class:`~aquaspec.transport.lightfield.compiled.Compiled`). Returns ``(lam, delta_hat, residual)``: the
    combination ``[lam_K, lam_c, lam_G.., mu]``, its values ``delta_hat``
    (n,) and the largest ``|delta - delta_hat|``. Exact (to rounding) with
    ``n <= rank + 3`` bands.
    """
    k_depth, c_beam, fb = (np.asarray(x, dtype=float) for x in (k_depth, c_beam, fb))
    cols = np.column_stack([k_depth, c_beam, np.asarray(g, dtype=float), np.ones(fb.size)])
    delta = fb - fb.mean()
    lam = np.linalg.lstsq(cols, delta, rcond=None)[0]
    hat = cols @ lam
    return lam, hat, float(np.abs(delta - hat).max()) if fb.size else 0.0


def kept_slope_bound(alpha: float) -> float:
    """``max |slope(x)| x`` over ``x = fb_mean S >= 0`` (:func:`kept_share`):
    how far an error in ``f_i b_i`` can move the kept share's logarithm,
    per unit of ``fb_mean``. Infinite for ``alpha = 0`` (the slope stays -1)."""
    if alpha <= 0.0:
        return np.inf
    x = np.linspace(0.0, 60.0, 6001)
    e = np.exp(-x)
    return float(np.max(x * (1.0 - alpha) * e / (alpha + (1.0 - alpha) * e)))


def kept_projection(comp, alpha: float, projection=None):
    """The kept share with no term per band, or None where it would err too much.

    The band's multiply-add ``slope S delta_i`` (:func:`kept_share`) goes
    into the pixel's other terms when ``delta`` is a combination of the
    band's coefficients (:func:`fb_projection`): ``slope S delta_hat_i = K_i
    lam_K kb + c'_i lam_c kb + sum_r G_ir lam_r kb + mu kb`` with ``kb =
    slope S``, so the pixel shifts its depth, distance and basis values by
    ``lam kb`` and multiplies by ``exp(mu kb)``, once for all bands. Used
    when the residual moves the kept light's logarithm by at most
    :data:`KEPT_PROJECTION_TOLERANCE` (``kept_slope_bound(alpha) residual /
    fb_mean``); never with ``alpha = 0``, where the slope is -1 at every
    distance, nor with fewer than :data:`KEPT_PROJECTION_MIN_BANDS` bands.
    ``comp``: a :class:`~aquaspec.transport.lightfield.compiled.Compiled` (or anything with its ``split``,
    ``k_depth``, ``c_beam``, ``g`` and ``fb``); ``projection``: its
    :func:`fb_projection`, if already made. Returns ``{"lam": (rank + 3,),
    "fb_offset": delta_hat (n,), "error_bound": float}`` or None.
    """
    if (not comp.split or alpha <= 0.0 or np.size(comp.fb) < KEPT_PROJECTION_MIN_BANDS
            or getattr(comp, "alpha_nodes", None) is not None):
        return None
    lam, hat, res = (projection if projection is not None
                     else fb_projection(comp.k_depth, comp.c_beam, comp.g, comp.fb))
    fbm = float(np.mean(comp.fb))
    bound = 0.0 if res == 0.0 else (kept_slope_bound(alpha) * res / fbm if fbm > 0 else np.inf)
    if not bound <= KEPT_PROJECTION_TOLERANCE:
        return None
    return {"lam": lam, "fb_offset": hat, "error_bound": bound}
