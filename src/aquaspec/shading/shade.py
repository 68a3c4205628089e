"""Deferred spectral shading of a G-buffer in NumPy (float64): the reference.

:func:`shade_gbuffer` turns a :class:`~aquaspec.scene.gbuffer.GBuffer` into linear
camera RGB with the analytic model of :mod:`aquaspec.transport.monzon2022`. It is the oracle
the GPU pass :class:`aquaspec.gpu.passes.deferred.DeferredPass` (WGSL:
``gpu/passes/deferred.wgsl`` and ``gpu/wgsl/common.wgsl``) is tested against; the
two follow the same formulas and the same branches, so change them together.

Conventions
-----------
World units are metres, y is up, the water surface is y = 0 and the depth of
a point p is ``-p.y``. The camera sits at depth ``d_o = -camera.position.y``
(>= 0); pixel ray ``v`` is :meth:`Camera.ray_directions`. Per pixel:

- open water (``distance = inf``): the ray runs to infinity, or, going up,
  to the water surface at ``S = d_o / v_y``, where the sky is seen through
  Snell's window (:func:`aquaspec.medium.interface.surface_from_below`);
- a hit at distance ``S``: a Lambertian surface at depth
  ``-(o_y + S v_y)`` with normal ``n``, lit by the ambient irradiance
  (:func:`aquaspec.transport.monzon2022.ambient_irradiance`, model ``ambient``).
  A hit *beyond* the water surface (an up ray with ``S > d_o / v_y``, e.g. a
  rock sticking out of the water) is not reached: the ray ends at the
  surface, and the pixel is shaded as open water looking up.

Band radiance ``L = T(S) L_surf + L_MS`` (:func:`aquaspec.transport.monzon2022.pixel_radiance`)
becomes camera RGB as ``sum_i w_i L_i R_c,i`` with ``response_weights``.
"""

from __future__ import annotations

import numpy as np

from aquaspec.colour.sensors import radiance_to_rgb
from aquaspec.errors import AquaspecError
from aquaspec.scene.camera import camera_depth
from aquaspec.scene.occlusion import OcclusionMaps
from aquaspec.shading.lamp import lamp_radiance
from aquaspec.shading.sun import sun_radiance
from aquaspec.transport import monzon2022 as model
from aquaspec.scene.gbuffer import PER_PIXEL, GBuffer, hit_reflectance
# The Jakob-Hanika sigmoid at normalised wavelengths (reflectance.py holds it).
from aquaspec.transport.lightfield.conespread import (node_pyramid_weights, pyramid_weights,
                                                      spread_by_lambda)
from aquaspec.transport.lightfield.conespread import spread as pyramid_spread
from aquaspec.transport.lightfield.occlusion import occlusion_factor, weights_from_tables
from aquaspec.transport.lightfield.shadow import ambient_shadow
from aquaspec.transport.lightfield.tables import LightfieldTables
from aquaspec.transport.lightfield.water_occlusion import water_shadow, water_visibility

#: Upper bound on float64 elements of one row chunk per band array.
_CHUNK_ELEMENTS = 1 << 20


def _band_array(name, value, n, *, unit, minimum=0.0):
    arr = np.asarray(value, dtype=float)
    if arr.shape != (n,):
        raise AquaspecError(f"{name} has shape {arr.shape}; expected ({n},), one value "
                            f"per band in {unit}")
    if not np.all(np.isfinite(arr)):
        raise AquaspecError(f"{name} contains NaN or infinity; expected finite {unit}")
    if minimum is not None and np.any(arr < minimum):
        i = int(np.argmax(arr < minimum))
        raise AquaspecError(f"{name}[{i}] = {arr[i]:g} is negative; accepted: >= 0 {unit}")
    return arr


