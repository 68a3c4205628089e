"""The light-field model compiled for the GPU at one camera depth.

:class:`aquaspec.transport.lightfield.tables.LightfieldTables` gives per band the
in-scattering prefactor ``F(d, v_y)`` and the irradiance ``E(d, n_y)`` as tables;
evaluating them per band and pixel (two table reads and three exponentials per band) made the
light-field frame 1.6 times the seeds' on a CPU rasteriser. This module
rewrites the same model so that the per-pixel cost is that of the seeds'
model (SPEC: keep the per-pixel cost near the seeds'):

- **Water table** ``W(v_y, S)``: everything the water adds to a pixel whose
  ray (direction ``v``, up component ``v_y``) ends on a surface at distance
  ``S``, in camera RGB, for the camera's depth ``d_o``. With the open-water
  field ``L_bg(d, v) = R(d, v) + u(d) L_end`` of
  :meth:`aquaspec.transport.lightfield.tables.LightfieldTables.pixel_radiance`
  (``L_end`` the sky seen through the window or, with a seabed, the seabed
  where the line of sight ends, ``u`` the transmittance to it),
  ``W = sum_i w_i [L_bg(d_o, v) - T'(S) L_bg(d_S, v)]`` (``T' = exp(-c' S)``,
  ``c' = c - f b`` the beam extinction with the forward cone, ``d_S = d_o - S
  v_y``): the radiance of a black target. It depends on the pixel only
  through ``(v_y, S)`` (horizontally uniform water), so a 2-D table for the
  camera's depth gives it for all bands at once (:func:`water_table`; the
  GPU builds the same table, ``gpu/passes/watertable.wgsl``, with or
  without a seabed: a closed form per band). A last column
  holds open water (the ray hits nothing). With the cone spread a second layer holds the
  cone's share ``-(T' - T) L_bg(d_S, v)`` and the first uses ``T = exp(-c S)``.
- **Factored irradiance**: the target's own light ``T'(S) rho E(d_S, n_y) / pi``
  needs ``E`` per band. Its logarithm is fitted, over the tables' nodes, as
  ``ln(E_i(d, n_y) / E0_i) ~ C_i + K_i d + sum_r G_ir U_r(d, n_y)`` with
  :data:`IRRADIANCE_RANK` functions ``U_r`` shared by all bands (one
  four-channel texture read per pixel) and per-band coefficients
  (alternating least squares, :func:`irradiance_factors`). With
  ``n <= rank`` bands the factorisation is exact.

**Cone spread** (tables with ``cone_spread``;
:mod:`aquaspec.transport.lightfield.spreadplan`): the pyramid of
:mod:`aquaspec.transport.lightfield.conespread` (weights ``a_0 .. a_L``) starts at level ``L0`` =
:data:`~aquaspec.transport.lightfield.spreadplan.SPREAD_START_LEVEL`
(:func:`~aquaspec.transport.lightfield.spreadplan.spread_plan`). Its finer levels blur by a
few pixels only and are taken as the pixel's own: the pixel keeps the share
``alpha = a_0 + .. + a_{L0-1}`` of its cone term (water table ``W0 + alpha
W1``, the target's light times ``alpha + (1 - alpha) exp(-f b S)``, whose
logarithm is taken linear in ``f_i b_i`` per pixel,
:func:`~aquaspec.transport.lightfield.spreadplan.kept_share`,
so that a band costs one exponential and a multiply-add). Level
``L0`` itself (``2^L0`` times coarser) is estimated from the cone term at two
pixels on the diagonal of each coarse pixel's block (offsets ``2^L0 / 4`` and
``3 2^L0 / 4``, :func:`~aquaspec.transport.lightfield.spreadplan.coarse_sample_pixels`),
the pyramid runs from there
(:func:`aquaspec.transport.lightfield.conespread.spread`), and its result is added with one
bilinear sample per group of four pixels of a row
(:func:`~aquaspec.transport.lightfield.spreadplan.upsample_groups`). On the GPU that is a
coarse pass, a small pyramid, then the full-resolution pass with the display
transform fused.

Per pixel the GPU then reads the water table once and the ``U`` texture
once (plus the spread's result with the spread), and per band evaluates one exponential
``exp(K_i d_S - c'_i S + sum_r G_ir U_r)`` times the reflectance. The NumPy
twin of the GPU pass is :func:`shade_compiled`; how far the compiled model is
from :func:`aquaspec.shading.shade.shade_gbuffer` (the model itself) is measured
by the tests (``tests/transport/lightfield/test_compiled.py``) and by
:attr:`Compiled.irradiance_error`.

Table axes (texel units, texel ``k`` centred at ``k``, as a GPU sampler's
``(k + 0.5) / size``):

- direction: outside the window (``v_y <= window_cos``) ``n_out`` nodes
  uniform in ``q = sign(v_y) sqrt(|v_y|)`` over ``[-1, q_w]``, ``q_w =
  sign(window_cos) sqrt(|window_cos|)`` (dense near the horizon, where an up
  ray from a shallow camera changes fast); inside it ``n_in`` nodes uniform
  in ``u = sqrt((v_y - window_cos) / (1 - window_cos))`` over ``[0, 1]``
  (dense at the window's edge, where the Fresnel transmission of a grazing
  sky ray rises as ``sqrt(v_y - window_cos)``, linear in ``u``; for the
  ``"null"`` surface, whose window's edge is the horizon, ``u = q``)
  (:func:`direction_split`). The edge falls between two texels that the
  lookup never blends, so its jump stays sharp.
- distance: ``x = S / (S + length) (K - 2)`` for a hit (``S = inf`` at
  ``K - 2``), ``K - 1`` for open water; ``length`` = :data:`LENGTH_SCALE_M`.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

from aquaspec.cache import cached_arrays, code_digest
from aquaspec.errors import AquaspecError
from aquaspec.numerics import bilinear
from aquaspec.scene.gbuffer import hit_reflectance
from aquaspec.transport.lightfield.conespread import (interp_nodes, lambda_coordinate, spread,
                                                      spread_nodes)
from aquaspec.transport.lightfield import factors
from aquaspec.transport.lightfield.spreadplan import (coarse_sample_pixels, kept_projection,
                                                      kept_share, multiple_plan, node_alpha,
                                                      node_hats, spread_plan, upsample_groups)
from aquaspec.transport.lightfield.tables import (LightfieldTables, cut_at_seabed, seeds_shape,
                                                  table_lookup)

#: Functions U_r shared by all bands in the factored irradiance: four fill one
#: texture read (RGBA). Measured on the tables' nodes (depth <= 30 m, phase
#: Petzold): largest error of E 0.5 % (Jerlov 3C, 8 bands) to 5 % (Jerlov I,
#: 32 bands, surfaces facing down near the surface), rms 0.06-0.6 %.
IRRADIANCE_RANK = 4
#: Ranks tried in turn by :func:`choose_irradiance_factors` until the largest
#: error is within :data:`IRRADIANCE_TOLERANCE` (else the last). The GPU reads
#: the functions four per texture sample; a rank between two multiples of 4
#: costs the second read but fewer multiply-adds per band. Largest errors
#: (Petzold, rank 4 / 5 / 6 / 8): Jerlov IB 32 bands 2.5 / 1.5 / 1.3 / 0.4 %;
#: near a seabed (7.8 m, albedo 0.3) IB 8 bands 2.7 / 0.8 / 0.3 / 0 %;
#: Jerlov I 16 bands 4.3 / 3.1 / 3.2 / 0.7 %.
IRRADIANCE_RANKS = (4, 5, 6, 7, 8)
IRRADIANCE_TOLERANCE = 0.02
#: Direction nodes of the water table, split between outside and inside
#: Snell's window in proportion to their length in ``q`` (:func:`direction_split`).
DIRECTIONS = 256
#: Distance nodes of the water table (the last is open water). The table is
#: rebuilt on the GPU whenever the camera's depth changes, so its size is
#: paid per moving frame: 128 instead of 512 nodes changed the compiled
#: model's error against the model itself (tests/transport/lightfield/
#: test_compiled.py::test_twin_follows_the_model, seven waters and spreads) by at most
#: 4e-6 in the mean and 1.9e-5 in the 99th percentile (3C 3 bands: mean 2.1 -> 2.5e-5,
#: p99 1.45 -> 1.64e-4; the others within 3 %), and took a rebuild with the
#: single-scattering spread from 8.6-10.7 ms to 2.8-5.3 ms (lavapipe, IB, 8 bands).
DISTANCES = 128
#: Length scale of the distance axis, m.
LENGTH_SCALE_M = 4.0
#: Alternating least-squares sweeps of :func:`irradiance_factors`.
ALS_SWEEPS = 40
#: Depth up to which :func:`irradiance_factors` reports its error, m.
ERROR_DEPTH_M = 30.0

def irradiance_factors(tables: LightfieldTables, rank: int = IRRADIANCE_RANK, sweeps: int = ALS_SWEEPS) -> dict:
    """Fit ``ln(E_i(d, n_y)/E0_i) ~ C_i + K_i d + sum_r G_ir U_r(d, n_y)`` on the tables' nodes.

    Returns ``{"coef": (n, 2 + rank) [C, K, G_0 ..], "basis": (rank, n_depth,
    n_mu) U on the nodes, "max_error", "rms_error"}``: the largest and rms
    relative error of ``E`` over the nodes down to :data:`ERROR_DEPTH_M`.
    Least squares in ``ln E``; with ``n <= rank`` bands exact (``U_i = ln E_i``).
    The solves are normal equations with a conditioning guard and the start
    the leading rows of an SVD (:mod:`aquaspec.transport.lightfield.factors`,
    which says why that is safe here).
    """
    if not (isinstance(rank, (int, np.integer)) and rank >= 1):
        raise AquaspecError(f"rank={rank!r}; accepted: an integer >= 1")
    e = np.asarray(tables.irradiance_per_e0, dtype=float)
    if not np.all(np.isfinite(e) & (e >= 0)):
        raise AquaspecError("irradiance table has negative or non-finite values")
    n, nd, nm = e.shape
    depth = np.asarray(tables.depth_m, dtype=float)
    m = np.log(np.maximum(e, 1e-30)).reshape(n, -1)
    dd = np.repeat(depth, nm)
    fixed = np.stack([np.ones_like(dd), dd])                  # (2, P)
    if n <= rank:
        coef = np.zeros((n, 2 + rank))
        coef[:, 2:2 + n] = np.eye(n)
        basis = np.zeros((rank, nd * nm))
        basis[:n] = m
    else:
        c_fixed = factors.normal_lstsq(fixed.T, m.T).T
        basis = factors.leading_rows(m - c_fixed @ fixed, rank)
        for _ in range(sweeps):
            a = np.vstack([fixed, basis])
            coef = factors.normal_lstsq(a.T, m.T).T
            basis = factors.normal_lstsq(coef[:, 2:], m - coef[:, :2] @ fixed)
        coef = factors.normal_lstsq(np.vstack([fixed, basis]).T, m.T).T
    fit = coef @ np.vstack([fixed, basis])
    rel = np.expm1(fit - m)[:, dd <= ERROR_DEPTH_M]
    if not np.all(np.isfinite(coef)) or not np.all(np.isfinite(basis)):
        raise AquaspecError("the irradiance factorisation came out non-finite")
    return {"coef": coef, "basis": basis.reshape(rank, nd, nm),
            "max_error": float(np.abs(rel).max()), "rms_error": float(np.sqrt(np.mean(rel ** 2)))}


def choose_irradiance_factors(tables: LightfieldTables) -> dict:
    """:func:`irradiance_factors` with the first rank of :data:`IRRADIANCE_RANKS`
    whose largest error is within :data:`IRRADIANCE_TOLERANCE` (else the last).

    Kept in aquaspec's cache, keyed by the irradiance table and the code and
    constants of this module and :mod:`aquaspec.transport.lightfield.factors`."""
    key = code_digest([sys.modules[__name__], factors], *(np.asarray(t, dtype=float).tobytes()
                                                 for t in (tables.irradiance_per_e0,
                                                           tables.depth_m)))
    fac = cached_arrays("irradiance-factors", key, lambda: {
        k: np.asarray(v) for k, v in _choose_irradiance_factors(tables).items()})
    return {"coef": fac["coef"], "basis": fac["basis"],
            "max_error": float(fac["max_error"]), "rms_error": float(fac["rms_error"])}


def _choose_irradiance_factors(tables) -> dict:
    for rank in IRRADIANCE_RANKS:
        fac = irradiance_factors(tables, rank)
        if fac["max_error"] <= IRRADIANCE_TOLERANCE:
            break
    return fac


def _q(v):
    return np.sign(v) * np.sqrt(np.abs(v))


def direction_split(window_cos: float) -> tuple[int, int]:
    """Direction nodes ``(n_out, n_in)`` outside / inside the window (at least 2 each)."""
    if not -1.0 < window_cos < 1.0:
        raise AquaspecError(f"window_cos={window_cos!r}; accepted: strictly between -1 and 1")
    n_out = int(np.clip(round(DIRECTIONS * (_q(window_cos) + 1.0) / 2.0), 2, DIRECTIONS - 2))
    return n_out, DIRECTIONS - n_out


def direction_coordinate(v_y, window_cos: float):
    """Texel coordinate of the water table's direction axis (see the module docstring)."""
    n_out, n_in = direction_split(window_cos)
    v = np.clip(np.asarray(v_y, dtype=float), -1.0, 1.0)
    q, q_w = _q(v), _q(window_cos)
    outside = (q + 1.0) / (q_w + 1.0) * (n_out - 1)
    u = np.sqrt(np.maximum(v - window_cos, 0.0) / (1.0 - window_cos))
    inside = n_out + u * (n_in - 1)
    return np.where(v > window_cos, inside, outside)


