"""Image-formation layers of a render: ground truth for underwater image restoration.

Methods that remove the water from underwater photographs (dehazing, colour
restoration, depth from attenuation) are trained and tested on what a
render knows and a photograph does not. The linear camera RGB ``I`` of a
render splits into what the water adds and what the surfaces send, the
backscatter and the direct signal of Akkaynak & Treibitz's revised image
formation model (CVPR 2018), ``I = D + B``:

- ``backscatter`` B: the image rendered again with every surface of the
  G-buffer black (reflectance 0). It is the water's own light, still
  shaped by the surfaces: they hide the water and sky behind them (and,
  with the scene's shadow, ``ambient_shadow``, they block light in the
  water).
- ``direct`` D = I - B: the surfaces' own light at the camera, attenuated
  along the ray, with the part the water scatters forward (the light
  field's forward cone; with the cone spread, spread over neighbouring
  pixels, so a little of it lands on open water beside a target).
- ``surface`` J: the light leaving each visible surface towards the
  camera, at the surface, with no water in between: camera RGB of
  ``rho E(d, n) / pi`` with the model's irradiance at the surface's depth
  and orientation (:func:`aquaspec.transport.monzon2022.ambient_irradiance`, or the light
  field's :meth:`aquaspec.transport.lightfield.tables.LightfieldTables.surface_radiance`), plus with a sun
  its beam on the surface, shadows included (:func:`aquaspec.light.sun.surface_irradiance`).
- ``albedo``: camera RGB of ``rho E0 / pi``, the surface under the light
  just below the water surface (``E0``): the colour cast the water gives
  the light on its way down is taken out too (what colour restoration
  aims at).
- ``transmission`` t: per channel, the share of the surface's light that
  stays in the camera ray's beam, ``RGB(T L_surf) / RGB(L_surf)`` with
  ``T = exp(-c' S)`` per band and ``c'`` the beam's extinction (``c``; in
  the light field ``c - f b``, its forward cone counted as unscattered); 0
  where there is no surface. The ratio is taken in camera RGB, after the
  bands are summed, so it belongs to this surface's spectrum, and it lies
  between the bands' smallest and largest T. Without the cone spread and
  the scene's shadow, ``D = t J`` (the NumPy backend to rounding; the GPU
  within its compiled model's error, see :mod:`aquaspec.transport.lightfield.compiled`)
  for every sensor whose response is nowhere negative, as real cameras';
  ``human`` (CIE 1931 to linear sRGB) has negative lobes, which the ratio
  takes by magnitude, so that t stays a transmittance there too.
- ``range_m``: the distance along the ray to the surface, m; 0 for open
  water (rays that reach the water surface first count as open water).

All colour layers are linear camera RGB like the linear image; every layer
is finite. Files: :func:`aquaspec.io.layers_file.write_layers` (EXR with
layers ``backscatter.R`` ... and the channel ``range_m``, or NPZ), read back
with :func:`aquaspec.io.layers_file.read_layers`.
"""

from __future__ import annotations

import numpy as np

from aquaspec.colour.reflectance import Reflectance
from aquaspec.colour.sensors import radiance_to_rgb
from aquaspec.errors import AquaspecError
from aquaspec.io.layers_file import LAYER_NAMES
from aquaspec.light.sun import surface_irradiance
from aquaspec.scene.camera import camera_depth
from aquaspec.scene.gbuffer import GBuffer, hit_reflectance
from aquaspec.shading.shade import check_medium
from aquaspec.transport import monzon2022 as model
from aquaspec.transport.lightfield.tables import LightfieldTables

_BLACK = Reflectance("black", np.array([100.0, 2000.0]), np.zeros(2),
                     source="aquaspec.rendering.layers: reflectance 0, for the backscatter layer")
# Hit pixels per chunk of the NumPy layers (times the band count, float64).
_CHUNK_ELEMENTS = 4_000_000


def black_gbuffer(gbuffer: GBuffer) -> GBuffer:
    """``gbuffer`` with every surface black: same geometry, one material of
    reflectance 0 (the backscatter layer is the image of it)."""
    if not isinstance(gbuffer, GBuffer):
        raise AquaspecError(f"gbuffer must be an aquaspec.scene.gbuffer.GBuffer, got "
                            f"{type(gbuffer).__name__}")
    material = np.zeros_like(gbuffer.material)
    return GBuffer(gbuffer.camera, gbuffer.distance, gbuffer.normal, material,
                   np.zeros_like(gbuffer.sigmoid), [_BLACK])