def check_medium(a, b, kd, e0, response_weights, material_bands, sigmoid_centers_t,
                 ambient, n_materials=None):
    """Validate the per-band inputs of the shading; returns them as float64 arrays.

    Shared by :func:`shade_gbuffer` and the GPU pass so both accept and
    reject the same inputs. ``n_materials``, when given, is the number of
    materials the G-buffer defines.
    """
    a_arr = np.asarray(a, dtype=float)
    if a_arr.ndim != 1 or a_arr.size < 1:
        raise AquaspecError(f"a has shape {a_arr.shape}; expected (n,) with n >= 1 bands")
    n = a_arr.size
    a_arr = _band_array("a", a_arr, n, unit="1/m")
    b_arr = _band_array("b", b, n, unit="1/m")
    kd_arr = _band_array("kd", kd, n, unit="1/m")
    e0_arr = _band_array("e0", e0, n, unit="W m^-2 nm^-1")
    c = a_arr + b_arr
    if np.any(c <= 0):
        i = int(np.argmax(c <= 0))
        raise AquaspecError(f"extinction a + b is {c[i]:g} in band {i}; it must be > 0 1/m "
                            "(open-water rays would never end)")
    w = np.asarray(response_weights, dtype=float)
    if w.shape != (n, 3):
        raise AquaspecError(f"response_weights has shape {w.shape}; expected ({n}, 3)")
    if not np.all(np.isfinite(w)):
        raise AquaspecError("response_weights contains NaN or infinity")
    mb = np.zeros((0, n)) if material_bands is None else np.asarray(material_bands, dtype=float)
    if mb.ndim != 2 or mb.shape[1] != n:
        raise AquaspecError(f"material_bands has shape {mb.shape}; expected (M, {n}): "
                            "one band reflectance per material")
    if n_materials is not None and mb.shape[0] != n_materials:
        raise AquaspecError(f"material_bands has {mb.shape[0]} rows but the G-buffer defines "
                            f"{n_materials} materials")
    if not np.all(np.isfinite(mb)) or np.any(mb < 0):
        raise AquaspecError("material_bands must be finite and >= 0")
    t = _band_array("sigmoid_centers_t", sigmoid_centers_t, n, unit="(lambda - 550)/100",
                    minimum=None)
    if ambient not in model.AMBIENT_MODELS:
        raise AquaspecError(f"unknown ambient model {ambient!r}; known: "
                            f"{', '.join(model.AMBIENT_MODELS)}")
    return a_arr, b_arr, kd_arr, e0_arr, w, mb, t