def direction_nodes(window_cos: float):
    """``v_y`` of the direction nodes and whether each is inside the window."""
    n_out, n_in = direction_split(window_cos)
    q = np.linspace(-1.0, _q(window_cos), n_out)
    u = np.linspace(0.0, 1.0, n_in)
    v = np.concatenate([np.sign(q) * q * q, window_cos + (1.0 - window_cos) * u * u])
    inside = np.arange(v.size) >= n_out
    # The first inside node is the window edge seen from inside.
    v[n_out] = np.nextafter(window_cos, 2.0)
    return v, inside


def distance_coordinate(s, hit):
    """Texel coordinate of the distance axis: ``S / (S + length)`` scaled, open water last."""
    s = np.asarray(s, dtype=float)
    with np.errstate(invalid="ignore"):
        x = np.where(np.isfinite(s), s / (s + LENGTH_SCALE_M), 1.0) * (DISTANCES - 2)
    return np.where(hit, x, DISTANCES - 1.0)


def distance_nodes():
    """``S`` of the hit nodes (the last is ``inf``)."""
    x = np.arange(DISTANCES - 1) / (DISTANCES - 2)
    with np.errstate(divide="ignore"):
        return np.where(x < 1.0, LENGTH_SCALE_M * x / np.where(x < 1.0, 1.0 - x, 1.0), np.inf)