def surface_layers(gbuffer: GBuffer, *, a, b, kd, e0, response_weights, material_bands,
                   sigmoid_centers_t, ambient: str = model.DEFAULT_AMBIENT,
                   lightfield: LightfieldTables | None = None, sun=None, sun_visibility=None) -> dict:
    """``surface``, ``albedo``, ``transmission`` (H, W, 3) and ``range_m`` (H, W),
    float64, from the G-buffer and the medium (the keywords of
    :func:`aquaspec.shading.shade.shade_gbuffer`; ``lightfield``: its tables, for
    the light-field model's irradiance and beam; None: the seeds' model;
    ``sun``: :class:`aquaspec.transport.sun_scattering.SunInputs` with ``sun_visibility``
    (H, W) or per band (H, W, n), the share of the beam each surface gets,
    :func:`aquaspec.shading.sun.surface_visibility`).
    See the module docstring for the definitions."""
    a, b, kd, e0, w, mb, t = check_medium(a, b, kd, e0, response_weights, material_bands,
                                          sigmoid_centers_t, ambient,
                                          n_materials=len(gbuffer.materials))
    cam = gbuffer.camera
    hgt, wid, n = cam.height, cam.width, a.size
    d_o = camera_depth(cam)
    v_y = cam.ray_directions()[..., 1].reshape(-1)
    s = gbuffer.distance.reshape(-1).astype(float)
    hit = model.hit_before_surface(s, v_y, d_o)
    out = {k: np.zeros((hgt * wid, 3)) for k in ("surface", "albedo", "transmission")}
    if lightfield is None:
        c_beam = a + b
    else:
        c_beam = lightfield.ray_extinction(a, b)
    idx = np.flatnonzero(hit)
    mat = gbuffer.material.reshape(-1)
    sig = gbuffer.sigmoid.reshape(-1, 3)
    n_y = gbuffer.normal[..., 1].reshape(-1).astype(float)
    o_y = float(cam.position[1])
    step = max(1, _CHUNK_ELEMENTS // n)
    for i0 in range(0, idx.size, step):
        p = idx[i0:i0 + step]
        rho = hit_reflectance(mat[p], sig[p], mb, t)
        depth = -(o_y + s[p] * v_y[p])
        if lightfield is None:
            l_surf = model.lambertian_radiance(
                rho, model.ambient_irradiance(e0, kd, depth[:, None], n_y[p, None], ambient))
        else:
            l_surf = lightfield.surface_radiance(rho, depth, n_y[p], e0)
        if sun is not None:
            # (H, W) or, with each band's caustic factor, (H, W, n): (P, 1 or n)
            vis = 1.0 if sun_visibility is None else sun_visibility.reshape(hgt * wid, -1)[p]
            normal = gbuffer.normal.reshape(-1, 3)[p].astype(float)
            l_surf = l_surf + model.lambertian_radiance(rho, surface_irradiance(
                sun.beam0, sun.c_sun, depth, normal, sun.to_sun) * vis)
        out["surface"][p] = radiance_to_rgb(l_surf, w)
        out["albedo"][p] = radiance_to_rgb(model.lambertian_radiance(rho, e0), w)
        # (|w|: a channel with negative lobes keeps t within the bands' T.)
        j = radiance_to_rgb(l_surf, np.abs(w))
        kept = radiance_to_rgb(model.transmittance(c_beam, s[p, None]) * l_surf,
                                     np.abs(w))
        out["transmission"][p] = np.where(j > 0, kept / np.where(j > 0, j, 1.0), 0.0)
    layers = {k: v.reshape(hgt, wid, 3) for k, v in out.items()}
    layers["range_m"] = np.where(hit, s, 0.0).reshape(hgt, wid)
    for k, v in layers.items():
        if not np.all(np.isfinite(v)):
            raise AquaspecError(f"the {k} layer came out non-finite; check the water "
                                "coefficients and the G-buffer")
    return layers


def image_layers(linear_rgb, backscatter_rgb, gbuffer: GBuffer, medium: dict,
                 lightfield: LightfieldTables | None = None, sun=None, sun_visibility=None) -> dict:
    """Every layer (:data:`LAYER_NAMES`) of an image ``linear_rgb`` whose
    G-buffer was ``gbuffer``, given ``backscatter_rgb``, the image of
    :func:`black_gbuffer` rendered the same way; ``medium`` as for
    :func:`surface_layers`."""
    linear = np.asarray(linear_rgb, dtype=float)
    back = np.asarray(backscatter_rgb, dtype=float)
    shape = (gbuffer.camera.height, gbuffer.camera.width, 3)
    for name, arr in (("linear image", linear), ("backscatter image", back)):
        if arr.shape != shape:
            raise AquaspecError(f"the {name} has shape {arr.shape}; the G-buffer's camera "
                                f"needs {shape}")
        if not np.all(np.isfinite(arr)):
            raise AquaspecError(f"the {name} is not finite")
    layers = {"backscatter": back, "direct": linear - back}
    layers.update(surface_layers(gbuffer, **medium, lightfield=lightfield, sun=sun,
                                 sun_visibility=sun_visibility))
    return {k: layers[k] for k in LAYER_NAMES}