def shade_gbuffer(gbuffer: GBuffer, *, a, b, kd, e0, response_weights, material_bands,
                  sigmoid_centers_t, ambient: str = model.DEFAULT_AMBIENT,
                  return_radiance: bool = False, lightfield: LightfieldTables | None = None,
                  progress=None, shadow_rays=None, sun=None, sun_shadow=None,
                  occlusion: OcclusionMaps | None = None, occlude_water: bool = True,
                  lamps=(), lamp_shadows=None) -> dict:
    """Shade a G-buffer spectrally: the NumPy reference of the deferred pass.

    Parameters
    ----------
    gbuffer : GBuffer
        Distance, normal, material and sigmoid coefficients per pixel.
    a, b, kd : array_like, shape (n,)
        Band absorption, scattering and diffuse attenuation in 1/m.
    e0 : array_like, shape (n,)
        Downwelling irradiance just below the surface, W m^-2 nm^-1.
    response_weights : array_like, shape (n, 3)
        Band-averaged camera response times band width
        (see :func:`aquaspec.colour.sensors.radiance_to_rgb`).
    material_bands : array_like, shape (M, n)
        Band reflectances of ``gbuffer.materials`` (M = their number; may be
        ``None`` when there are none).
    sigmoid_centers_t : array_like, shape (n,)
        Normalised band-centre wavelengths ``(lambda - 550) / 100`` at which
        per-pixel sigmoid reflectances are evaluated.
    ambient : str
        Ambient irradiance model, a key of :data:`aquaspec.transport.monzon2022.AMBIENT_MODELS`.
    return_radiance : bool
        Also return the band radiance.
    lightfield : LightfieldTables, optional
        Tables from :func:`aquaspec.transport.lightfield.bake.lightfield_tables`: shade with
        the light-field multiple-scattering model (``ms_model="lightfield"``)
        instead of the seeds' (then ``kd`` and ``ambient`` are not used).
    progress : callable, optional
        Called with a short message at each step of the scene's shadow
        (tables with ``ambient_shadow``: :func:`scene_shadow`).
    shadow_rays : optional
        Where the shadow's receivers' rays are integrated (``scene_shadow``'s
        ``rays``; default here, in NumPy).
    sun : aquaspec.transport.sun_scattering.SunInputs, optional
        Add the direct sun: lit surfaces and the beam's single scattering
        (:func:`aquaspec.shading.sun.sun_radiance`).
    sun_shadow : (height_map, ShadowMapSpec), optional
        The sun's shadow map (:func:`aquaspec.scene.shadowmap.shadow_map_numpy`); None:
        nothing shadows the sun.
    occlusion : OcclusionMaps, optional
        The scene's occlusion of the ambient light field
        (:func:`aquaspec.scene.occlusion.occlusion_maps`): each hit pixel's
        light-field term (not the sun's direct light, which has its own
        shadow map) is multiplied per band by
        :func:`aquaspec.transport.lightfield.occlusion.occlusion_factor`,
        and every pixel's in-scattering loses the water's own shadow
        (:func:`aquaspec.transport.lightfield.water_occlusion.water_shadow`).
        Light-field model only (``lightfield`` given), not together with the
        tables' ``ambient_shadow``.
    occlude_water : bool
        With ``occlusion``: also the water's own shadow (default; False: the
        surfaces' factor alone, what the GPU pass computes).
    lamps : sequence of aquaspec.transport.lamp_scattering.LampInputs
        Lamps placed in the world: their light on surfaces and scattered once
        along each ray (:func:`aquaspec.shading.lamp.lamp_radiance`).
    lamp_shadows : list, optional
        Per lamp ``(faces, maps)`` (:mod:`aquaspec.scene.lamp_shadow`) or None;
        None: nothing shadows the lamps.

    Returns
    -------
    dict
        ``"camera_rgb"``: (H, W, 3) float64 linear camera RGB; with
        ``return_radiance``, also ``"radiance"``: (H, W, n) float64 in
        W m^-2 sr^-1 nm^-1.

    Notes
    -----
    Rows are shaded in chunks so that 1920x1080 at 64 bands stays within a
    few hundred MB. GPU twin: ``gpu/passes/deferred.wgsl``.
    """
    if not isinstance(gbuffer, GBuffer):
        raise AquaspecError(f"gbuffer must be an aquaspec.scene.gbuffer.GBuffer, got "
                            f"{type(gbuffer).__name__}")
    a, b, kd, e0, w, mb, t = check_medium(a, b, kd, e0, response_weights, material_bands,
                                          sigmoid_centers_t, ambient,
                                          n_materials=len(gbuffer.materials))
    if occlusion is not None:
        if lightfield is None:
            raise AquaspecError("occlusion of the ambient light is part of the light-field "
                                "model: give lightfield= tables (ms_model 'lightfield')")
        if not isinstance(occlusion, OcclusionMaps):
            raise AquaspecError(f"occlusion must be aquaspec.scene.occlusion.OcclusionMaps "
                                f"(occlusion_maps(scene, camera)), got {type(occlusion).__name__}")
        if lightfield.shadow is not None:
            raise AquaspecError("occlusion and the ambient shadow (lightfield_tables("
                                "ambient_shadow=True), --ambient-shadow) both take the scene's "
                                "shadow out of the water's light; accepted: one of them")
    occ_weights = None if occlusion is None or occlusion.empty else weights_from_tables(
        lightfield, occlusion.directions, occlusion.solid_angle, a=a, b=b)
    water_vis = None if occ_weights is None or not occlude_water else water_visibility(occlusion)
    cam = gbuffer.camera
    d_o = camera_depth(cam)
    o_y = float(cam.position[1])
    hgt, wid, n = cam.height, cam.width, a.size
    per_pixel = gbuffer.material == PER_PIXEL
    bad = gbuffer.hit & per_pixel & ~np.all(np.isfinite(gbuffer.sigmoid), axis=-1)
    if np.any(bad):
        i, j = np.argwhere(bad)[0]
        raise AquaspecError(f"G-buffer sigmoid coefficients at pixel ({i}, {j}) are "
                            f"{gbuffer.sigmoid[i, j].tolist()}; they must be finite")

    if lightfield is None:
        def radiance_of(**kw):
            return model.pixel_radiance(a=a, b=b, kd=kd, e0=e0, depth_o=d_o, **kw)
    else:
        def radiance_of(ambient=None, **kw):
            return lightfield.pixel_radiance(a=a, b=b, e0=e0, depth_o=d_o, split_cone=spread,
                                             **kw)

    # The light-field model's forward cone spread over the image
    # (lightfield_tables(cone_spread=True)): each pixel's cone term is kept
    # apart, convolved with the cone's kernel, then added.
    spread = lightfield is not None and lightfield.cone is not None
    # The scene's shadow in the light field (lightfield_tables(ambient_shadow=True)):
    # scene_shadow, subtracted once the image is whole.
    shadow = lightfield is not None and lightfield.shadow is not None
    whole = spread or shadow or bool(lamps)
    rgb = np.empty((hgt, wid, 3))
    radiance = np.empty((hgt, wid, n)) if (return_radiance or whole) else None
    cone_flat = np.zeros((hgt * wid, n)) if spread else None

    def split(result, where, r0):
        """The radiance of ``result``; with the spread, its cone term is stored
        for the chunk's pixels ``where`` (rows from ``r0``)."""
        if not spread:
            return result
        base, cone = result
        start = r0 * wid
        cone_flat[start:start + where.size][where] = cone   # a slice is a view
        return base
    dirs = cam.ray_directions()
    rows = max(1, _CHUNK_ELEMENTS // max(1, wid * n))
    for r0 in range(0, hgt, rows):
        r1 = min(hgt, r0 + rows)
        v_y = dirs[r0:r1, :, 1].reshape(-1)
        s = gbuffer.distance[r0:r1].reshape(-1).astype(float)
        mat = gbuffer.material[r0:r1].reshape(-1)
        n_y = gbuffer.normal[r0:r1, :, 1].reshape(-1).astype(float)
        sig = gbuffer.sigmoid[r0:r1].reshape(-1, 3)
        hit = model.hit_before_surface(s, v_y, d_o)
        s = np.where(hit, s, np.inf)

        lrad = np.empty((v_y.size, n))
        ow = ~hit
        if np.any(ow):
            lrad[ow] = split(radiance_of(v_y=v_y[ow, None], s=s[ow, None]), ow, r0)
        if np.any(hit):
            rho = hit_reflectance(mat[hit], sig[hit], mb, t)
            surface_depth = -(o_y + s[hit] * v_y[hit])
            occluded = {}
            if occ_weights is not None:
                normals = gbuffer.normal[r0:r1].reshape(-1, 3)[hit].astype(float)
                normals /= np.linalg.norm(normals, axis=1, keepdims=True)
                points = cam.position + dirs[r0:r1].reshape(-1, 3)[hit] * s[hit, None]
                occluded["surface_scale"] = occlusion_factor(
                    occ_weights, surface_depth, normals, *occlusion.visibility(points, normals))
            lrad[hit] = split(radiance_of(
                v_y=v_y[hit, None], s=s[hit, None], rho=rho,
                surface_depth=surface_depth[:, None], n_y=n_y[hit, None], ambient=ambient,
                **occluded), hit, r0)
        if water_vis is not None:
            # The water's own ambient shadow (transport.lightfield.water_occlusion).
            lrad -= water_shadow(lightfield, occ_weights, water_vis, cam.position,
                                 dirs[r0:r1].reshape(-1, 3), s, a=a, b=b, e0=e0,
                                 cone_cos=float(np.cos(np.radians(lightfield.forward_cone_deg))))
        if not np.all(np.isfinite(lrad)):
            raise AquaspecError("shading produced a non-finite radiance; check the water "
                                "coefficients and the G-buffer")
        rgb[r0:r1] = radiance_to_rgb(lrad, w).reshape(r1 - r0, wid, 3)
        if radiance is not None:
            radiance[r0:r1] = lrad.reshape(r1 - r0, wid, n)
    if lamps:
        # Before the spread: the forward cone's share of the lamps' lit
        # surfaces (against the veil they hide) moves from their pixels into
        # the spread's input, as the daylight's does (aquaspec.shading.lamp).
        if progress is not None:
            progress(f"{len(lamps)} lamp(s): lit surfaces and single scattering")
        # (The multiple-scattering spread's kernel depends on each band's
        # lambda; the GPU's lamps feed the single-scattering one only.)
        lamp_split = spread and not lightfield.cone.multiple
        l_lamps = lamp_radiance(gbuffer, lamps, shadows=lamp_shadows, split_cone=lamp_split,
                                rho_of_hits=lambda m: hit_reflectance(
                                    gbuffer.material[m], gbuffer.sigmoid[m], mb, t))
        if lamp_split:
            l_lamps, lamp_cone = l_lamps
            l_lamps = l_lamps - lamp_cone
            cone_flat += lamp_cone.reshape(-1, n)
        radiance += l_lamps
        if not np.all(np.isfinite(radiance)):
            raise AquaspecError("the lamps' light is not finite; check the lamps and the water")
    if spread and lightfield.cone.multiple:
        # Multiple scattering in the cone: each pixel's and band's kernel by
        # its lambda = f b S (aquaspec.transport.lightfield.conespread.spread_by_lambda).
        cone = lightfield.cone
        s_all = gbuffer.distance.astype(float)
        lam = (np.asarray(cone.weight, dtype=float)
               * np.where(np.isfinite(s_all), s_all, 0.0)[..., None])
        radiance += spread_by_lambda(cone_flat.reshape(hgt, wid, n), lam, cone.lambda_nodes,
                                     node_pyramid_weights(cone, cam.fy, hgt, wid))
    elif spread:
        radiance += pyramid_spread(cone_flat.reshape(hgt, wid, n),
                                   pyramid_weights(lightfield.cone, cam.fy, hgt, wid))
    if shadow:
        radiance -= scene_shadow(gbuffer, b=b, e0=e0, material_bands=mb,
                                 sigmoid_centers_t=t, lightfield=lightfield, progress=progress,
                                 rays=shadow_rays)
    if sun is not None:
        if progress is not None:
            progress("the sun: lit surfaces and single scattering")
        hmap, spec = sun_shadow if sun_shadow is not None else (None, None)
        l_sun = sun_radiance(gbuffer, sun, height_map=hmap, spec=spec,
                             rho_of_hits=lambda m: hit_reflectance(
                                 gbuffer.material[m], gbuffer.sigmoid[m], mb, t))
        if radiance is not None:
            radiance += l_sun
        if not whole:
            rgb += radiance_to_rgb(l_sun.reshape(-1, n), w).reshape(hgt, wid, 3)
    if whole:
        rgb = radiance_to_rgb(radiance.reshape(-1, n), w).reshape(hgt, wid, 3)
    out = {"camera_rgb": rgb}
    if return_radiance:
        out["radiance"] = radiance
    return out


def scene_shadow(gbuffer: GBuffer, *, b, e0, material_bands, sigmoid_centers_t,
                 lightfield: LightfieldTables, progress=None, rays=None,
                 **_medium) -> np.ndarray:
    """The scene's first-order shadow in the light field for a G-buffer: ``dL``
    (H, W, n), to subtract from the band radiance (:mod:`aquaspec.transport.lightfield.shadow`).

    The surfaces' own radiance ``rho E(d, n_y) / pi`` comes from the light
    field's irradiance table, as in :func:`shade_gbuffer`, which calls this
    with ``lightfield_tables(ambient_shadow=True)``; the GPU renderer calls it
    too (:class:`aquaspec.rendering.renderer.Renderer`), on the G-buffer it rasterised,
    and subtracts the result in camera RGB. Takes the keyword arguments of
    :meth:`aquaspec.rendering.setup.SpectralSetup.medium` (those it does not use are
    ignored). ``progress`` is called with a short message per grid of
    receivers; ``rays`` integrates the receivers' rays elsewhere (the GPU
    renderer's :class:`aquaspec.gpu.passes.shadow_rays.ShadowRays`; default NumPy:
    seconds per image, almost independent of its size).
    """
    cam = gbuffer.camera
    d_o = camera_depth(cam)
    b = np.asarray(b, dtype=float)
    e0 = np.asarray(e0, dtype=float)
    mb = np.asarray(material_bands, dtype=float).reshape(-1, b.size)
    v_y = cam.ray_directions()[..., 1]
    dist = gbuffer.distance.astype(float)
    hit = model.hit_before_surface(dist, v_y, d_o)
    if len(mb) != len(gbuffer.materials):
        raise AquaspecError(f"material_bands has {len(mb)} rows but the G-buffer defines "
                            f"{len(gbuffer.materials)} materials")
    rho = hit_reflectance(gbuffer.material[hit], gbuffer.sigmoid[hit], mb,
                           np.asarray(sigmoid_centers_t, dtype=float))
    l_s = np.zeros(dist.shape + (b.size,))
    l_s[hit] = lightfield.surface_radiance(rho, -(cam.position[1] + dist[hit] * v_y[hit]),
                                           gbuffer.normal[..., 1][hit].astype(float), e0)
    return ambient_shadow(lightfield, cam, np.where(hit, dist, np.inf), gbuffer.normal, l_s,
                          b=b, e0=e0, hit=hit, progress=progress, rays=rays)