def water_table(tables: LightfieldTables, *, a, b, e0, response_weights, depth_o: float,
                split: bool, alpha_nodes=None):
    """The water table ``(layers, directions, DISTANCES, 3)`` in camera RGB, float64.

    Layer 0: ``sum_i w_i [L_bg(d_o, v) - T_i L_bg(d_S, v)]`` with ``T = T'``
    (``split=False``) or ``exp(-c S)`` (``split=True``); layer 1 (split only):
    the cone's share ``-sum_i w_i (T' - T) L_bg(d_S, v)``. Column
    ``DISTANCES - 1``: open water. The terms of
    :meth:`aquaspec.transport.lightfield.tables.LightfieldTables.pixel_radiance` for a black target
    (its two-point form with the forward cone), in closed form on the nodes (the
    tests compare the two on every node, with and without a seabed).

    The open-water field is ``L_bg(d, v) = R(d, v) + exp(-c l(d)) L_end``:
    ``R`` the path integral ``F b E0 / (4 pi) ms_path_integral`` along the line
    of sight from depth ``d``, which ends on the water surface (up rays, ``l
    = d / v_y``, ``L_end`` the sky inside the window), on the seabed at depth
    ``H`` (down rays with a seabed, ``l = (H - d) / -v_y``, ``L_end`` the
    seabed's radiance,
    :meth:`~aquaspec.transport.lightfield.tables.LightfieldTables.seabed_radiance`)
    or nowhere (``l = inf``). With a seabed the hit distances of down rays are
    cut at the seabed (a black target beyond it is taken at the seabed, also
    in the spread's lambda coordinate: the table is flat in ``S`` there) and
    ``S = inf`` going down is open water, which sees the seabed.

    With ``alpha_nodes`` (K,) (the multiple-scattering spread: the share kept
    by the pixel at each lambda node, :func:`multiple_plan`) the band's cone
    term ``C_i`` at ``z_i = log3(1 + 2 f_i b_i S)`` is kept with ``alpha(z_i)``
    (interpolated between the nodes, :func:`aquaspec.transport.lightfield.conespread.interp_nodes`):
    layer 0 also holds ``sum_i w_i alpha(z_i) C_i``, and layers ``1 .. K``
    hold the cone term split between the nodes, ``sum_i w_i h_k(z_i) C_i``
    (hat weights, :func:`aquaspec.transport.lightfield.conespread.lambda_node_weights`), to be
    spread with node ``k``'s weights from the start level (which sum to ``1 -
    alpha_k``).
    """
    a, b, e0 = (np.asarray(x, dtype=float) for x in (a, b, e0))
    w = np.asarray(response_weights, dtype=float)
    if alpha_nodes is not None and not split:
        raise AquaspecError("alpha_nodes (the multiple-scattering spread) need split=True")
    c = a + b
    f = np.asarray(tables.forward_fraction, dtype=float)
    c_beam = c - f * b
    k1 = np.asarray(tables.k_inf, dtype=float)
    bed = tables.seabed_depth_m
    l_bed = tables.seabed_radiance(e0) if tables.has_seabed else np.zeros_like(k1)
    v, _ = direction_nodes(tables.window_cos)
    s_nodes = distance_nodes()                         # hit nodes, the last inf

    def r_at(depth, vv):
        """R(d, v) per band: (P, n)."""
        to_end = np.broadcast_to(cut_at_seabed(np.inf, depth, vv, bed), depth.shape)
        return tables.prefactor(depth, vv) * e0 * seeds_shape(b, c, k1, depth[:, None],
                                                              vv[:, None], to_end[:, None])

    def end_light(depth, vv, l_top):
        """exp(-c l(d)) L_end per band: (P, n)."""
        up, down = vv > 0, (vv < 0) & np.isfinite(bed)
        length = np.where(up, depth / np.where(up, vv, 1.0),
                          (bed - depth) / np.where(down, -vv, 1.0))
        l_end = np.where(up[:, None], l_top, np.where(down[:, None], l_bed, 0.0))
        return np.where((up | down)[:, None],
                        np.exp(-c * np.where(up | down, length, 0.0)[:, None]), 0.0) * l_end

    # Up rays within 1e-30 of level reach the surface at a distance that
    # overflows: exp(-inf) = 0 is the limit.
    with np.errstate(over="ignore"):
        l_top = tables.top_radiance(v, e0)                                     # (J, n)
        d_o = np.full(v.size, float(depth_o))
        open_l = r_at(d_o, v) + end_light(d_o, v, l_top)                      # L_bg(d_o, v)
        vv, ss = np.meshgrid(v, s_nodes, indexing="ij")
        vv, ss = vv.reshape(-1), ss.reshape(-1)
        ss = np.minimum(ss, np.where(vv > 0, depth_o / np.where(vv > 0, vv, 1.0), np.inf))
        # S = inf (rays going down or level): open water, T = 0.
        far = ~np.isfinite(ss)
        ss = np.where(far, 0.0, cut_at_seabed(ss, depth_o, vv, bed))
        d_s = np.clip(depth_o - ss * vv, 0.0, bed)
        rows = np.repeat(np.arange(v.size), s_nodes.size)
        blocked = r_at(d_s, vv) + end_light(d_s, vv, l_top[rows])            # L_bg(d_S, v)
        t_beam = np.where(far[:, None], 0.0, np.exp(-c_beam * ss[:, None]))
        t = np.where(far[:, None], 0.0, np.exp(-c * ss[:, None])) if split else t_beam
        base = open_l[rows] - t * blocked
    out = np.zeros((_layers(split, alpha_nodes), v.size, DISTANCES, 3))
    cone = -(t_beam - t) * blocked
    _fill_hit_columns(out, base, cone, ss, c - c_beam, w, alpha_nodes, (v.size, s_nodes.size))
    out[0, :, DISTANCES - 1] = open_l @ w
    if not np.all(np.isfinite(out)):
        raise AquaspecError("the light-field water table came out non-finite; check the "
                            "water coefficients and tables")
    return out


