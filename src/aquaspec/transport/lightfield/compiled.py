"""The light-field model compiled for the GPU at one camera depth.

:mod:`aquaspec.transport.lightfield.solve` gives per band the in-scattering prefactor
``F(d, v_y)`` and the irradiance ``E(d, n_y)`` as tables; evaluating them per
band and pixel (two table reads and three exponentials per band) made the
light-field frame 1.6 times the seeds' on a CPU rasteriser. This module
rewrites the same model so that the per-pixel cost is that of the seeds'
model (SPEC: keep the per-pixel cost near the seeds'):

- **Water table** ``W(v_y, S)``: everything the water adds to a pixel whose
  ray (direction ``v``, up component ``v_y``) ends on a surface at distance
  ``S``, in camera RGB, for the camera's depth ``d_o``. With the open-water
  field ``L_bg(d, v) = R(d, v) + u(d) L_top`` of
  :func:`aquaspec.transport.lightfield.solve.lightfield_pixel_radiance`,
  ``W = sum_i w_i [L_bg(d_o, v) - T'(S) L_bg(d_S, v)]`` (``T' = exp(-c' S)``,
  ``c' = c - f b`` the beam extinction with the forward cone, ``d_S = d_o - S
  v_y``): the radiance of a black target. It depends on the pixel only
  through ``(v_y, S)`` (horizontally uniform water), so a 2-D table for the
  camera's depth gives it for all bands at once (:func:`water_table`; the
  GPU builds the same table, ``shaders/watertable.wgsl``). A last column
  holds open water (the ray hits nothing). With the cone spread a second layer holds the
  cone's share ``-(T' - T) L_bg(d_S, v)`` and the first uses ``T = exp(-c S)``.
- **Factored irradiance**: the target's own light ``T'(S) rho E(d_S, n_y) / pi``
  needs ``E`` per band. Its logarithm is fitted, over the tables' nodes, as
  ``ln(E_i(d, n_y) / E0_i) ~ C_i + K_i d + sum_r G_ir U_r(d, n_y)`` with
  :data:`IRRADIANCE_RANK` functions ``U_r`` shared by all bands (one
  four-channel texture read per pixel) and per-band coefficients
  (alternating least squares, :func:`irradiance_factors`). With
  ``n <= rank`` bands the factorisation is exact.

**Cone spread** (tables with ``cone_spread``): the pyramid of
:mod:`aquaspec.transport.lightfield.conespread` (weights ``a_0 .. a_L``) starts at level ``L0`` =
:data:`SPREAD_START_LEVEL` (:func:`spread_plan`). Its finer levels blur by a
few pixels only and are taken as the pixel's own: the pixel keeps the share
``alpha = a_0 + .. + a_{L0-1}`` of its cone term (water table ``W0 + alpha
W1``, the target's light times ``alpha + (1 - alpha) exp(-f b S)``, whose
logarithm is taken linear in ``f_i b_i`` per pixel, :func:`kept_share`,
so that a band costs one exponential and a multiply-add). Level
``L0`` itself (``2^L0`` times coarser) is estimated from the cone term at two
pixels on the diagonal of each coarse pixel's block (offsets ``2^L0 / 4`` and
``3 2^L0 / 4``, :func:`coarse_sample_pixels`), the pyramid runs from there
(:func:`aquaspec.transport.lightfield.conespread.spread`), and its result is added with one
bilinear sample per group of four pixels of a row (:func:`upsample_groups`). On the GPU that is a
coarse pass, a small pyramid, then the full-resolution pass with the display
transform fused.

Per pixel the GPU then reads the water table once and the ``U`` texture
once (plus the spread's result with the spread), and per band evaluates one exponential
``exp(K_i d_S - c'_i S + sum_r G_ir U_r)`` times the reflectance. The NumPy
twin of the GPU pass is :func:`shade_compiled`; how far the compiled model is
from :func:`aquaspec.shading.shade.shade_gbuffer` (the model itself) is measured
by the tests (``tests/test_lightfield_compiled.py``) and by
:attr:`Compiled.irradiance_error`.

Table axes (texel units, texel ``k`` centred at ``k``, as a GPU sampler's
``(k + 0.5) / size``):

- direction: ``q = sign(v_y) sqrt(|v_y|)`` (dense near the horizon, where an
  up ray from a shallow camera changes fast); ``n_out`` nodes over ``q in
  [-1, q_w]`` outside the window (``v_y <= window_cos``, ``q_w =
  sign(window_cos) sqrt(|window_cos|)``), then ``n_in`` nodes over ``[q_w, 1]``
  inside it (:func:`direction_split`; the tables' default water surface,
  ``"null"``, puts the window's edge at the horizon). The edge falls
  between two texels that the lookup never blends, so its jump stays sharp.
- distance: ``x = S / (S + length) (K - 2)`` for a hit (``S = inf`` at
  ``K - 2``), ``K - 1`` for open water; ``length`` = :data:`LENGTH_SCALE_M`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError

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
#: Distance nodes of the water table (the last is open water).
DISTANCES = 512
#: Length scale of the distance axis, m.
LENGTH_SCALE_M = 4.0
#: Alternating least-squares sweeps of :func:`irradiance_factors`.
ALS_SWEEPS = 40
#: Depth up to which :func:`irradiance_factors` reports its error, m.
ERROR_DEPTH_M = 30.0
#: Coarsest pyramid level at which the cone spread starts (:func:`spread_plan`),
#: and the largest angle its blocks may span, rad (0.77 degrees: level 3 at
#: 1280x720 and 1920x1080 with the built-in camera; level 0, the whole
#: pyramid, for the validation's 96x72 images). Measured on the built-in
#: scene at 1280x720 (Jerlov IB / II / 7C), starting at level 3 instead of 0
#: changed the image by 0.15-0.33 % on average, 2.6-5.5 % at the 99th
#: percentile (pixels along silhouettes), level 2 by 0.07-0.14 % / 1.1-2.5 %.
SPREAD_START_LEVEL = 3
SPREAD_BLOCK_RAD = 0.0135


def irradiance_factors(tables, rank: int = IRRADIANCE_RANK, sweeps: int = ALS_SWEEPS) -> dict:
    """Fit ``ln(E_i(d, n_y)/E0_i) ~ C_i + K_i d + sum_r G_ir U_r(d, n_y)`` on the tables' nodes.

    Returns ``{"coef": (n, 2 + rank) [C, K, G_0 ..], "basis": (rank, n_depth,
    n_mu) U on the nodes, "max_error", "rms_error"}``: the largest and rms
    relative error of ``E`` over the nodes down to :data:`ERROR_DEPTH_M`.
    Least squares in ``ln E``; with ``n <= rank`` bands exact (``U_i = ln E_i``).
    """
    if not (isinstance(rank, (int, np.integer)) and rank >= 1):
        raise AquaspecError(f"rank={rank!r}; accepted: an integer >= 1")
    e = np.asarray(tables["irradiance_per_e0"], dtype=float)
    if not np.all(np.isfinite(e) & (e >= 0)):
        raise AquaspecError("irradiance table has negative or non-finite values")
    n, nd, nm = e.shape
    depth = np.asarray(tables["depth_m"], dtype=float)
    m = np.log(np.maximum(e, 1e-30)).reshape(n, -1)
    dd = np.repeat(depth, nm)
    fixed = np.stack([np.ones_like(dd), dd])                  # (2, P)
    if n <= rank:
        coef = np.zeros((n, 2 + rank))
        coef[:, 2:2 + n] = np.eye(n)
        basis = np.zeros((rank, nd * nm))
        basis[:n] = m
    else:
        c_fixed = np.linalg.lstsq(fixed.T, m.T, rcond=None)[0].T
        _, sv, vt = np.linalg.svd(m - c_fixed @ fixed, full_matrices=False)
        basis = vt[:rank] * sv[:rank, None]
        for _ in range(sweeps):
            a = np.vstack([fixed, basis])
            coef = np.linalg.lstsq(a.T, m.T, rcond=None)[0].T
            basis = np.linalg.lstsq(coef[:, 2:], m - coef[:, :2] @ fixed, rcond=None)[0]
        coef = np.linalg.lstsq(np.vstack([fixed, basis]).T, m.T, rcond=None)[0].T
    fit = coef @ np.vstack([fixed, basis])
    rel = np.expm1(fit - m)[:, dd <= ERROR_DEPTH_M]
    if not np.all(np.isfinite(coef)) or not np.all(np.isfinite(basis)):
        raise AquaspecError("the irradiance factorisation came out non-finite")
    return {"coef": coef, "basis": basis.reshape(rank, nd, nm),
            "max_error": float(np.abs(rel).max()), "rms_error": float(np.sqrt(np.mean(rel ** 2)))}


def choose_irradiance_factors(tables) -> dict:
    """:func:`irradiance_factors` with the first rank of :data:`IRRADIANCE_RANKS`
    whose largest error is within :data:`IRRADIANCE_TOLERANCE` (else the last).

    Kept in aquaspec's cache, keyed by the irradiance table and this
    module's code and constants."""
    import sys

    from aquaspec.cache import cached_arrays, code_digest
    key = code_digest([sys.modules[__name__]], *(np.asarray(tables[k], dtype=float).tobytes()
                                                 for k in ("irradiance_per_e0", "depth_m")))
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
    inside = n_out + (q - q_w) / (1.0 - q_w) * (n_in - 1)
    return np.where(v > window_cos, inside, outside)


