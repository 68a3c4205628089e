"""Marine snow's light: each particle's radiance towards the camera, and its disc in the image.

The particles (:mod:`aquaspec.scene.particles`) are Lambertian spheres of
reflectance ``rho`` (spectrally flat), diameter ``D`` far below a pixel's
footprint at most distances. Per band, the radiance of a sphere averaged
over the disc the camera sees, from direction ``w`` (unit, particle ->
camera), at depth ``d``:

- **the water's diffuse light** (the light field, :mod:`aquaspec.transport.lightfield`):
  a surface element of normal ``n`` gets the plane irradiance
  ``E(d, n_y)`` of the light-field tables (``irradiance_per_e0`` times
  ``E0``, the field is azimuthally symmetric), and the disc's mean
  radiance is ``rho/pi`` times the projected-area mean of it over the
  visible hemisphere::

      L_diffuse = rho / pi * V(d, w_y) E0,
      V(d, w_y) = 1/pi  int_{n.w > 0} E(d, n_y)/E0 (n.w) dn
                = 1/pi  int_{-1}^{1} E(d, mu)/E0 g(mu, w_y) dmu,

  with ``g`` the azimuthal integral of ``max(0, n.w)`` (closed form in
  :func:`azimuthal_cosine`). In isotropic radiance ``L`` (``E = pi L``,
  ``E0 = 4 pi L``) this gives ``rho L``; for ``E = A + B n_y`` it gives
  ``A + 2/3 B w_y`` (tested);
- **a beam** (the sun's refracted beam, ``F = F0 exp(-c* d / mu0)``
  normal to it, :class:`aquaspec.transport.sun_scattering.SunInputs`; a
  lamp's ``I(alpha) exp(-c r_l) / r_l^2``): the Lambert sphere's phase
  law, ``L = (2/3) rho F / pi * Phi(alpha)`` with
  ``Phi(alpha) = (sin alpha + (pi - alpha) cos alpha) / pi`` and ``alpha``
  the angle between the directions to the light and to the camera
  (H. N. Russell, "On the albedo of the planets and their satellites",
  ApJ 43, 173, 1916; ``2/3 rho`` is the sphere's geometric albedo). The
  scene's shadow of the sun is read from its shadow map at the particle's
  centre when one is given (:func:`aquaspec.scene.shadowmap.map_visibility`);
  no lamp shadows, no sea's caustics on the particles.

On the way to the camera the light is attenuated by ``exp(-c_view r)``
(``c - f b``, as the surfaces' light, :meth:`LightfieldTables.ray_extinction`).
Camera RGB is the band radiance times the sensor's band weights.

**The image.** A particle at distance ``r`` (axial ``z``) has an image of
diameter ``D_img = D f_px / z`` pixels and covers ``pi D_img^2 / 4`` of a
pixel's area in all. It is drawn as a disc of diameter
``max(D_img + D_coc, blur_px)`` (the support of its image blurred by the
lens's circle of confusion ``D_coc``; ``blur_px`` the smallest), with
weights ``w = clamp(R + 0.5 - rho_px, 0, 1) / (pi (R^2 + 1/12))`` at pixel
centres ``rho_px`` from its centre (the anti-aliased disc; ``pi (R^2 + 1/12)``
its integral, so the coverage is kept), only where it is nearer than the
G-buffer's surface. The pixel's coverage ``alpha = sum_i a_i w_i`` and
light ``S = sum_i a_i w_i L_i`` are composed over the image as
``L' = L max(1 - alpha, 0) + S / max(alpha, 1)`` (order-independent; the
water's light between the camera and a particle that the particle hides is
left in).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.scene.shadowmap import map_visibility
from aquaspec.transport.lightfield.tables import band_last_table, table_lookup

#: Nearest particle drawn, m along the camera's axis (a port's glass is about there).
NEAR_M = 0.1
#: Largest disc radius drawn, pixels (nearer particles keep their light on this disc).
MAX_RADIUS_PX = 48.0
#: Columns of a splat record: centre column, row (pixels), disc radius (pixels),
#: distance (m), camera RGB (3), coverage ``a`` (pixel areas).
SPLAT_FIELDS = ("col", "row", "radius_px", "distance_m", "r", "g", "b", "coverage")
#: Angular nodes of :func:`visible_irradiance_table`'s quadrature over the normal's polar angle.
QUADRATURE_NODES = 257


def azimuthal_cosine(mu, w_y) -> np.ndarray:
    """``g(mu, w_y) = int_0^{2 pi} max(0, n.w) dphi`` for normals of up component
    ``mu`` and a unit ``w`` of up component ``w_y``."""
    mu, w_y = np.broadcast_arrays(np.asarray(mu, float), np.asarray(w_y, float))
    a = mu * w_y
    b = np.sqrt(np.clip(1.0 - mu ** 2, 0.0, None) * np.clip(1.0 - w_y ** 2, 0.0, None))
    phi0 = np.arccos(np.clip(-a / np.where(b > 0, b, 1.0), -1.0, 1.0))
    partial = 2.0 * a * phi0 + 2.0 * b * np.sin(phi0)
    return np.where(a >= b, 2.0 * np.pi * a, np.where(a <= -b, 0.0, partial))


def lambert_phase(cos_alpha) -> np.ndarray:
    """``Phi(alpha)`` of a Lambert sphere (1 at full phase, 0 at new)."""
    alpha = np.arccos(np.clip(np.asarray(cos_alpha, float), -1.0, 1.0))
    return (np.sin(alpha) + (np.pi - alpha) * np.cos(alpha)) / np.pi


def visible_irradiance_table(tables) -> np.ndarray:
    """``V(d, w_y)`` (n, n_depth, n_mu) on the light-field tables' axes (the
    cosine axis read as ``w_y``): ``1/pi`` times the visible hemisphere's
    integral of ``E(d, n_y)/E0 (n.w)`` (module docstring), by the trapezoidal
    rule over the normal's polar angle."""
    theta = np.linspace(0.0, np.pi, QUADRATURE_NODES)
    mu = np.cos(theta)
    depth = np.asarray(tables.depth_m, dtype=float)
    e = table_lookup(tables.irradiance_per_e0, depth[:, None], mu[None, :],
                     tables.max_depth_m)                       # (n_depth, n_theta, n)
    w = np.asarray(tables.cosine, dtype=float)
    g = azimuthal_cosine(mu[None, :], w[:, None]) * np.sin(theta)[None, :]   # (n_mu, n_theta)
    weights = np.full(theta.size, theta[1] - theta[0])
    weights[[0, -1]] *= 0.5
    v = np.einsum("dtn,mt,t->ndm", e, g, weights) / np.pi
    return v.astype(np.float32)