def _layers(split: bool, alpha_nodes) -> int:
    return 1 if not split else (2 if alpha_nodes is None else 1 + np.size(alpha_nodes))


def _fill_hit_columns(out, base, cone, s, fb, w, alpha_nodes, shape):
    """The hit columns of the water table ``out`` from per-band ``base`` and
    ``cone`` (P, n) at distances ``s`` (P,) (:func:`water_table`'s layers)."""
    if alpha_nodes is not None:
        lam = np.asarray(fb)[None, :] * s[:, None]                        # (P, n)
        base = base + interp_nodes(alpha_nodes, lambda_coordinate(lam)) * cone
        for k, h in enumerate(node_hats(lam, np.size(alpha_nodes))):
            out[1 + k, :, :DISTANCES - 1] = ((h * cone) @ w).reshape(shape + (3,))
    out[0, :, :DISTANCES - 1] = (base @ w).reshape(shape + (3,))
    if alpha_nodes is None and out.shape[0] > 1:
        out[1, :, :DISTANCES - 1] = (cone @ w).reshape(shape + (3,))


def lookup_water(table, v_y, s, hit, window_cos: float):
    """Bilinear lookup of the water table as the GPU sampler does: (..., layers, 3)."""
    t = np.asarray(table, dtype=float)
    return bilinear(np.moveaxis(t, 0, -2),      # (directions, distances, layers, 3)
                    direction_coordinate(v_y, window_cos), distance_coordinate(s, hit))


