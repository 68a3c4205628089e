"""The water's own ambient shadow: in-scattering lost along a camera ray (first order).

The light field's in-scattering is that of open water. Under a ledge, or
in front of a wall, the water itself sees part of its sphere of directions
blocked, so the light it scatters towards the camera is lower. At a point
``y`` of a camera ray (look direction ``v``), with the directions ``w_k``,
solid angles ``dw_k``, visibility ``V_k`` and occluder distance ``s_k`` of
:class:`aquaspec.scene.occlusion.OcclusionMaps` (looked up at ``y`` over
the whole sphere: a point in the water has no normal,
:func:`water_visibility`), the share of the in-scattering the occluders
take away is

    R_i(y) = sum_k q_k (1 - V_k) exp(-c*_i s_k) L_i(d'_k, w_k) dw_k
             / sum_k q_k L_i(d_y, w_k) dw_k,

the sums over the directions *outside the forward cone* of ``v``
(``v . w_k <= cos theta_c``: the cone's share ``f b L(y, v)`` is the
camera ray's own, carried by its extinction ``c - f b`` and by the cone
spread), with the surfaces' loss per direction
(:mod:`aquaspec.transport.lightfield.occlusion`: the water in front of the
occluder still scatters, ``d'_k`` the occluder's depth) and ``q_k`` the
phase function's weight ``p(v . w_k)`` (:func:`blocked_share`). The
in-scattering itself comes from the light field's tables through the
transfer equation along ``v`` (:func:`out_of_cone_source`): the open-water
radiance obeys ``dL/dt = -c L + j`` along its line of sight, so

    j_out(d, v) = j - f b L = (c - f b) L(d, v) + v_y dL/dd,

the light field's own in-scattering outside the cone whatever its phase
function. The camera ray then loses (:func:`water_shadow`)

    dL_i = int_0^S exp(-(c_i - f_i b_i) t) j_out,i(y(t), v) R_i(y(t)) dt,

to the hit ``S``, or, in open water, to the water surface, the seabed or
:data:`OPEN_WATER_OPTICAL_DEPTH` optical depths; ``t`` on :data:`RAY_NODES`
intervals equal in the band-mean transmittance, the source taken
at each interval's middle and ``exp(-k_i t)`` integrated exactly per band.

*The phase function.* The light-field tables do not carry it, so ``q``
is 1 unless given (``phase``: isotropic weighting of the blocked
directions, exact for isotropic water; for forward-peaked water it
overstates the share of the steep downwelling light).

*Left out*: the water between a shaded surface and its occluder is in
shadow too (second order in the surfaces' loss), and the light the
occluders reflect (issue 36 item 3).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from aquaspec.errors import AquaspecError

#: Nodes along each camera ray.
RAY_NODES = 16
#: Open-water rays are followed this many band-mean optical depths (c - f b).
OPEN_WATER_OPTICAL_DEPTH = 8.0
#: Depth step of the source's derivative ``dL/dd``, m.
DEPTH_STEP_M = 0.05
#: Points per chunk (arrays are P x K x n).
_CHUNK = 2048
#: Normals whose facing half-spheres cover the sphere (each direction is
#: looked up in the first that faces it).
_AXES = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0],
                  [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])


def water_visibility(maps):
    """A function ``points (P, 3) -> (V, s)`` (P, K) over the whole sphere
    for points in the water (no normal, no offset off a surface), from
    :class:`aquaspec.scene.occlusion.OcclusionMaps`."""
    bare = replace(maps, normal_offset_texels=0.0)
    facing = maps.directions @ _AXES.T > 0.0                   # (K, 6)
    first = np.argmax(facing, axis=1)

    def visibility(points):
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        vis = np.ones((len(p), maps.k))
        dist = np.full((len(p), maps.k), np.inf)
        for a, axis in enumerate(_AXES):
            mine = first == a
            if not np.any(mine):
                continue
            v, s = bare.visibility(p, np.broadcast_to(axis, p.shape))
            vis[:, mine], dist[:, mine] = v[:, mine], s[:, mine]
        return vis, dist
    return visibility


def blocked_share(weights, depth_m, view, vis, dist, *, cone_cos: float = 1.0,
                  phase=None) -> np.ndarray:
    """``R_i`` (P, n) (module docstring) at points of depths (P,) looking
    along unit ``view`` (P, 3), with visibility and occluder distance (P, K)
    on the directions of ``weights``
    (:class:`aquaspec.transport.lightfield.occlusion.OcclusionWeights`).
    ``cone_cos``: directions with ``view . w_k > cone_cos`` are the
    forward cone's and left out; ``phase``: ``q(cos)`` (any shape), None
    for 1."""
    d = np.maximum(np.asarray(depth_m, dtype=float).reshape(-1), 0.0)
    v = np.asarray(view, dtype=float).reshape(-1, 3)
    k_dirs = weights.directions.shape[0]
    vis = np.clip(np.asarray(vis, dtype=float).reshape(-1, k_dirs), 0.0, 1.0)
    dist = np.asarray(dist, dtype=float).reshape(-1, k_dirs)
    if not (len(d) == len(v) == len(vis) == len(dist)):
        raise AquaspecError(f"water occlusion: {len(d)} depths, {len(v)} view directions, "
                            f"{len(vis)} visibilities, {len(dist)} distances; accepted: one "
                            "each per point")
    if np.any(np.isnan(dist)) or np.any(dist < 0):
        raise AquaspecError("water occlusion: distances must be >= 0 or inf, never NaN")
    cos = v @ weights.directions.T                                   # (P, K)
    q = np.ones_like(cos) if phase is None else np.asarray(phase(cos), dtype=float)
    g = np.where(cos > cone_cos, 0.0, q) * weights.solid_angle       # (P, K)
    w_y = weights.directions[:, 1][None, :]
    up = w_y > 0
    to_top = np.where(up, d[:, None] / np.where(up, w_y, 1.0), np.inf)
    s = np.minimum(dist, to_top)
    fin = np.isfinite(s)
    d_occ = np.clip(d[:, None] - np.where(fin, s, 0.0) * w_y, 0.0, weights.seabed_depth_m)
    here = weights.radiance(np.broadcast_to(d[:, None], g.shape))    # (P, K, n)
    there = weights.radiance(d_occ)
    total = np.einsum("pk,pkn->pn", g, here)
    atten = np.exp(-weights.extinction * np.where(fin, s, 0.0)[..., None])
    lost = np.einsum("pk,pkn->pn", np.where(fin, (1.0 - vis) * g, 0.0), there * atten)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(total > 0, lost / np.where(total > 0, total, 1.0), 0.0)
    return np.clip(ratio, 0.0, 1.0)


def out_of_cone_source(tables, *, a, b, e0, depth_m, v_y) -> np.ndarray:
    """``j_out`` (P, n) at depths (P,) for looks ``v_y`` (P,) (module
    docstring) from :class:`aquaspec.transport.lightfield.tables.LightfieldTables`:
    ``(c - f b) L + v_y dL/dd``, ``L`` the open-water radiance
    (:meth:`LightfieldTables.pixel_radiance
    <aquaspec.transport.lightfield.tables.LightfieldTables.pixel_radiance>`,
    ``S = inf``), the derivative by central differences (one-sided at the
    surface and the seabed); negative values (the tables' interpolation) are cut to 0."""
    d = np.asarray(depth_m, dtype=float).reshape(-1, 1)
    v = np.asarray(v_y, dtype=float).reshape(-1, 1)
    bed = tables.seabed_depth_m

    def rad(depth):
        return tables.pixel_radiance(a=a, b=b, e0=e0, depth_o=depth, v_y=v,
                                     s=np.full(depth.shape, np.inf))
    lo = np.clip(d - DEPTH_STEP_M, 0.0, bed)
    hi = np.clip(d + DEPTH_STEP_M, 0.0, bed)
    mid = np.clip(d, 0.0, bed)
    span = np.maximum(hi - lo, 1e-12)
    deriv = (rad(hi) - rad(lo)) / span
    j = tables.ray_extinction(a, b) * rad(mid) + v * deriv
    return np.maximum(j, 0.0)


def ray_nodes(k_mean, length, n_nodes: int = RAY_NODES):
    """``(t (P, M), edges (P, M + 1))``: ``M`` intervals of rays of lengths
    (P,) equal in ``1 - exp(-k_mean t)``, and a node in each (its middle in
    that transmittance)."""
    s = np.asarray(length, dtype=float).reshape(-1, 1)
    k = float(k_mean)
    span = -np.expm1(-k * s)                                         # 1 - T(S)
    u_edge = np.arange(n_nodes + 1) / n_nodes
    u_mid = (np.arange(n_nodes) + 0.5) / n_nodes
    edges = -np.log1p(-np.minimum(u_edge[None, :] * span, 1.0 - 1e-15)) / k
    edges[:, -1] = np.minimum(edges[:, -1], s[:, 0])
    return -np.log1p(-u_mid[None, :] * span) / k, edges


def interval_weights(edges, k) -> np.ndarray:
    """``int e^{-k_i t} dt`` over each interval (P, M, n): exact per band, so
    bands far from the mean extinction are integrated as well as the rest
    (the source is taken constant over an interval)."""
    k = np.asarray(k, dtype=float)
    t0, t1 = edges[:, :-1, None], edges[:, 1:, None]
    return np.exp(-k * t0) * -np.expm1(-k * (t1 - t0)) / k


def water_shadow(tables, weights, visibility, origin, dirs, length, *, a, b, e0,
                 cone_cos: float = 1.0, phase=None, n_nodes: int = RAY_NODES) -> np.ndarray:
    """``dL`` (P, n): the in-scattering camera rays lose to the scene's
    occlusion of the water (module docstring), to subtract from their radiance.

    ``visibility``: ``points (Q, 3) -> (V, s)`` (Q, K) on the directions of
    ``weights`` (:func:`water_visibility`); ``origin`` (3,) the camera,
    ``dirs`` (P, 3) unit rays, ``length`` (P,) the hit's distance or inf
    (open water: cut at the water surface, the seabed and
    :data:`OPEN_WATER_OPTICAL_DEPTH`)."""
    o = np.asarray(origin, dtype=float).reshape(3)
    v = np.asarray(dirs, dtype=float).reshape(-1, 3)
    s = np.asarray(length, dtype=float).reshape(-1)
    a, b, e0 = (np.asarray(x, dtype=float) for x in (a, b, e0))
    if len(s) != len(v) or np.any(np.isnan(s)) or np.any(s < 0):
        raise AquaspecError(f"water occlusion: {len(v)} rays and {len(s)} lengths; accepted: "
                            "one length >= 0 (or inf) per ray")
    k = tables.ray_extinction(a, b)
    k_mean = float(np.mean(k))
    d_o = -o[1]
    up, down = v[:, 1] > 0, v[:, 1] < 0
    with np.errstate(divide="ignore"):
        to_top = np.where(up, d_o / np.where(up, v[:, 1], 1.0), np.inf)
        to_bed = np.where(down, (tables.seabed_depth_m - d_o) / np.where(down, -v[:, 1], 1.0),
                          np.inf)
    end = np.minimum.reduce([s, to_top, to_bed,
                             np.full(s.shape, OPEN_WATER_OPTICAL_DEPTH / k_mean)])
    t, edges = ray_nodes(k_mean, end, n_nodes)                       # (P, M)
    pts = o + v[:, None, :] * t[..., None]                           # (P, M, 3)
    flat = pts.reshape(-1, 3)
    vis, dist = visibility(flat)
    out_flat = np.zeros((len(flat), k.size))
    hidden = np.flatnonzero(np.any((vis < 1.0) & np.isfinite(dist), axis=1))
    ray_of = np.repeat(np.arange(len(v)), n_nodes)
    for c0 in range(0, hidden.size, _CHUNK):
        idx = hidden[c0:c0 + _CHUNK]
        depth = -flat[idx, 1]
        share = blocked_share(weights, depth, v[ray_of[idx]], vis[idx], dist[idx],
                              cone_cos=cone_cos, phase=phase)
        j = out_of_cone_source(tables, a=a, b=b, e0=e0, depth_m=depth, v_y=v[ray_of[idx], 1])
        out_flat[idx] = j * share
    node = out_flat.reshape(len(v), n_nodes, k.size)
    dl = np.einsum("pmn,pmn->pn", interval_weights(edges, k), node)
    if not np.all(np.isfinite(dl)):
        raise AquaspecError("the water's occlusion came out non-finite; check the water "
                            "coefficients and the occlusion maps")
    return dl