@dataclass(frozen=True)
class ParticleLight:
    """Per band, what lights the particles and carries their light to the camera.

    ``rho`` the particles' reflectance; ``e0`` (n,) the light field's
    ``E0``; ``tables`` the light-field tables (for the lookup's axes) and
    ``visible`` their :func:`visible_irradiance_table`; ``c_view`` (n,)
    1/m; ``response_weights`` (n, 3); ``sun`` a
    :class:`aquaspec.transport.sun_scattering.SunInputs` or None; ``lamps``
    :class:`aquaspec.transport.lamp_scattering.LampInputs` (placed);
    ``sun_shadow`` the scene's shadow map of the sun ``(height_map, spec)``
    (:func:`aquaspec.scene.shadowmap.numpy_shadow_map`) or None (no shadows).
    """

    rho: float
    e0: np.ndarray
    tables: object
    visible: np.ndarray
    c_view: np.ndarray
    response_weights: np.ndarray
    sun: object = None
    lamps: tuple = ()
    sun_shadow: tuple | None = None

    @classmethod
    def of(cls, rho, *, tables, e0, a, b, response_weights, sun=None, lamps=(),
           visible=None, sun_shadow=None) -> "ParticleLight":
        """From the light-field tables and the medium (``visible`` reused when given)."""
        if tables is None:
            raise AquaspecError("marine snow is lit by the light field: it needs "
                                "ms_model='lightfield'; accepted: the light-field model")
        return cls(float(rho), np.asarray(e0, float), tables,
                   visible_irradiance_table(tables) if visible is None else visible,
                   np.asarray(tables.ray_extinction(a, b), float),
                   np.asarray(response_weights, float), sun, tuple(lamps),
                   sun_shadow if sun is not None else None)

    def radiance(self, positions, camera_position) -> np.ndarray:
        """Band radiance (N, n) the camera receives from particles at
        ``positions`` (N, 3), averaged over each particle's disc, attenuated
        to ``camera_position``."""
        p = np.asarray(positions, dtype=float)
        to_cam = np.asarray(camera_position, float) - p
        r = np.sqrt(np.einsum("ij,ij->i", to_cam, to_cam))
        w = to_cam / np.where(r > 0, r, 1.0)[:, None]
        depth = np.clip(-p[:, 1], 0.0, None)
        # (The same texels as table_lookup(self.visible, ...), laid out band last.)
        lit = table_lookup(self._visible_band_last, depth, w[:, 1], self.tables.max_depth_m,
                           band_last=True)
        lit *= self.e0
        if self.sun is None and not self.lamps:
            lit *= self.rho / np.pi
            lit *= np.exp(-self.c_view * r[:, None])
            return lit
        beam = np.zeros_like(lit)
        if self.sun is not None:
            mu0 = max(float(self.sun.mu0), 1e-6)
            f = np.asarray(self.sun.beam0, float) * np.exp(
                -np.asarray(self.sun.c_sun, float) * depth[:, None] / mu0)
            if self.sun_shadow is not None:
                f = f * map_visibility(*self.sun_shadow, p)[:, None]
            beam += f * lambert_phase(w @ np.asarray(self.sun.to_sun, float))[:, None]
        for inp in self.lamps:
            lamp = inp.lamp
            to_lamp = np.asarray(lamp.position, float) - p
            r_l = np.maximum(np.linalg.norm(to_lamp, axis=-1), 1e-3)
            s = to_lamp / r_l[:, None]
            off_axis = np.arccos(np.clip(-s @ np.asarray(lamp.direction, float), -1.0, 1.0))
            e = (np.asarray(inp.intensity, float) * lamp.relative_intensity(off_axis)[:, None]
                 * np.exp(-np.asarray(inp.c_lamp, float) * r_l[:, None]) / r_l[:, None] ** 2)
            beam += e * lambert_phase(np.sum(s * w, axis=-1))[:, None]
        out = self.rho / np.pi * (lit + (2.0 / 3.0) * beam)
        return out * np.exp(-self.c_view * r[:, None])

    @cached_property
    def _visible_band_last(self) -> np.ndarray:
        return band_last_table(self.visible)

    def rgb(self, positions, camera_position) -> np.ndarray:
        """Camera RGB (N, 3) of :meth:`radiance`."""
        return self.radiance(positions, camera_position) @ self.response_weights


