"""The scene's own shadow in the water's light field, to first order (NumPy).

Integrated from a G-buffer (:func:`aquaspec.shading.shade.scene_shadow`) for the
NumPy model and under the GPU renderer's image
(:meth:`aquaspec.rendering.renderer.Renderer.subtract_shadow`), the receivers' rays
spread over the machine's cores (:mod:`aquaspec.parallel`).

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
:data:`aquaspec.transport.lightfield.shadowphase.SHADOW_CONE_DEG`). It is the first
scattering of the blocked light; the blocked light's own multiple scattering is carried only by ``k``.

Which directions are blocked is read from the G-buffer, so only surfaces
the camera sees cast a shadow here, and only from their visible side.
Rays are integrated on a grid of receiver pixels (every few pixels):

- a ray that ends on a surface, over directions around the ray (the
  phase function's forward peak resolved, :meth:`ShadowContext.hit_rays`) from
  points graded towards the hit: a direction meets the hit's tangent
  plane at ``q``, which blocks where the G-buffer sees a surface at ``q``'s
  distance (so a planar target's edges are the G-buffer's; a curved one is
  taken as its tangent plane);
- an open-water ray, over blocks of hit pixels (sources, each its area
  ``A`` and normal ``n``, subtending ``A |n . w| / r^2`` from a point it faces,
  at most the on-axis disc's ``2 pi (1 - r / sqrt(r^2 + A / pi))``), with the
  phase function averaged over each block's solid angle and the radiance
  taken where that average puts its weight
  (:func:`aquaspec.transport.lightfield.shadowphase.disc_phase_table`), as a cumulative integral along the ray, read at each pixel's own length.

Each pixel interpolates bilinearly between the receivers around it that
are of its own kind (hit or open water), when those carry more than
:data:`SERVE_WEIGHT` of its weights; the others go to a grid twice as fine,
and so on down to their own ray, so that a thin structure costs receivers
along it rather than a ray per pixel (tests/transport/lightfield/test_shadow.py: four poles 4
pixels wide, 122 hit rays for their 1312 pixels). Measured against a direct integration over directions and
along the ray with the board's rectangle as the occluder
(``tests/transport/lightfield/test_shadow.py``, 96x72, Jerlov II, Petzold): within 1 % of the
term's size on the board's lower half, 2-4 % on its upper half and just
below it; with twice the direction cells each way the board's rows came
within 0.5 %, with 4x the source blocks and 2x the nodes along the ray the
row below within 2.5 %: what is left is the quadratures'.

Measured on the validation scene (Jerlov II, IB, 3C, 3 m, Petzold's phase
function, 96x72, 30 bands, Mitsuba at 4096 samples per pixel, 28 cameras,
region brightness; 2026-11-24), the light field with the multiple-scattering
cone spread without / with this term: grey patch +14.6 / +2.4 %, +5.4 /
-0.3 %, +13.4 / +3.3 %; 24 patches +8.3 / +2.1 %, +4.7 / +0.2 %, +7.6 /
+2.5 %. With the single-scattering spread it over-corrects (II: 24 patches
+1.1 / -5.1 %), because that spread keeps too much of a target's own
light on it: the term belongs with ``spread_scattering="multiple"``.
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.medium.phase_bands import mix_with_pure_water
from aquaspec.numerics import bilinear
from aquaspec.parallel import in_threads
from aquaspec.transport.lightfield.shadowphase import mixed_phase
from aquaspec.transport.lightfield.tables import (LightfieldTables, band_last_table,
                                                  table_cos_index, table_depth_index,
                                                  table_lookup)

#: Receivers (coarse pixels whose rays are integrated) at most along the
#: image's longer side, and source blocks at most in the image.
RECEIVERS_LONG_SIDE = 32
MAX_SOURCES = 1500
#: A pixel is interpolated from the receivers around it when those of its
#: own kind (hit or open water) carry more than this share of its bilinear
#: weights; otherwise it goes to a grid twice as fine (down to its own ray).
#: Against a direct integration at the board's edges (test_shadow.py's
#: scene, 96x72; the worst band) 0 / 0.5 / 0.75 left the worst pixels beside
#: the board at 33 / 12 / 12 % of the term's size and its top row at 36 / 36
#: / 5 %; 0.5 / 0.75 the rows above and below it at 21 / 11 % and 14 / 7 %.
#: The built-in scene at 1280x720, 8 bands, takes 988 / 1876 receivers'
#: rays with 0.5 / 0.75: the term 1.7-2.3 / 2.4-3.3 s with the rays on the
#: GPU (in NumPy, before its rays and interpolation were made faster, 7.5 /
#: 13.0 s).
SERVE_WEIGHT = 0.75
#: Nodes of the cumulative integral along the rays.
T_NODES = 48
#: Rays that end on a surface are integrated over directions instead (the
#: source blocks are too coarse where the forward peak of the phase
#: function meets them): nodes along the ray; angles from the ray's
#: direction in cells geometric from HIT_THETA_MIN to HIT_THETA_KNEE rad
#: (the forward peak), then even to pi (a target's edges seen from close);
#: azimuths.
HIT_U_NODES = 12
HIT_THETA_PEAK_CELLS = 20
HIT_THETA_WIDE_CELLS = 24
HIT_THETA_MIN = 1e-3
HIT_THETA_KNEE = 0.2
HIT_PHI_CELLS = 24


def _receiver_pixels(n_px: int, step: int) -> np.ndarray:
    """Every ``step``-th pixel from ``step // 2``, and the last pixel."""
    k = np.arange(step // 2, n_px, step)
    return k if k[-1] == n_px - 1 else np.append(k, n_px - 1)


def _sources(cam, dirs, distance, normal, surface_radiance, hit):
    """Blocks of hit pixels (``dirs``: the camera's rays): area (m^2), mean point,
    normal, camera ray's v_y and radiance."""
    hgt, wid = distance.shape
    step = max(1, int(np.ceil(np.sqrt(hgt * wid / MAX_SOURCES))))
    fwd_cos = np.clip(dirs @ cam.forward, 1e-6, 1.0)
    s = np.where(hit, distance, 0.0)
    normal = np.where(hit[..., None], normal, 0.0)     # (whatever open water holds)
    cos_n = np.clip(-np.sum(normal * dirs, axis=-1), 0.05, 1.0)
    # A pixel's solid angle seen from the camera is cos^3 / (fx fy).
    area = np.where(hit, s * s * fwd_cos ** 3 / (cam.fx * cam.fy) / cos_n, 0.0)
    point = cam.position + s[..., None] * dirs

    def blocks(x):              # (sums over step x step blocks, the last ones partial)
        rows = np.add.reduceat(x, np.arange(0, hgt, step), axis=0)
        return np.add.reduceat(rows, np.arange(0, wid, step), axis=1)

    a_sum = blocks(area)
    keep = a_sum > 0
    w = np.where(keep, a_sum, 1.0)
    pts = blocks(area[..., None] * point)[keep] / w[keep][:, None]
    nrm = blocks(area[..., None] * normal)[keep]
    nrm = nrm / np.maximum(np.linalg.norm(nrm, axis=-1, keepdims=True), 1e-12)
    rad = blocks(area[..., None] * surface_radiance)[keep] / w[keep][:, None]
    ray = pts - cam.position
    v_y = ray[:, 1] / np.linalg.norm(ray, axis=-1)
    return a_sum[keep], pts, nrm, v_y, rad


def ambient_shadow(tables: LightfieldTables, camera, distance, normal, surface_radiance, *, b, e0,
                   hit=None, progress=None, rays=None) -> np.ndarray:
    """The radiance the scene's surfaces take from the water's light field (module docstring).

    Parameters
    ----------
    tables : LightfieldTables
        :func:`aquaspec.transport.lightfield.bake.lightfield_tables` with ``ambient_shadow=True``.
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
        Called with a short message per grid of receivers.
    rays : optional
        Where the receivers' rays are integrated: ``None`` here in NumPy
        (:meth:`ShadowContext.hit_rays`, :meth:`ShadowContext.open_integrand`), or an
        object with the same two methods taking the context first, such as
        :class:`aquaspec.gpu.passes.shadow_rays.ShadowRays` (WGSL, the same maths).

    Returns
    -------
    (H, W, n) float64
        ``dL`` per pixel and band, to subtract from the model's radiance.
    """
    if tables.shadow is None:
        raise AquaspecError("the light-field tables have no shadow tables; make them with "
                            "lightfield_tables(..., ambient_shadow=True)")
    cam = camera
    distance = np.asarray(distance, dtype=float)
    hgt, wid = distance.shape
    if (hgt, wid) != (cam.height, cam.width):
        raise AquaspecError(f"distance has shape {distance.shape}; the camera is "
                            f"{cam.height}x{cam.width}")
    hit = np.isfinite(distance) if hit is None else np.asarray(hit, dtype=bool)
    b = np.asarray(b, dtype=float)
    n = b.size
    out = np.zeros((hgt, wid, n))
    if not np.any(hit):
        return out
    ctx = ShadowContext(tables, cam, distance, np.asarray(normal, dtype=float),
                        np.asarray(surface_radiance, dtype=float), hit, b,
                        np.asarray(e0, dtype=float))
    # Receivers: every step-th pixel (and the last) of each axis; pixels with
    # no receiver of their own kind around them go to a grid twice as fine,
    # and so on down to their own ray (thin structures and the water between
    # them cost receivers along them, not a ray per pixel).
    step = max(1, int(np.ceil(max(hgt, wid) / RECEIVERS_LONG_SIDE)))
    flat = out.reshape(-1, n)
    kind = hit.reshape(-1)
    length = ctx.open_length().reshape(-1)
    remaining = np.arange(hgt * wid)
    while remaining.size:
        ry, rx = _receiver_pixels(hgt, step), _receiver_pixels(wid, step)
        rec_kind = hit[np.ix_(ry, rx)]
        pi, pj = np.divmod(remaining, wid)
        idx, wgt, lonely = _neighbours(ry, rx, rec_kind, pi, pj, kind[remaining],
                                       SERVE_WEIGHT if step > 1 else 0.0)
        served = remaining[~lonely]
        idx, wgt = idx[~lonely], wgt[~lonely]
        # The receivers those pixels read, computed once each.
        need = np.unique(idx[wgt > 0])
        pos = np.zeros(ry.size * rx.size, dtype=int)
        pos[need] = np.arange(need.size)
        rr, rc = ry[need // rx.size], rx[need % rx.size]
        need_hit = hit[rr, rc]
        if progress is not None and need.size:
            progress(f"the scene's shadow: receivers {step} px apart for {served.size} of "
                     f"{hgt * wid} pixels, {int(need_hit.sum())} rays on surfaces and "
                     f"{int((~need_hit).sum())} in open water")
        # Rays that end on a surface: over directions (their own plane blocks).
        hit_tot = np.zeros((need.size, n))
        hit_tot[need_hit] = (ctx.hit_rays(rr[need_hit], rc[need_hit]) if rays is None
                             else rays.hit_rays(ctx, rr[need_hit], rc[need_hit]))
        # Open water: over the sources, cumulative along the ray, read at each
        # pixel's own length.
        cum = np.zeros((need.size, T_NODES, n))
        dirs = ctx.dirs[rr[~need_hit], rc[~need_hit]]
        cum[~need_hit] = ctx.cumulative(ctx.open_integrand(dirs) if rays is None
                                        else rays.open_integrand(ctx, dirs))
        at = pos[idx]                       # (weights 0 where a corner was not computed)
        sel = kind[served]
        flat[served[sel]] = _weighted_rows(hit_tot, at[sel], wgt[sel])
        q = np.flatnonzero(~sel)
        flat[served[q]] = ctx.at_length(cum, at[q], wgt[q], length[served[q]])
        remaining = remaining[lonely]
        if step == 1:                       # (every pixel is its own receiver there)
            break
        step = max(1, step // 2)
    if not np.all(np.isfinite(out)):
        raise AquaspecError("the ambient shadow came out non-finite; check the G-buffer")
    return out


def _neighbours(ry, rx, rec_kind, rows, cols, kind, serve=0.0):
    """For pixels ``(rows, cols)`` of kind ``kind`` (hit or not, each (P,)): the four
    receivers around each (flat indices into ``ry x rx``; ``rec_kind`` their
    kinds, (len(ry), len(rx))), their bilinear weights among those of the
    pixel's kind (normalised), and whether none is (lonely). A ray that
    grazes a silhouette is not taken for its neighbours across it."""
    fr = np.interp(rows, ry, np.arange(ry.size))
    fc = np.interp(cols, rx, np.arange(rx.size))
    i0 = np.minimum(np.floor(fr).astype(int), max(ry.size - 2, 0))
    j0 = np.minimum(np.floor(fc).astype(int), max(rx.size - 2, 0))
    i1, j1 = np.minimum(i0 + 1, ry.size - 1), np.minimum(j0 + 1, rx.size - 1)
    wr, wc = fr - i0, fc - j0
    corners = [(i0, j0, (1 - wr) * (1 - wc)), (i0, j1, (1 - wr) * wc),
               (i1, j0, wr * (1 - wc)), (i1, j1, wr * wc)]
    idx = np.stack([i * rx.size + j for i, j, _ in corners], -1)
    w = np.stack([wt * (rec_kind[i, j] == kind) for i, j, wt in corners], -1)
    total = w.sum(axis=-1)
    lonely = total <= serve
    return idx, w / np.where(lonely, 1.0, total)[:, None], lonely


class ShadowContext:
    """What both integrations read: the tables, the camera, the G-buffer and the sources.

    The GPU twins (:mod:`aquaspec.gpu.passes.shadow_hit`,
    :mod:`aquaspec.gpu.passes.shadow_open`) upload its arrays (``lrad_e0``,
    ``src_rows``, ``disc_all``, ``k``, ``mix``, ...) and integrate the same rays.
    """

    def __init__(self, tables, cam, distance, normal, surface_radiance, hit, b, e0):
        self.cam, self.distance, self.normal, self.hit = cam, distance, normal, hit
        self.l_s_img = surface_radiance
        self.b, self.e0 = b, e0
        self.dirs = cam.ray_directions()
        self.d_max = tables.max_depth_m
        sh = tables.shadow
        # (The radiance itself, each texel's bands together: most lookups are here.)
        self.lrad_e0 = band_last_table(sh.radiance_per_e0) * e0
        self.cone_cos = np.cos(np.radians(tables.forward_cone_deg))
        self.theta_nodes = np.asarray(sh.theta, dtype=float)
        self.phase = np.asarray(sh.phase, dtype=float)
        self.mix = np.asarray(sh.phase_mix, dtype=float)
        self.k = np.asarray(sh.extinction, dtype=float)
        self.disc_theta = np.asarray(sh.disc_theta, dtype=float)
        self.disc_alpha = np.asarray(sh.disc_alpha, dtype=float)
        # Both phase functions' cap means and the shift, (theta, alpha, 3).
        self.disc_all = np.ascontiguousarray(np.stack(
            [*np.asarray(sh.disc_phase, dtype=float),
             np.asarray(sh.disc_shift, dtype=float)], -1))
        self.area, self.pts, self.nrm, vy_src, self.l_s = _sources(
            cam, self.dirs, distance, normal, surface_radiance, hit)
        self.d_src = np.clip(-self.pts[:, 1], 0.0, None)
        # The radiance table's row at each source's depth (M, n_mu, n): the
        # open rays then interpolate in direction alone (the same bilinear
        # value, its depth step taken once per source).
        i, fx = table_depth_index(self.d_src, self.d_max, self.lrad_e0.shape[0])
        fx = fx[:, None, None]
        self.src_rows = (1 - fx) * self.lrad_e0[i] + fx * self.lrad_e0[i + 1]
        # The in-cone part the forward cone already took: L_bg(d_y, v') - L_s.
        self.in_cone_dl = self.l_bg(self.d_src, vy_src) - self.l_s
        self.t_max = float(np.max(np.linalg.norm(self.pts - cam.position, axis=-1)))
        self.t = np.linspace(0.0, self.t_max, T_NODES)

    def l_bg(self, depth, look_y):
        """The open water's radiance looking along a direction of up component ``look_y``."""
        return table_lookup(self.lrad_e0, depth, look_y, self.d_max, band_last=True)

    def l_src(self, look_y):
        """:meth:`l_bg` at the sources' depths, ``look_y`` (..., M): (..., M, n)."""
        nm = self.src_rows.shape[1]
        j, fy = table_cos_index(look_y, nm)
        fy = fy[..., None]
        flat = self.src_rows.reshape(-1, self.src_rows.shape[-1])
        k = np.arange(self.src_rows.shape[0]) * nm + j          # (flat indices: np.take)
        return (1 - fy) * np.take(flat, k, axis=0) + fy * np.take(flat, k + 1, axis=0)

    def open_length(self):
        """Where an open-water pixel's ray stops counting: the farthest source,
        or the water surface for up rays."""
        d_o = -float(self.cam.position[1])
        vy = self.dirs[..., 1]
        up = vy > 0
        return np.where(up, np.minimum(self.t_max, d_o / np.where(up, vy, 1.0)), self.t_max)

    def at_length(self, cum, rays, weights, length):
        """Cumulative integrals ``cum`` (R, K, n) of receiver rays ``rays`` (P, 4),
        read linearly at each pixel's ``length`` (P,) and weighted by ``weights``
        (P, 4): (P, n)."""
        ft = np.clip(np.asarray(length, dtype=float) / max(self.t_max, 1e-12), 0.0, 1.0) \
            * (T_NODES - 1)
        i = np.minimum(np.floor(ft).astype(int), T_NODES - 2)
        f = (ft - i)[:, None]
        # (A row per ray and node: the pixel's two nodes are rows i and i + 1.)
        flat = cum.reshape(-1, cum.shape[-1])
        at = rays * T_NODES + i[:, None]
        return (_weighted_rows(flat, at, weights) * (1.0 - f)
                + _weighted_rows(flat, at + 1, weights) * f)

    def open_integrand(self, rays):
        """The term's integrand at the nodes :attr:`t` along rays ``(R, 3)`` that end
        on no surface, summed over the source blocks: (R, K, n)."""
        g = np.zeros((rays.shape[0], T_NODES, self.b.size))
        for q, gq in enumerate(in_threads(self.open_ray, rays)):
            g[q] = gq
        return g

    def cumulative(self, g):
        """``int_0^t`` of integrands ``g`` (R, K, n) at the nodes :attr:`t` (trapezoids)."""
        steps = np.diff(self.t)[None, :, None]
        return np.concatenate([np.zeros((g.shape[0], 1, g.shape[2])),
                               np.cumsum(0.5 * (g[:, 1:] + g[:, :-1]) * steps, axis=1)], axis=1)

    def open_ray(self, v):
        """The integrand of :meth:`open_integrand` along one ray ``v``: (K, n)."""
        o, t = self.cam.position, self.t
        x = o + t[:, None] * v                                  # (K, 3)
        w = self.pts[None, :, :] - x[:, None, :]                # (K, M, 3)
        r = np.maximum(np.linalg.norm(w, axis=-1), 1e-9)
        u = w / r[..., None]
        facing = np.maximum(-np.sum(self.nrm[None] * u, axis=-1), 0.0)
        disc = 2 * np.pi * (1.0 - r / np.sqrt(r * r + self.area / np.pi))
        solid = facing * np.minimum(self.area / (r * r), disc)  # (K, M), 0: not facing
        mu = u @ v
        # The phase function averaged over the block (a cap of its solid
        # angle), and the radiance taken where it puts its weight: the
        # direction turned towards v by the p-weighted offset.
        th = np.arccos(np.clip(mu, -1.0, 1.0))
        cap = np.arccos(np.clip(1.0 - solid / (2 * np.pi), -1.0, 1.0))
        xi = np.interp(th, self.disc_theta, np.arange(self.disc_theta.size))
        yi = np.interp(cap, self.disc_alpha, np.arange(self.disc_alpha.size))
        p0, p1, shift = np.moveaxis(bilinear(self.disc_all, xi, yi), -1, 0)
        turn = np.minimum(shift, th)
        perp = v - mu[..., None] * u
        perp /= np.maximum(np.linalg.norm(perp, axis=-1, keepdims=True), 1e-12)
        look_y = np.cos(turn) * u[..., 1] + np.sin(turn) * perp[..., 1]
        dl = (self.l_src(look_y) - self.l_s
              - (mu > self.cone_cos)[..., None] * self.in_cone_dl)
        dl *= np.exp(-self.k * (t[:, None] + r)[..., None])
        # The band's phase function mixes p0 and p1: a sum over the blocks for each.
        return mix_with_pure_water(np.einsum("km,kmn->kn", solid * p0, dl),
                                   np.einsum("km,kmn->kn", solid * p1, dl), self.mix) * self.b

    def hit_quadrature(self):
        """The quadrature of :meth:`hit_rays` (its GPU twin uploads the same):
        ``(cos theta, sin theta cos phi, sin theta sin phi, dw, in the forward
        cone)`` per direction cell around the ray (J,) in the frame of
        :func:`ray_frames`, the cells' band phase functions (J, n), and the
        Gauss-Legendre nodes and weights on [0, 1] along the ray (U,)."""
        gx, gw = np.polynomial.legendre.leggauss(HIT_U_NODES)
        edges = np.concatenate([[0.0], np.geomspace(HIT_THETA_MIN, HIT_THETA_KNEE,
                                                    HIT_THETA_PEAK_CELLS),
                                np.linspace(HIT_THETA_KNEE, np.pi, HIT_THETA_WIDE_CELLS + 1)[1:]])
        th = np.repeat(0.5 * (edges[1:] + edges[:-1]), HIT_PHI_CELLS)
        dw = np.repeat(np.cos(edges[:-1]) - np.cos(edges[1:]),   # int sin theta d theta
                       HIT_PHI_CELLS) * (2 * np.pi / HIT_PHI_CELLS)
        phi = np.tile((np.arange(HIT_PHI_CELLS) + 0.5) * 2 * np.pi / HIT_PHI_CELLS,
                      edges.size - 1)
        p_dir = mixed_phase(np.stack([np.interp(th, self.theta_nodes, f) for f in self.phase]),
                       self.mix)
        ct, st = np.cos(th), np.sin(th)
        return ((ct, st * np.cos(phi), st * np.sin(phi), dw, ct > self.cone_cos), p_dir,
                0.5 * (gx + 1.0), 0.5 * gw)

    def hit_rays(self, rows, cols) -> np.ndarray:
        """The term along the rays of hit pixels ``(rows, cols)``, over directions.

        From points ``x`` on the ray (Gauss-Legendre in ``sqrt`` of the distance
        back from the hit, dense near it) a quadrature around the ray's
        direction; a direction meets the hit's tangent plane at ``q``, which
        blocks if the G-buffer sees a surface at ``q``'s distance there (2 % or
        2 cm), so the plane's edges are the G-buffer's. Returns (P, n)."""
        cam, hgt, wid = self.cam, *self.distance.shape
        n, o = self.b.size, cam.position
        (ct, c1, c2, dw, in_cone), p_dir, gx, gw = self.hit_quadrature()
        chunks = [(rows[c0:c0 + 16], cols[c0:c0 + 16]) for c0 in range(0, rows.size, 16)]

        def chunk(rc):
            pr, pc = rc
            out = np.zeros((pr.size, n))
            v, nrm, s = self.dirs[pr, pc], self.normal[pr, pc], self.distance[pr, pc]
            e1, e2 = ray_frames(v)
            w = (ct[None, :, None] * v[:, None, :] + c1[None, :, None] * e1[:, None, :]
                 + c2[None, :, None] * e2[:, None, :])           # (P, J, 3)
            towards = -np.sum(w * nrm[:, None, :], axis=-1)     # (P, J): > 0 meets the plane
            # u: distance back from the hit, u = s x^2 (x Gauss-Legendre on [0, 1]).
            u = s[:, None] * gx[None, :] ** 2                   # (P, U)
            wu = s[:, None] * 2 * gx[None, :] * gw[None, :]
            h = u * np.clip(-np.sum(v * nrm, axis=-1), 0.0, 1.0)[:, None]
            # (Directions that do not meet the plane never block: r = 0 and masked.)
            meets = np.broadcast_to((towards > 1e-6)[:, None, :], (v.shape[0], u.shape[1],
                                                                   towards.shape[1]))
            r = np.where(meets, h[:, :, None] / np.where(meets, towards[:, None, :], 1.0), 0.0)
            x = o + (s[:, None] - u)[..., None] * v[:, None, :]  # (P, U, 3)
            q = x[:, :, None, :] + r[..., None] * w[:, None, :, :]
            dq = q - o
            z = dq @ cam.forward
            zs = np.where(z > 1e-9, z, 1.0)
            col = np.floor(cam.cx + cam.fx * (dq @ cam.right) / zs).astype(int)
            row = np.floor(cam.cy - cam.fy * (dq @ cam.true_up) / zs).astype(int)
            inside = meets & (z > 1e-9) & (col >= 0) & (col < wid) & (row >= 0) & (row < hgt)
            cc, rw = np.clip(col, 0, wid - 1), np.clip(row, 0, hgt - 1)
            dist_q = np.linalg.norm(dq, axis=-1)
            seen_hit = self.hit[rw, cc]
            seen = np.where(seen_hit, self.distance[rw, cc], 0.0)
            blocked = inside & seen_hit & (np.abs(seen - dist_q)
                                           < np.maximum(0.02 * dist_q, 0.02))
            a, bu, bj = np.nonzero(blocked)
            if a.size == 0:
                return out
            d_q = np.clip(-q[a, bu, bj, 1], 0.0, None)
            l_s = self.l_s_img[rw[a, bu, bj], cc[a, bu, bj]]
            dl = self.l_bg(d_q, w[a, bj, 1]) - l_s
            # (Inside the forward cone, less what the cone took: the blocker's
            # radiance seen along its own camera ray.)
            c = np.flatnonzero(in_cone[bj])
            dl[c] -= self.l_bg(d_q[c], dq[a[c], bu[c], bj[c], 1] / dist_q[a[c], bu[c], bj[c]]) \
                - l_s[c]
            dl *= p_dir[bj] * np.exp(-self.k * (s[a] - u[a, bu] + r[a, bu, bj])[:, None])
            dl *= (dw[bj] * wu[a, bu])[:, None]
            # (a is sorted: np.nonzero's order; one sum per receiver.)
            first = np.flatnonzero(np.r_[True, a[1:] != a[:-1]])
            out[a[first]] = np.add.reduceat(dl, first, axis=0) * self.b
            return out

        if not chunks:
            return np.zeros((0, n))
        return np.concatenate(in_threads(chunk, chunks))


def ray_frames(v):
    """Unit vectors ``(e1, e2)`` (P, 3) across rays ``v`` (P, 3): the frame of
    :meth:`ShadowContext.hit_quadrature`'s azimuths."""
    e1 = np.cross(v, np.where(np.abs(v[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]]))
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    return e1, np.cross(v, e1)


def _weighted_rows(values, rows, weights) -> np.ndarray:
    """``sum_k weights[:, k] values[rows[:, k]]`` (P, n) for ``rows`` / ``weights`` (P, 4),
    a corner at a time (no (P, 4, n) gather)."""
    out = np.empty((rows.shape[0], values.shape[-1]))
    for c0 in range(0, rows.shape[0], 8192):        # (in chunks that stay in cache)
        r, w, o = rows[c0:c0 + 8192], weights[c0:c0 + 8192], out[c0:c0 + 8192]
        np.multiply(w[:, :1], np.take(values, r[:, 0], axis=0), out=o)
        for k in range(1, rows.shape[1]):
            o += w[:, k:k + 1] * np.take(values, r[:, k], axis=0)
    return out