def direction_nodes(window_cos: float):
    """``v_y`` of the direction nodes and whether each is inside the window."""
    n_out, n_in = direction_split(window_cos)
    q_w = _q(window_cos)
    q = np.concatenate([np.linspace(-1.0, q_w, n_out), np.linspace(q_w, 1.0, n_in)])
    v = np.sign(q) * q * q
    inside = np.arange(q.size) >= n_out
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


def water_table(tables, *, a, b, e0, response_weights, depth_o: float, split: bool,
                alpha_nodes=None):
    """The water table ``(layers, directions, DISTANCES, 3)`` in camera RGB, float64.

    Layer 0: ``sum_i w_i [L_bg(d_o, v) - T_i L_bg(d_S, v)]`` with ``T = T'``
    (``split=False``) or ``exp(-c S)`` (``split=True``); layer 1 (split only):
    the cone's share ``-sum_i w_i (T' - T) L_bg(d_S, v)``. Column
    ``DISTANCES - 1``: open water. The terms of
    :func:`aquaspec.transport.lightfield.solve.lightfield_pixel_radiance` for a black target
    (deep water), evaluated directly on the nodes (the test compares the two).

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
    from aquaspec.transport.lightfield.solve import _seeds_shape, bilinear
    a, b, e0 = (np.asarray(x, dtype=float) for x in (a, b, e0))
    w = np.asarray(response_weights, dtype=float)
    if alpha_nodes is not None and not split:
        raise AquaspecError("alpha_nodes (the multiple-scattering spread) need split=True")
    if np.isfinite(float(tables["seabed_depth_m"][0])):
        return _water_table_from_model(tables, a=a, b=b, e0=e0, w=w, depth_o=depth_o,
                                       split=split, alpha_nodes=alpha_nodes)
    c = a + b
    f = np.asarray(tables.get("forward_fraction", np.zeros(a.size)), dtype=float)
    c_beam = c - f * b
    k1 = np.asarray(tables["k_inf"], dtype=float)
    d_max = float(tables["max_depth_m"][0])
    wc = float(tables["window_cos"][0])
    sky = np.asarray(tables["sky_radiance_per_e0"], dtype=float) * e0
    v, inside = direction_nodes(wc)
    s_nodes = distance_nodes()                         # hit nodes, the last inf

    def r_at(depth, vv):
        """R(d, v) per band: (P, n)."""
        pref = np.exp(bilinear(tables["ms_log_prefactor"], depth, vv, d_max))
        return pref * e0 * _seeds_shape(b, c, k1, depth[:, None], vv[:, None], np.inf)

    # Up rays within 1e-30 of level reach the surface at a distance that
    # overflows: exp(-inf) = 0 is the limit.
    with np.errstate(over="ignore"):
        up = v > 0
        v_safe = np.where(up, v, 1.0)
        l_top = np.where(inside[:, None], sky, 0.0)                            # (J, n)
        u_o = np.where(up[:, None], np.exp(-c * depth_o / v_safe[:, None]), 0.0)
        open_l = r_at(np.full(v.size, depth_o), v) + u_o * l_top              # L_bg(d_o, v)
        vv, ss = np.meshgrid(v, s_nodes, indexing="ij")
        to_surface = np.where(vv > 0, depth_o / np.where(vv > 0, vv, 1.0), np.inf)
        ss = np.minimum(ss, to_surface).reshape(-1)
        vv = vv.reshape(-1)
        # S = inf (rays going down or level): open water, T = 0.
        far = ~np.isfinite(ss)
        ss = np.where(far, 0.0, ss)
        d_s = np.maximum(depth_o - ss * vv, 0.0)
        upp = vv > 0
        u_s = np.where(upp[:, None], np.exp(-c * d_s[:, None] / np.where(upp, vv, 1.0)[:, None]),
                       0.0)
        rows = np.repeat(np.arange(v.size), s_nodes.size)
        blocked = r_at(d_s, vv) + u_s * l_top[rows]                          # L_bg(d_S, v)
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
    from aquaspec.transport.lightfield.conespread import interp_nodes, lambda_coordinate
    if alpha_nodes is not None:
        lam = np.asarray(fb)[None, :] * s[:, None]                        # (P, n)
        base = base + interp_nodes(alpha_nodes, lambda_coordinate(lam)) * cone
        for k, h in enumerate(node_hats(lam, np.size(alpha_nodes))):
            out[1 + k, :, :DISTANCES - 1] = ((h * cone) @ w).reshape(shape + (3,))
    out[0, :, :DISTANCES - 1] = (base @ w).reshape(shape + (3,))
    if alpha_nodes is None and out.shape[0] > 1:
        out[1, :, :DISTANCES - 1] = (cone @ w).reshape(shape + (3,))


def node_hats(lam, nodes: int) -> np.ndarray:
    """Hat weights ``(nodes, *lam.shape)`` of ``lambda = f b S`` on the first
    ``nodes`` of :data:`aquaspec.transport.lightfield.conespread.LAMBDA_NODES`: the model's
    :func:`aquaspec.transport.lightfield.conespread.lambda_node_weights`, which the GPU computes
    as ``max(0, 1 - |z - k|)`` with ``z = log3(1 + 2 lambda)`` (the nodes sit
    at ``z = 0 .. nodes - 1``, :func:`multiple_plan` checks)."""
    from aquaspec.transport.lightfield.conespread import LAMBDA_NODES, lambda_node_weights
    return lambda_node_weights(lam, LAMBDA_NODES[:nodes])


def _water_table_from_model(tables, *, a, b, e0, w, depth_o: float, split: bool,
                            alpha_nodes=None):
    """:func:`water_table` for tables with a seabed: the model itself
    (:func:`aquaspec.transport.lightfield.solve.lightfield_pixel_radiance`) on every node, a
    black target at each finite distance and open water (the seabed seen
    below, the sky above) in the last column and at ``S = inf`` going down.
    The seabed's growing modes have no closed form along the ray in the deep
    water table's terms, so this is evaluated directly (NumPy; 0.13-1.0 s at
    8-64 bands)."""
    from aquaspec.transport.lightfield.solve import lightfield_pixel_radiance
    v, _ = direction_nodes(float(tables["window_cos"][0]))
    s_nodes = distance_nodes()
    out = np.zeros((_layers(split, alpha_nodes), v.size, DISTANCES, 3))
    kw = dict(a=a, b=b, e0=e0, depth_o=float(depth_o))
    with np.errstate(over="ignore"):      # up rays within 1e-30 of level
        open_l = lightfield_pixel_radiance(tables, **kw, v_y=v[:, None],
                                           s=np.full((v.size, 1), np.inf))
        out[0, :, DISTANCES - 1] = open_l @ w
        # (Nodes as a (directions, distances, 1) grid: what depends on the
        # direction alone, such as the light at the camera, is evaluated
        # once per direction.)
        vv = v[:, None, None]
        up = vv > 0
        ss = np.minimum(s_nodes[None, :, None],
                        np.where(up, depth_o / np.where(up, vv, 1.0), np.inf))
        sd = np.maximum(depth_o - np.where(np.isfinite(ss), ss, 0.0) * vv, 0.0)
        hit = lightfield_pixel_radiance(tables, **kw, v_y=vv, s=ss, rho=np.zeros(a.size),
                                        surface_depth=sd, n_y=np.ones_like(sd),
                                        split_cone=split)
        ss = ss.reshape(-1, 1)
        far = ~np.isfinite(ss[:, 0])
    base, cone = ((x.reshape(-1, a.size) for x in hit) if split
                  else (hit.reshape(-1, a.size), np.zeros((ss.shape[0], a.size))))
    base = np.where(far[:, None], np.repeat(open_l, s_nodes.size, axis=0), base)
    cone = np.where(far[:, None], 0.0, cone)
    f = np.asarray(tables.get("forward_fraction", np.zeros(a.size)), dtype=float)
    _fill_hit_columns(out, base, cone, np.where(far, 0.0, ss[:, 0]), f * b, w, alpha_nodes,
                      (v.size, s_nodes.size))
    if not np.all(np.isfinite(out)):
        raise AquaspecError("the light-field water table came out non-finite; check the "
                            "water coefficients and tables")
    return out


def lookup_water(table, v_y, s, hit, window_cos: float):
    """Bilinear lookup of the water table as the GPU sampler does: (..., layers, 3)."""
    t = np.asarray(table, dtype=float)
    y = direction_coordinate(v_y, window_cos)
    x = distance_coordinate(s, hit)
    ny, nx = t.shape[1], t.shape[2]
    j = np.clip(np.floor(y).astype(int), 0, ny - 2)
    i = np.clip(np.floor(x).astype(int), 0, nx - 2)
    fy = np.clip(y - j, 0.0, 1.0)[..., None, None]
    fx = np.clip(x - i, 0.0, 1.0)[..., None, None]
    tt = np.moveaxis(t, 0, -2)      # (ny, nx, layers, 3)
    return ((1 - fy) * ((1 - fx) * tt[j, i] + fx * tt[j, i + 1])
            + fy * ((1 - fx) * tt[j + 1, i] + fx * tt[j + 1, i + 1]))


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


def compile_lightfield(tables, *, a, b, e0, response_weights, depth_o: float,
                       factors: dict | None = None, alpha_nodes=None) -> Compiled:
    """Compile the model for the camera depth ``depth_o`` (``factors`` reused
    if given; ``alpha_nodes``: the multiple-scattering spread's kept shares
    from :func:`multiple_plan`, for tables with ``cone_offset_cdf_nodes``)."""
    a, b, e0 = (np.asarray(x, dtype=float) for x in (a, b, e0))
    w = np.asarray(response_weights, dtype=float)
    fac = factors if factors is not None else choose_irradiance_factors(tables)
    f = np.asarray(tables.get("forward_fraction", np.zeros(a.size)), dtype=float)
    split = "cone_offset_cdf" in tables
    if ("cone_offset_cdf_nodes" in tables) != (alpha_nodes is not None):
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
                    window_cos=float(tables["window_cos"][0]),
                    max_depth=float(tables["max_depth_m"][0]),
                    irradiance_error=(fac["max_error"], fac["rms_error"]),
                    alpha_nodes=alpha_nodes)


def node_alpha(comp: "Compiled", s) -> np.ndarray:
    """The multiple-scattering spread's share kept by a pixel at distance
    ``s``: ``comp.alpha_nodes`` interpolated at ``z = log3(1 + 2 mean(f b) s)``
    (:func:`surface_rgb`; the GPU's water table holds it in layer 0's fourth
    channel)."""
    from aquaspec.transport.lightfield.conespread import interp_nodes, lambda_coordinate
    return interp_nodes(comp.alpha_nodes, lambda_coordinate(np.mean(comp.fb)
                                                             * np.asarray(s, dtype=float)))


def multiple_plan(node_weights, pixels_per_radian: float, start_level: int | None = None):
    """``(L0, tables)`` of the multiple-scattering spread: the start level as
    :func:`spread_plan` chooses it, and :func:`aquaspec.transport.lightfield.conespread.node_level_tables`
    of the nodes' pyramid weights ``(K, L + 1)``
    (:func:`aquaspec.transport.lightfield.conespread.node_pyramid_weights`) from there."""
    from aquaspec.transport.lightfield.conespread import node_coordinates_are_integers, node_level_tables
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
    from aquaspec.transport.lightfield.conespread import level_shapes
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
    from aquaspec.transport.lightfield.conespread import bilinear_at
    h, w = shape
    centres = 4 * (np.arange(w) // 4) + 2.0 if factor >= 4 else np.arange(w) + 0.5
    return bilinear_at(coarse, (np.arange(h) + 0.5) / factor - 0.5, centres / factor - 0.5)


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
    :class:`Compiled`). Returns ``(lam, delta_hat, residual)``: the
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


def kept_projection(comp: "Compiled", alpha: float, projection=None):
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
    ``comp``: a :class:`Compiled` (or anything with its ``split``,
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


def surface_rgb(comp: Compiled, rho, s, surface_depth, n_y, alpha: float = 0.0):
    """Camera RGB of the targets' own light, ``(P, 3)`` (and its spread share when split).

    ``rho`` (P, n); ``s``, ``surface_depth``, ``n_y`` (P,). Returns
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
    from aquaspec.transport.lightfield.solve import bilinear
    s = np.asarray(s, dtype=float)[:, None]
    u = bilinear(comp.basis, surface_depth, n_y, comp.max_depth)         # (P, rank)
    ln_e = comp.k_depth * np.asarray(surface_depth, dtype=float)[:, None] \
        - comp.c_beam * s + u @ comp.g.T
    l = np.asarray(rho, dtype=float) * np.exp(ln_e)
    if comp.alpha_nodes is not None:
        from aquaspec.transport.lightfield.conespread import interp_nodes, lambda_coordinate
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
                   pyramid_weights=None, start_level: int | None = None) -> np.ndarray:
    """The NumPy twin of the GPU light-field pass: (H, W, 3) linear camera RGB.

    With ``comp.split`` the cone's share is spread over the image with the
    pyramid ``pyramid_weights`` (:func:`aquaspec.transport.lightfield.conespread.pyramid_weights`),
    starting at the level of :func:`spread_plan` (``start_level`` overrides it).
    With ``comp.alpha_nodes`` (the multiple-scattering spread)
    ``pyramid_weights`` are the nodes' ``(K, L + 1)``
    (:func:`aquaspec.transport.lightfield.conespread.node_pyramid_weights`), ``comp`` compiled
    with :func:`multiple_plan`'s ``alpha``, and one pyramid holds every node's image
    (:func:`aquaspec.transport.lightfield.conespread.spread_nodes`).
    """
    from aquaspec.scene.gbuffer import PER_PIXEL
    from aquaspec.colour.reflectance import sigmoid_at as sigmoid_reflectance
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
        pp = mat == PER_PIXEL
        rho = np.zeros((mat.size, comp.c_beam.size))
        rho[pp] = sigmoid_reflectance(gbuffer.sigmoid.reshape(-1, 3)[hit][pp],
                                      np.asarray(sigmoid_centers_t, dtype=float))
        rho[~pp] = mb[mat[~pp]]
        sd = np.maximum(d_o - s[hit] * v_y[hit], 0.0)
        parts = surface_rgb(comp, rho, s[hit], sd,
                            gbuffer.normal[..., 1].reshape(-1)[hit].astype(float), alpha)
        rgb[hit] += parts[0]
        if comp.split:
            cone[hit] += parts[1]
    h, w = cam.height, cam.width
    rgb = rgb.reshape(h, w, 3)
    if comp.split:
        from aquaspec.transport.lightfield.conespread import spread
        cone = cone.reshape((h, w) + cone.shape[1:])
        ys, xs = coarse_sample_pixels(h, w, start)
        coarse = cone[ys, xs].mean(axis=2)
        if multiple:
            from aquaspec.transport.lightfield.conespread import spread_nodes
            composite = spread_nodes(coarse, levels["a"])
        elif coarse_w.size > 1:
            composite = spread(coarse, coarse_w)
        else:
            composite = coarse_w[0] * coarse
        rgb = rgb + upsample_groups(composite, 2 ** start, (h, w))
    if not np.all(np.isfinite(rgb)):
        raise AquaspecError("the compiled light field produced NaN or infinity")
    return rgb