def in_view(positions, camera, margin_px: float) -> np.ndarray:
    """Which of ``positions`` (N, 3) lie beyond :data:`NEAR_M` along the axis
    and project within ``margin_px`` of the image: the particles to light
    (a cheap cull before :func:`splats`, which keeps the same ones and fewer)."""
    p = np.asarray(positions, dtype=float) - camera.position
    z = p @ camera.forward
    zs = np.where(z > NEAR_M, z, 1.0)
    col = camera.cx + camera.fx * (p @ camera.right) / zs
    row = camera.cy - camera.fy * (p @ camera.true_up) / zs
    return ((z > NEAR_M) & (col > -margin_px) & (col < camera.width + margin_px)
            & (row > -margin_px) & (row < camera.height + margin_px))


def splats(positions, diameters, rgb, camera, *, blur_px: float, coc_px=None) -> np.ndarray:
    """The particles in front of ``camera`` whose disc touches the image, as
    records of :data:`SPLAT_FIELDS` (M, 8) float32.

    ``coc_px``: a function of the axial distance (m) giving the lens's blur
    diameter in pixels (:meth:`aquaspec.optics.lens.ThinLens.blur_diameter_px`),
    or None (a pinhole: ``blur_px`` alone)."""
    p = np.asarray(positions, dtype=float) - camera.position
    z = p @ camera.forward
    keep = z > NEAR_M
    p, z = p[keep], z[keep]
    d = np.asarray(diameters, float)[keep]
    col = camera.cx + camera.fx * (p @ camera.right) / z
    row = camera.cy - camera.fy * (p @ camera.true_up) / z
    d_img = d * camera.fy / z
    d_disc = d_img + (0.0 if coc_px is None else np.asarray(coc_px(z), float))
    radius = np.clip(0.5 * np.maximum(d_disc, blur_px), 0.5, MAX_RADIUS_PX)
    reach = radius + 1.0
    inside = ((col + reach > 0) & (col - reach < camera.width)
              & (row + reach > 0) & (row - reach < camera.height))
    out = np.empty((int(inside.sum()), len(SPLAT_FIELDS)), np.float32)
    out[:, 0], out[:, 1], out[:, 2] = col[inside], row[inside], radius[inside]
    out[:, 3] = np.linalg.norm(p[inside], axis=-1)
    out[:, 4:7] = np.asarray(rgb, float)[keep][inside]
    out[:, 7] = 0.25 * np.pi * d_img[inside] ** 2
    return out


