"""The scene's own shadow in the water's light field, to first order (NumPy model).

The light-field model's in-scattering comes from a horizontally uniform,
one-dimensional light field: water with nothing in it. A target blocks
part of that field, so the water in front of it and below it receives
less light than open water, and the veil a camera sees in front of a
target's lower half is too bright (measured against the path tracer,
Petzold's phase function, Jerlov II, 3 m: +18-35 %; see the README's
"Where it is weakest"). The forward cone (``lightfield_tables(forward_cone_deg=...)``)
already takes the light blocked inside the cone, with the radiance of the
pixel's own direction ``L_bg(d, v')``; this module adds what that leaves
out: the blocked light outside the cone, and inside it the difference
between the radiance of the blocked direction and the pixel's.

For a camera ray (direction ``v``, length ``T``: the hit's distance, or
where the last surface ends) the radiance that the scene's surfaces take
away is

    dL = int_0^T dt exp(-k t) b int_{blocked} p(w . v) exp(-k r)
         [(L_bg(d_y, w) - L_s) - [w . v > cos theta_c] (L_bg(d_y, v') - L_s)] dw

with ``x = o + t v`` the point on the ray, ``w`` a direction from ``x`` that
meets a surface point ``y`` (depth ``d_y``, camera ray ``v'``) at distance
``r``, ``L_s`` that surface's Lambertian radiance ``rho E / pi``,
``L_bg(d, w)`` the open water's radiance seen looking along ``w``,
``theta_c`` the forward cone of the tables, and ``k = c - f(15 deg) b``
(light scattered within 15 degrees stays in the shadow's beam;
:data:`SHADOW_CONE_DEG`). It is the first scattering of the blocked light;
the blocked light's own multiple scattering is carried only by ``k``.

Which directions are blocked is read from the G-buffer: every surface the
camera sees blocks, for each point of each ray in front of it, the solid
angle it subtends there (``A |n . w| / r^2`` for a patch of area ``A``,
bounded by the on-axis disc's ``2 pi (1 - r / sqrt(r^2 + A / pi))`` near the
surface) if it faces that point. Surfaces outside the image or hidden from
the camera cast no shadow here. The sum runs over blocks of pixels
(sources) for rays through a coarse grid of pixels (receivers), as a
cumulative integral over ``t``; each pixel then takes the cumulative value
at its own ray length, interpolated bilinearly between receivers and
linearly in ``t``, so the shadow's edge follows the pixel's own hit.

Measured (helper experiment, 2026-11-24, a version of this term evaluated
with the board's plane as the occluder): subtracted from the light-field
model with the multiple-scattering cone spread, the grey patch's error
against Mitsuba went from +13.0 to +1.1 % in Jerlov II, +5.6 to -0.1 % in
IB and +13.6 to +3.7 % in 3C (3 m, Petzold, 28 cameras). With the
single-scattering spread it over-corrects: the term belongs with
``spread_scattering="multiple"``.
"""

from __future__ import annotations

import numpy as np

from .errors import AquaspecError

#: Forward cone (degrees) whose scattering stays in the shadow's beam:
#: ``k = c - f(SHADOW_CONE_DEG) b``. In the helper experiment 15 brought
#: Petzold II / IB / 3C targets within +1.1 / -0.1 / +3.7 %; 40
#: over-corrected 3C (-4.5 %); the full extinction ``c`` made the term 5x
#: too small.
SHADOW_CONE_DEG = 15.0
#: Receivers (coarse pixels whose rays are integrated) at most along the
#: image's longer side, and source blocks at most in the image.
RECEIVERS_LONG_SIDE = 32
MAX_SOURCES = 1500
#: Nodes of the cumulative integral along the rays.
T_NODES = 48
#: Nodes of the per-band phase table in angle (geometric towards forward).
PHASE_NODES = 512
#: Near a hit the source blocks are too coarse: the last stretch of each
#: hit pixel's ray, NEAR_BLOCKS source blocks long (at the hit's distance),
#: is integrated over directions instead, with the surface's own plane as
#: the occluder where the G-buffer agrees (:func:`_near_field`).
NEAR_BLOCKS = 2.5
#: Quadrature of the near field: nodes along the ray, angles from the ray's
#: direction (geometric cells from NEAR_THETA_MIN rad to pi) and azimuths.
NEAR_U_NODES = 6
NEAR_THETA_CELLS = 32
NEAR_THETA_MIN = 1e-3
NEAR_PHI_CELLS = 12