@dataclass
class Compiled:
    """The light-field model compiled for one camera depth (see the module docstring)."""

    depth_o: float
    split: bool
    #: (layers, directions, DISTANCES, 3) camera RGB (:func:`water_table`).
    water: np.ndarray
    #: (rank, n_depth, n_mu): U on the tables' nodes.
    basis: np.ndarray
    #: Per band (n,): K (1/m), c' (1/m), f b (1/m); G (n, rank); surface weights
    #: (n, 3) = w E0 / pi exp(C).
    k_depth: np.ndarray
    c_beam: np.ndarray
    fb: np.ndarray
    g: np.ndarray
    surface_weights: np.ndarray
    window_cos: float
    max_depth: float
    #: Largest and rms relative error of the factored E on the nodes (<= 30 m).
    irradiance_error: tuple
    #: The multiple-scattering spread: the share kept by the pixel at each
    #: lambda node (:func:`multiple_plan`), which the water table holds; None
    #: with the single-scattering spread or none.
    alpha_nodes: np.ndarray | None = None


def compile_lightfield(tables: LightfieldTables, *, a, b, e0, response_weights, depth_o: float,
                       factors: dict | None = None, alpha_nodes=None) -> Compiled:
    """Compile the model for the camera depth ``depth_o`` (``factors`` reused
    if given; ``alpha_nodes``: the multiple-scattering spread's kept shares
    from :func:`~aquaspec.transport.lightfield.spreadplan.multiple_plan`, for tables
    whose cone spread is ``multiple``)."""
    a, b, e0 = (np.asarray(x, dtype=float) for x in (a, b, e0))
    w = np.asarray(response_weights, dtype=float)
    fac = factors if factors is not None else choose_irradiance_factors(tables)
    f = np.asarray(tables.forward_fraction, dtype=float)
    split = tables.cone is not None
    if (split and tables.cone.multiple) != (alpha_nodes is not None):
        raise AquaspecError("tables with the multiple-scattering spread (cone_offset_cdf_nodes) "
                            "compile with alpha_nodes from multiple_plan(), other tables "
                            "without")
    if alpha_nodes is not None:
        alpha_nodes = np.asarray(alpha_nodes, dtype=float)
    water = water_table(tables, a=a, b=b, e0=e0, response_weights=w, depth_o=float(depth_o),
                        split=split, alpha_nodes=alpha_nodes)
    coef = fac["coef"]
    return Compiled(depth_o=float(depth_o), split=split, water=water, basis=fac["basis"],
                    k_depth=coef[:, 1], c_beam=a + (1.0 - f) * b, fb=f * b, g=coef[:, 2:],
                    surface_weights=w * (e0 / np.pi * np.exp(coef[:, 0]))[:, None],
                    window_cos=tables.window_cos, max_depth=tables.max_depth_m,
                    irradiance_error=(fac["max_error"], fac["rms_error"]),
                    alpha_nodes=alpha_nodes)