def splat_image(records, surface_distance) -> np.ndarray:
    """The discs of ``records`` (:func:`splats`) on an image whose G-buffer
    distance is ``surface_distance`` (H, W; inf or negative: open water):
    (H, W, 4), camera RGB ``S`` and coverage ``alpha`` per pixel."""
    dist = np.asarray(surface_distance, dtype=float)
    h, w = dist.shape
    open_water = ~np.isfinite(dist) | (dist < 0)
    flat_dist = np.where(open_water, np.inf, dist).ravel()
    acc = np.zeros((h * w, 4))
    rec = np.asarray(records, dtype=float)
    reach = np.ceil(rec[:, 2] + 1.0).astype(int)
    for k in np.unique(reach):
        group = rec[reach == k]
        off = np.arange(-k, k + 1)
        # Pixel centres (j + 0.5, i + 0.5) around each particle's own pixel.
        j = np.floor(group[:, 0])[:, None, None].astype(int) + off[None, None, :]
        i = np.floor(group[:, 1])[:, None, None].astype(int) + off[None, :, None]
        j, i = np.broadcast_arrays(j, i)
        rho = np.hypot(j + 0.5 - group[:, 0, None, None], i + 0.5 - group[:, 1, None, None])
        r = group[:, 2, None, None]
        weight = np.clip(r + 0.5 - rho, 0.0, 1.0) / (np.pi * (r ** 2 + 1.0 / 12.0))
        ok = (weight > 0) & (j >= 0) & (j < w) & (i >= 0) & (i < h)
        idx = np.where(ok, i * w + j, 0)
        ok &= group[:, 3, None, None] < flat_dist[idx]
        alpha = (weight * group[:, 7, None, None])[ok]
        np.add.at(acc, idx[ok], np.concatenate(
            [alpha[:, None] * np.broadcast_to(group[:, None, None, 4:7], ok.shape + (3,))[ok],
             alpha[:, None]], axis=1))
    return acc.reshape(h, w, 4)


def composite(linear, accumulated) -> np.ndarray:
    """``linear`` (H, W, 3) with the particles of ``accumulated`` (:func:`splat_image`)
    over it: ``L max(1 - alpha, 0) + S / max(alpha, 1)``."""
    acc = np.asarray(accumulated, dtype=float)
    alpha = acc[..., 3:4]
    return (np.asarray(linear, float) * np.clip(1.0 - alpha, 0.0, None)
            + acc[..., :3] / np.maximum(alpha, 1.0))