def phase_table(method, b, wavelength_nm=None, **params):
    """``(theta nodes (m,), values (n, m))``: the band phase functions at angles
    geometric towards forward (mixed with pure water as
    :func:`aquaspec.phase.band_cone_fraction`)."""
    from .phase import PhaseFunction, PureWaterPhase, get_phase, pure_water_fraction
    phase = method if isinstance(method, PhaseFunction) else get_phase(method, **params)
    theta = np.concatenate([[0.0], np.geomspace(1e-5, np.pi, PHASE_NODES - 1)])
    mu = np.cos(theta)
    frac_w = pure_water_fraction(phase, b, wavelength_nm)
    p = phase.value(mu)
    values = p[None, :] + frac_w[:, None] * (PureWaterPhase().value(mu) - p)[None, :]
    return theta, values


def shadow_tables(lf, depth, cosine, *, phase, b, wavelength_nm=None, **phase_params) -> dict:
    """The tables :func:`ambient_shadow` reads, for ``lightfield_tables(ambient_shadow=True)``:
    ``"radiance_per_e0"`` (n, n_depth, n_mu) the open water's radiance ``L_bg(d, w_y)/E0``
    on the tables' axes, ``"shadow_theta"`` / ``"shadow_phase"`` (:func:`phase_table`)
    and ``"shadow_extinction"`` (n,) ``k = c - f(15 deg) b``."""
    from .phase import band_cone_fraction
    theta, values = phase_table(phase, b, wavelength_nm, **phase_params)
    f = band_cone_fraction(phase, SHADOW_CONE_DEG, b, wavelength_nm, **phase_params)
    return {"radiance_per_e0": lf.radiance(np.asarray(depth)[:, None],
                                           np.asarray(cosine)[None, :]),
            "shadow_theta": theta, "shadow_phase": values,
            "shadow_extinction": lf.c - f * np.asarray(b, dtype=float)}