def surface_rgb(comp: Compiled, rho, s, surface_depth, n_y, alpha: float = 0.0,
                surface_scale=None):
    """Camera RGB of the targets' own light, ``(P, 3)`` (and its spread share when split).

    ``rho`` (P, n); ``s``, ``surface_depth``, ``n_y`` (P,); ``surface_scale``
    (P, n) or None: the light-field term per band times it (the scene's
    occlusion, :func:`aquaspec.transport.lightfield.occlusion.occlusion_factor`). Returns
    ``(kept, spread)``: without the split ``kept`` is all of it (``T'``) and
    ``spread`` zero; with it ``kept`` is ``T' dk exp(slope S (f_i b_i -
    mean f b))`` (:func:`kept_share`: ``T`` plus about ``alpha`` of the cone
    ``T' - T``; ``f_i b_i - mean f b`` projected by :func:`kept_projection`
    where that applies, as the GPU does) and ``spread`` the rest divided by ``1 - alpha``, to be weighted by
    the pyramid's levels from ``L0`` (which sum to ``1 - alpha``).

    With ``comp.alpha_nodes`` (the multiple-scattering spread) the pixel's
    share is :func:`kept_share`'s with one ``alpha`` for all bands, the
    nodes' shares interpolated at the bands' mean ``x = mean(f b) S`` (``z =
    log3(1 + 2 x)``, :func:`node_alpha`; the GPU reads it from the water
    table). Per band it cost a logarithm and the hat weights in every pixel,
    +8 ms per 1280x720 frame at 8 bands on lavapipe, and a tangent with
    ``alpha`` depending on the band overflows where it changes fast.
    ``spread`` is ``(P, K, 3)``: the rest split between the nodes by the hat
    weights of ``z_i = log3(1 + 2 f_i b_i S)`` (:func:`node_hats`) and
    divided by ``1 - alpha(z_i)``, as node ``k``'s weights from the start
    level sum to ``1 - alpha_k``: the spread gives back exactly what the
    pixel does not keep.
    """
    s = np.asarray(s, dtype=float)[:, None]
    u = table_lookup(comp.basis, surface_depth, n_y, comp.max_depth)         # (P, rank)
    ln_e = comp.k_depth * np.asarray(surface_depth, dtype=float)[:, None] \
        - comp.c_beam * s + u @ comp.g.T
    l = np.asarray(rho, dtype=float) * np.exp(ln_e)
    if surface_scale is not None:
        l = l * np.asarray(surface_scale, dtype=float)
    if comp.alpha_nodes is not None:
        z = lambda_coordinate(comp.fb[None, :] * s)
        dk, slope = kept_share(comp.fb.mean(), node_alpha(comp, s[:, 0]), s[:, 0])
        rest = l - l * dk[:, None] * np.exp(slope[:, None] * s * (comp.fb - comp.fb.mean()))
        share = rest / np.maximum(1.0 - interp_nodes(comp.alpha_nodes, z), 1e-12)
        hats = node_hats(comp.fb[None, :] * s, comp.alpha_nodes.size)   # (K, P, n)
        return ((l - rest) @ comp.surface_weights,
                np.stack([(h * share) @ comp.surface_weights for h in hats], axis=1))
    if comp.split:
        dk, slope = kept_share(comp.fb.mean(), alpha, s[:, 0])
        proj = kept_projection(comp, alpha)
        offset = comp.fb - comp.fb.mean() if proj is None else proj["fb_offset"]
        kept = l * dk[:, None] * np.exp(slope[:, None] * s * offset)
        return (kept @ comp.surface_weights,
                (l - kept) @ comp.surface_weights / max(1.0 - alpha, 1e-12))
    return l @ comp.surface_weights, np.zeros((l.shape[0], 3))


