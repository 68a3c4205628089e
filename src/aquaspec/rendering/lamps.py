"""The lamps in a render: their GPU pass or their NumPy shadow maps, and their metadata.

:func:`aquaspec.rendering.api.render` takes ``lamps=``: Lamps
(:class:`aquaspec.light.lamp.Lamp`) or ``--lamp`` specs and presets such as
``"rov-pair"`` (:func:`aquaspec.light.lamp.parse_lamps`), kept in
:attr:`aquaspec.rendering.setup.SpectralSetup.lamps`. Their light on
surfaces, shadowed by a map per lamp, and scattered once towards the camera
(:mod:`aquaspec.transport.lamp_scattering`, per column of pixels:
:mod:`aquaspec.transport.lamp_froxels`), and their glow (the light scattered
more than once, :mod:`aquaspec.transport.lamp_halo`) are added to the image: on the
GPU by a :class:`aquaspec.gpu.passes.lamps.LampPass` over the G-buffer the
renderer last shaded, in camera RGB (:func:`add_gpu_lamps`); in NumPy by
:func:`aquaspec.shading.shade.shade_gbuffer` with the arguments of
:func:`numpy_lamp_terms` (the maps ray cast). An RGB-D photograph casts no
shadows (nothing is known behind what it shows).

With ``layers=True`` the lamps' veil is part of the backscatter (the image
with every surface black) and their lit surfaces of the direct signal; the
``surface``, ``albedo`` and ``transmission`` layers
(:mod:`aquaspec.rendering.layers`) hold the daylight's terms only.

With the light field's (single-scattering) cone spread, the forward cone's
share of the lamps' lit surfaces is spread over the image with the
daylight's kernel (:mod:`aquaspec.shading.lamp`): on the GPU the
:class:`~aquaspec.rendering.renderer.Renderer` calls :func:`lamps_before_shading`
between the geometry and the shading, which records the lamps' shadow maps,
veil and that share into the cone spread's input
(:meth:`aquaspec.gpu.passes.lamps.LampPass.encode_cone`); the lamps'
per-pixel pass runs after the shading (:func:`gpu_lamp_light`).

``view`` below is what :func:`aquaspec.rendering.api.render` sees: its
``camera``, ``scene``, ``gbuffer`` (an RGB-D photograph's, else None) and
``from_rgbd``.
"""

from __future__ import annotations

import numpy as np

from aquaspec.gpu.passes.lamps import LampPass
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.lamp_shadow import DEFAULT_LAMP_MAP_SIZE, lamp_depth_maps, lamp_shadow_faces
from aquaspec.transport.lamp_froxels import LAMP_SLICES, lamp_tile


def gpu_lamp_pass(renderer, setup: SpectralSetup, view) -> LampPass:
    """A lamp pass on ``renderer``'s device with ``setup``'s lamps placed for
    ``view``'s camera and the per-band constants of its materials."""
    camera = view.camera
    lp = LampPass(renderer.deferred.device, camera.width, camera.height, setup.bands.n)
    medium = setup.medium(view.scene.materials if view.gbuffer is None
                          else view.gbuffer.materials)
    lp.set_inputs(setup.lamp_inputs(camera), response_weights=medium["response_weights"],
                  material_bands=medium["material_bands"],
                  sigmoid_centers_t=medium["sigmoid_centers_t"])
    return lp


def lamps_before_shading(renderer, encoder, setup: SpectralSetup, camera, materials,
                         shadow_scene):
    """Record into ``encoder``, before the shading of ``renderer``'s G-buffer,
    the lamps' shadow maps of ``shadow_scene`` (None: nothing shadows), their
    veil and, with the light field's single-scattering cone spread, their lit
    surfaces' cone share into the spread's input. The pass is kept in
    ``renderer.lamp_pass`` for :func:`gpu_lamp_light` (None without lamps, or
    without the spread: then :func:`gpu_lamp_light` records it all after)."""
    renderer.lamp_pass = None
    lf = renderer.lightfield
    if not setup.lamps or not (renderer._use_lightfield and lf.spread and not lf.nodes):
        return
    lp = LampPass(renderer.deferred.device, camera.width, camera.height, setup.bands.n)
    medium = setup.medium(materials)
    lp.set_inputs(setup.lamp_inputs(camera), response_weights=medium["response_weights"],
                  material_bands=medium["material_bands"],
                  sigmoid_centers_t=medium["sigmoid_centers_t"])
    # The light field's spread plan for this camera (the pyramid pass it will run).
    start, alpha, _ = lf._update_spread(camera)
    lp.set_cone_spread(lf._spread_pass, start, alpha)
    lp.encode_shadow_maps(encoder, renderer.raster, shadow_scene)
    lp.encode_veil(encoder, camera, renderer.deferred.gbuffer.textures)
    lp.encode_cone(encoder)
    renderer.lamp_pass = lp