def _grid(n_px: int, step: int) -> np.ndarray:
    """Centres (pixel-edge coordinates) of ``ceil(n_px / step)`` blocks of ``step`` pixels."""
    k = np.arange(-(-n_px // step))
    return step * k + 0.5 * step


def _directions(cam, x, y) -> np.ndarray:
    """Unit rays through pixel-edge coordinates ``x`` (columns) and ``y`` (rows)."""
    d = (cam.right * ((x - cam.cx) / cam.fx)[..., None]
         - cam.true_up * ((y - cam.cy) / cam.fy)[..., None] + cam.forward)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _sources(cam, distance, normal, surface_radiance, hit):
    """Blocks of hit pixels: area (m^2), mean point, normal, camera ray's v_y and radiance."""
    hgt, wid = distance.shape
    step = max(1, int(np.ceil(np.sqrt(hgt * wid / MAX_SOURCES))))
    dirs = cam.ray_directions()
    fwd_cos = np.clip(dirs @ cam.forward, 1e-6, 1.0)
    s = np.where(hit, distance, 0.0)
    cos_n = np.clip(-np.sum(normal * dirs, axis=-1), 0.05, 1.0)
    # A pixel's solid angle seen from the camera is cos^3 / (fx fy).
    area = np.where(hit, s * s * fwd_cos ** 3 / (cam.fx * cam.fy) / cos_n, 0.0)
    point = cam.position + s[..., None] * dirs

    def blocks(x):
        hb, wb = -(-hgt // step), -(-wid // step)
        pad = [(0, hb * step - hgt), (0, wb * step - wid)] + [(0, 0)] * (x.ndim - 2)
        xp = np.pad(x, pad)
        return xp.reshape((hb, step, wb, step) + x.shape[2:]).sum(axis=(1, 3))

    a_sum = blocks(area)
    keep = a_sum > 0
    w = np.where(keep, a_sum, 1.0)
    pts = blocks(area[..., None] * point)[keep] / w[keep][:, None]
    nrm = blocks(area[..., None] * normal)[keep]
    nrm = nrm / np.maximum(np.linalg.norm(nrm, axis=-1, keepdims=True), 1e-12)
    rad = blocks(area[..., None] * surface_radiance)[keep] / w[keep][:, None]
    ray = pts - cam.position
    v_y = ray[:, 1] / np.linalg.norm(ray, axis=-1)
    return a_sum[keep], pts, nrm, v_y, rad, step


def ambient_shadow(tables, camera, distance, normal, surface_radiance, *, b, e0,
                   hit=None, progress=None) -> np.ndarray:
    """The radiance the scene's surfaces take from the water's light field (module docstring).

    Parameters
    ----------
    tables : dict
        :func:`aquaspec.lightfield.lightfield_tables` with ``ambient_shadow=True``.
    camera : Camera
    distance : (H, W) array
        Hit distance per pixel, m (``inf`` where the ray meets no surface
        before the water's surface).
    normal : (H, W, 3) array
        Unit surface normals (facing the camera where hit).
    surface_radiance : (H, W, n) array
        The surfaces' Lambertian radiance ``rho E / pi`` per band (0 where no hit).
    b, e0 : (n,) arrays
        Scattering coefficient (1/m) and downwelling irradiance below the surface.
    hit : (H, W) bool array, optional
        Which pixels hit a surface (default: finite ``distance``).
    progress : callable, optional
        Called with a fraction done.

    Returns
    -------
    (H, W, n) float64
        ``dL`` per pixel and band, to subtract from the model's radiance.
    """
    for key in ("radiance_per_e0", "shadow_phase", "shadow_theta", "shadow_extinction"):
        if key not in tables:
            raise AquaspecError(f"the light-field tables have no {key!r}; make them with "
                                "lightfield_tables(..., ambient_shadow=True)")
    from .lightfield import bilinear
    cam = camera
    distance = np.asarray(distance, dtype=float)
    hgt, wid = distance.shape
    if (hgt, wid) != (cam.height, cam.width):
        raise AquaspecError(f"distance has shape {distance.shape}; the camera is "
                            f"{cam.height}x{cam.width}")
    hit = np.isfinite(distance) if hit is None else np.asarray(hit, dtype=bool)
    b = np.asarray(b, dtype=float)
    e0 = np.asarray(e0, dtype=float)
    n = b.size
    out = np.zeros((hgt, wid, n))
    if not np.any(hit):
        return out
    area, pts, nrm, vy_src, l_s, src_step = _sources(cam, distance, np.asarray(normal, dtype=float),
                                           np.asarray(surface_radiance, dtype=float), hit)
    d_max = float(tables["max_depth_m"][0])
    lrad = np.asarray(tables["radiance_per_e0"], dtype=float)
    d_src = np.clip(-pts[:, 1], 0.0, None)
    # The in-cone part the forward cone already took: L_bg(d_y, v') - L_s.
    cone_cos = np.cos(np.radians(float(np.asarray(tables.get("forward_cone_deg", [0.0]))[0])))
    in_cone_dl = bilinear(lrad, d_src, vy_src, d_max) * e0 - l_s
    theta_nodes = np.asarray(tables["shadow_theta"], dtype=float)
    phase = np.asarray(tables["shadow_phase"], dtype=float)
    k = np.asarray(tables["shadow_extinction"], dtype=float)

    # Receivers: rays through a coarse grid; t nodes up to the farthest source.
    step = max(1, int(np.ceil(max(hgt, wid) / RECEIVERS_LONG_SIDE)))
    ry, rx = _grid(hgt, step), _grid(wid, step)
    rdir = _directions(cam, rx[None, :], ry[:, None]).reshape(-1, 3)
    t_max = float(np.max(np.linalg.norm(pts - cam.position, axis=-1)))
    t = np.linspace(0.0, t_max, T_NODES)
    g = np.zeros((rdir.shape[0], T_NODES, n))
    o = cam.position
    for q, v in enumerate(rdir):
        x = o + t[:, None] * v                                  # (K, 3)
        w = pts[None, :, :] - x[:, None, :]                     # (K, M, 3)
        r = np.maximum(np.linalg.norm(w, axis=-1), 1e-9)
        u = w / r[..., None]
        facing = np.maximum(-np.sum(nrm[None] * u, axis=-1), 0.0)
        disc = 2 * np.pi * (1.0 - r / np.sqrt(r * r + area / np.pi))
        solid = facing * np.minimum(area / (r * r), disc)
        live = solid > 0
        if not np.any(live):
            continue
        kk, mm = np.nonzero(live)
        mu = np.sum(u[kk, mm] * v, axis=-1)
        th = np.arccos(np.clip(mu, -1.0, 1.0))
        p = np.stack([np.interp(th, theta_nodes, phase[i]) for i in range(n)], axis=-1)
        lbg = bilinear(lrad, d_src[mm], u[kk, mm, 1], d_max) * e0
        dl = lbg - l_s[mm] - (mu > cone_cos)[:, None] * in_cone_dl[mm]
        att = np.exp(-k * (t[kk] + r[kk, mm])[:, None])
        contrib = (b * p * att * dl) * solid[kk, mm][:, None]
        np.add.at(g[q], kk, contrib)
        if progress is not None:
            progress((q + 1) / rdir.shape[0])
    # Cumulative integral over t (trapezoid), then per pixel at its own ray length.
    cum = np.concatenate([np.zeros((g.shape[0], 1, n)),
                          np.cumsum(0.5 * (g[:, 1:] + g[:, :-1]) * np.diff(t)[None, :, None],
                                    axis=1)], axis=1)
    cum = cum.reshape(ry.size, rx.size, T_NODES, n)
    dirs = cam.ray_directions()
    nrm_img = np.asarray(normal, dtype=float)
    # The near field's stretch of each hit pixel's ray (module constants).
    cos_in = np.clip(-np.sum(nrm_img * dirs, axis=-1), 0.25, 1.0)
    near_len = np.where(hit, NEAR_BLOCKS * src_step * np.where(hit, distance, 0.0)
                        / (cam.fx * cos_in), 0.0)
    length = np.clip(np.where(hit, distance - near_len, t_max), 0.0, t_max)
    # Up rays without a hit end at the water surface.
    d_o = -float(o[1])
    up = (dirs[..., 1] > 0) & ~hit
    length = np.where(up, np.minimum(length, d_o / np.where(up, dirs[..., 1], 1.0)), length)
    ft = length / t_max * (T_NODES - 1) if t_max > 0 else np.zeros_like(length)
    i_t = np.minimum(np.floor(ft).astype(int), T_NODES - 2)
    f_t = (ft - i_t)[..., None]
    from .conespread import bilinear_at
    rows = (np.arange(hgt) + 0.5 - ry[0]) / step if ry.size > 1 else np.zeros(hgt)
    cols = (np.arange(wid) + 0.5 - rx[0]) / step if rx.size > 1 else np.zeros(wid)
    # (Bilinear in the receivers for every t node is (H, W, K, n): by rows of the image.)
    for r0 in range(hgt):
        line = bilinear_at(cum, rows[r0:r0 + 1], cols)[0]      # (W, K, n)
        j = np.arange(wid)
        lo = line[j, i_t[r0]]
        hi = line[j, i_t[r0] + 1]
        out[r0] = lo + (hi - lo) * f_t[r0]
    out += _near_field(cam, dirs, distance, nrm_img, np.asarray(surface_radiance, dtype=float),
                       hit, near_len, lrad=lrad, d_max=d_max, e0=e0, b=b, k=k,
                       theta_nodes=theta_nodes, phase=phase, cone_cos=cone_cos)
    if not np.all(np.isfinite(out)):
        raise AquaspecError("the ambient shadow came out non-finite; check the G-buffer")
    return out


def _near_field(cam, dirs, distance, normal, surface_radiance, hit, near_len, *, lrad, d_max,
                e0, b, k, theta_nodes, phase, cone_cos) -> np.ndarray:
    """The shadow term over the last ``near_len`` of each hit pixel's ray.

    Directions from each point ``x`` there (a quadrature around the ray's
    direction) meet the hit's tangent plane at ``q``; ``q`` blocks if the
    G-buffer sees a surface at ``q``'s distance there (2 % or 2 cm), so the
    plane's edges are the G-buffer's. Returns (H, W, n)."""
    from .lightfield import bilinear
    hgt, wid = distance.shape
    n = b.size
    out = np.zeros((hgt, wid, n))
    o = cam.position
    # Quadrature: Gauss-Legendre in u (distance back from the hit along the
    # ray), cells geometric in theta (midpoint) and uniform in phi.
    gu, gw = np.polynomial.legendre.leggauss(NEAR_U_NODES)
    edges = np.concatenate([[0.0], np.geomspace(NEAR_THETA_MIN, np.pi, NEAR_THETA_CELLS)])
    th = 0.5 * (edges[1:] + edges[:-1])
    dth = np.cos(edges[:-1]) - np.cos(edges[1:])               # int sin theta d theta
    ph = (np.arange(NEAR_PHI_CELLS) + 0.5) * 2 * np.pi / NEAR_PHI_CELLS
    th_g, ph_g = np.meshgrid(th, ph, indexing="ij")
    dw = (dth[:, None] * np.full(NEAR_PHI_CELLS, 2 * np.pi / NEAR_PHI_CELLS)).reshape(-1)
    ct, st = np.cos(th_g).reshape(-1), np.sin(th_g).reshape(-1)
    cp, sp = np.cos(ph_g).reshape(-1), np.sin(ph_g).reshape(-1)
    p_dir = np.stack([np.interp(th_g.reshape(-1), theta_nodes, phase[i]) for i in range(n)],
                     axis=-1)                                   # (J, n)
    in_cone = ct > cone_cos
    ii, jj = np.nonzero(hit & (near_len > 0))
    chunk = 32
    for c0 in range(0, ii.size, chunk):
        pi, pj = ii[c0:c0 + chunk], jj[c0:c0 + chunk]
        v = dirs[pi, pj]                                        # (P, 3)
        nrm = normal[pi, pj]
        s = distance[pi, pj]
        u_len = near_len[pi, pj]
        # A frame around v.
        e1 = np.cross(v, np.where(np.abs(v[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]]))
        e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
        e2 = np.cross(v, e1)
        w = (ct[None, :, None] * v[:, None, :] + (st * cp)[None, :, None] * e1[:, None, :]
             + (st * sp)[None, :, None] * e2[:, None, :])      # (P, J, 3)
        towards = -np.sum(w * nrm[:, None, :], axis=-1)         # (P, J): > 0 meets the plane
        u = 0.5 * (gu[None, :] + 1.0) * u_len[:, None]          # (P, U)
        wu = 0.5 * gw[None, :] * u_len[:, None]
        h = u * np.clip(-np.sum(v * nrm, axis=-1), 0.0, 1.0)[:, None]   # height above the plane
        r = h[:, :, None] / np.where(towards > 1e-6, towards, np.inf)[:, None, :]   # (P, U, J)
        x = (o + (s[:, None] - u)[..., None] * v[:, None, :])   # (P, U, 3)
        q = x[:, :, None, :] + r[..., None] * w[:, None, :, :]  # (P, U, J, 3)
        dq = q - o
        z = dq @ cam.forward
        zs = np.where(z > 1e-9, z, 1.0)
        px = cam.cx + cam.fx * (dq @ cam.right) / zs
        py = cam.cy - cam.fy * (dq @ cam.true_up) / zs
        col = np.floor(px).astype(int)
        row = np.floor(py).astype(int)
        inside = (z > 1e-9) & (col >= 0) & (col < wid) & (row >= 0) & (row < hgt) & np.isfinite(r)
        cc, rr = np.clip(col, 0, wid - 1), np.clip(row, 0, hgt - 1)
        dist_q = np.linalg.norm(dq, axis=-1)
        seen = distance[rr, cc]
        blocked = inside & hit[rr, cc] & (np.abs(np.where(hit[rr, cc], seen, 0.0) - dist_q)
                                          < np.maximum(0.02 * dist_q, 0.02))
        if not np.any(blocked):
            continue
        a, bu, bj = np.nonzero(blocked)
        qq = q[a, bu, bj]
        d_q = np.clip(-qq[:, 1], 0.0, None)
        l_s = surface_radiance[rr[a, bu, bj], cc[a, bu, bj]]
        l_bg = bilinear(lrad, d_q, w[a, bj, 1], d_max) * e0
        l_v = bilinear(lrad, d_q, dq[a, bu, bj, 1] / dist_q[a, bu, bj], d_max) * e0
        dl = l_bg - l_s - in_cone[bj][:, None] * (l_v - l_s)
        tt = s[a] - u[a, bu]
        att = np.exp(-k * (tt + r[a, bu, bj])[:, None])
        val = b * p_dir[bj] * att * dl * (dw[bj] * wu[a, bu])[:, None]
        np.add.at(out, (pi[a], pj[a]), val)
    return out