def shade_compiled(gbuffer, comp: Compiled, *, material_bands, sigmoid_centers_t,
                   pyramid_weights=None, start_level: int | None = None,
                   surface_scale=None) -> np.ndarray:
    """The NumPy twin of the GPU light-field pass: (H, W, 3) linear camera RGB.

    With ``comp.split`` the cone's share is spread over the image with the
    pyramid ``pyramid_weights`` (:func:`aquaspec.transport.lightfield.conespread.pyramid_weights`),
    starting at the level of :func:`spread_plan` (``start_level`` overrides it).
    With ``comp.alpha_nodes`` (the multiple-scattering spread)
    ``pyramid_weights`` are the nodes' ``(K, L + 1)``
    (:func:`aquaspec.transport.lightfield.conespread.node_pyramid_weights`), ``comp`` compiled
    with :func:`multiple_plan`'s ``alpha``, and one pyramid holds every node's image
    (:func:`aquaspec.transport.lightfield.conespread.spread_nodes`).
    ``surface_scale`` (H, W, n) or None: each hit's light-field term per band
    times it (:func:`surface_rgb`; the GPU's occlusion factors).
    """
    cam = gbuffer.camera
    alpha = 0.0
    multiple = comp.alpha_nodes is not None
    if comp.split:
        if pyramid_weights is None:
            raise AquaspecError("a compiled model with the cone spread needs pyramid_weights")
        if multiple:
            start, levels = multiple_plan(pyramid_weights, cam.fy, start_level)
            if not np.allclose(levels["alpha"], comp.alpha_nodes, rtol=1e-12, atol=1e-15):
                raise AquaspecError("comp was compiled with other alpha_nodes than these "
                                    "pyramid weights give (multiple_plan)")
        else:
            start, alpha, coarse_w = spread_plan(pyramid_weights, cam.fy, start_level)
    d_o = comp.depth_o
    v_y = cam.ray_directions()[..., 1].reshape(-1)
    s = gbuffer.distance.reshape(-1).astype(float)
    up = v_y > 0
    to_surface = np.where(up, d_o / np.where(up, v_y, 1.0), np.inf)
    hit = np.isfinite(s) & (s >= 0) & (s <= to_surface)
    s = np.where(hit, s, 0.0)
    water = lookup_water(comp.water, v_y, s, hit, comp.window_cos)      # (P, layers, 3)
    rgb = water[:, 0].copy()
    cone = water[:, 1].copy() if comp.split else None
    if multiple:
        cone = water[:, 1:].copy()           # (P, K, 3)
    if comp.split and not multiple:
        rgb += alpha * cone                  # the pixel's share of the water's cone
    if np.any(hit):
        mat = gbuffer.material.reshape(-1)[hit]
        mb = np.asarray(material_bands, dtype=float).reshape(-1, comp.c_beam.size)
        rho = hit_reflectance(mat, gbuffer.sigmoid.reshape(-1, 3)[hit], mb,
                              np.asarray(sigmoid_centers_t, dtype=float))
        sd = np.maximum(d_o - s[hit] * v_y[hit], 0.0)
        scale = None if surface_scale is None else np.asarray(
            surface_scale, dtype=float).reshape(-1, comp.c_beam.size)[hit]
        parts = surface_rgb(comp, rho, s[hit], sd,
                            gbuffer.normal[..., 1].reshape(-1)[hit].astype(float), alpha,
                            surface_scale=scale)
        rgb[hit] += parts[0]
        if comp.split:
            cone[hit] += parts[1]
    h, w = cam.height, cam.width
    rgb = rgb.reshape(h, w, 3)
    if comp.split:
        cone = cone.reshape((h, w) + cone.shape[1:])
        ys, xs = coarse_sample_pixels(h, w, start)
        coarse = cone[ys, xs].mean(axis=2)
        if multiple:
            composite = spread_nodes(coarse, levels["a"])
        elif coarse_w.size > 1:
            composite = spread(coarse, coarse_w)
        else:
            composite = coarse_w[0] * coarse
        rgb = rgb + upsample_groups(composite, 2 ** start, (h, w))
    if not np.all(np.isfinite(rgb)):
        raise AquaspecError("the compiled light field produced NaN or infinity")
    return rgb