def lamps_shaded(renderer) -> None:
    """After the frame :func:`lamps_before_shading` fed is submitted: the cone
    spread's lamp input off again (the next frames may have no lamps)."""
    lp = getattr(renderer, "lamp_pass", None)
    if lp is not None and lp.cone_spread is not None:
        lp.cone_spread[0].set_extra(False)


def gpu_lamp_light(renderer, lamp_pass: LampPass, view, *, surfaces: bool = True) -> np.ndarray:
    """The lamps' light (H, W, 3) float64 in camera RGB for the G-buffer
    ``renderer`` last shaded, shadowed by ``view``'s scene (not an RGB-D
    image's); ``surfaces=False``: every surface black (the backscatter layer).
    When the renderer recorded the lamps before its shading
    (:func:`lamps_before_shading`), their per-pixel pass alone, of that frame."""
    dev = renderer.deferred.device
    enc = dev.create_command_encoder()
    if getattr(renderer, "lamp_pass", None) is not None:
        lamp_pass = renderer.lamp_pass
        lamp_pass.encode_pixels(enc)
    else:
        lamp_pass.set_cone_spread(None)
        lamp_pass.encode_shadow_maps(enc, renderer.raster, None if view.from_rgbd
                                     else view.scene)
        lamp_pass.encode(enc, view.camera, renderer.deferred.gbuffer.textures,
                         surfaces=surfaces)
    dev.queue.submit([enc.finish()])
    return lamp_pass.read_rgb().astype(np.float64)


def add_gpu_lamps(shaded, setup: SpectralSetup, view, say=None):
    """``shaded`` (the GPU's step 3 of :func:`aquaspec.rendering.api.render`,
    with its ``renderer``, ``linear`` image and ``lamps``) with the lamps'
    light added and their pass kept in ``shaded.lamps``; as it is without lamps."""
    if not setup.lamps:
        return shaded
    if say is not None:
        say(f"{len(setup.lamps)} lamp(s): shadow maps, lit surfaces, single scattering and "
            "glow on the GPU")
    shaded.lamps = (shaded.renderer.lamp_pass or gpu_lamp_pass(shaded.renderer, setup, view))
    shaded.linear = shaded.linear + gpu_lamp_light(shaded.renderer, shaded.lamps, view)
    return shaded


def numpy_lamp_terms(setup: SpectralSetup, view, say=None) -> dict:
    """:func:`aquaspec.shading.shade.shade_gbuffer`'s ``lamps`` and
    ``lamp_shadows`` for ``view`` (per lamp ``(faces, maps)`` ray cast in NumPy,
    :mod:`aquaspec.scene.lamp_shadow`; none for an RGB-D image); {} without lamps."""
    if not setup.lamps:
        return {}
    lamps = setup.lamp_inputs(view.camera)
    if view.from_rgbd:
        return {"lamps": lamps, "lamp_shadows": None}
    shadows = []
    for inp in lamps:
        faces = lamp_shadow_faces(inp.lamp)
        if say is not None:
            say(f"lamp {inp.lamp.name!r}: {len(faces)} shadow map face(s) of "
                f"{DEFAULT_LAMP_MAP_SIZE}x{DEFAULT_LAMP_MAP_SIZE} texels (NumPy)")
        shadows.append((faces, lamp_depth_maps(view.scene, faces)))
    return {"lamps": lamps, "lamp_shadows": shadows}


def lamp_params(setup: SpectralSetup, view) -> dict:
    """How the lamps were rendered, for a render's metadata ({} without lamps)."""
    if not setup.lamps:
        return {}
    return {"lamp_rendering": {
        "shadow_map_texels": None if view.from_rgbd else DEFAULT_LAMP_MAP_SIZE,
        "single_scattering": (f"columns of {lamp_tile(view.camera)}x{lamp_tile(view.camera)} "
                              f"pixels, {LAMP_SLICES} equiangular slices"),
        "placed": [inp.lamp.describe() for inp in setup.lamp_inputs(view.camera)]}}
