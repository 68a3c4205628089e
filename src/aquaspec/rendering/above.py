"""Rendering with the camera above the sea (issue 30): step 3 of
:func:`aquaspec.rendering.api.render` when the camera is above ``y = 0``.

The model is :func:`aquaspec.shading.above_water.sea_from_above`: the flat
surface mirrors the sky (Fresnel) and lets out the light field's radiance
from just below it along the refracted rays, down to the light field's
seabed (the scene's, e.g. the built-in scene's sand, or ``seabed=``) or into
deep water; with a sun, also its beam scattered once in the water and its
glint on the surface; with waves (``waves=``, ``--wind``), every ray mirrored
and refracted by the wave tile's facet where it meets the sea and the sun's
glitter over the slopes the tile does not resolve
(:mod:`aquaspec.light.wave_facets`). It needs the light-field model and the
flat surface's light field, which a camera above the water makes the
default. A scene's meshes under the water (the built-in scene's, a mesh, a
scene of yours) are seen through the surface, with the sun's caustics on
them and on the light field's seabed under waves
(:mod:`aquaspec.shading.above_meshes`): the refracted rays are ray cast in
NumPy, so such a frame is shaded in NumPy whichever the backend (seconds to
a minute at 1280x720; said in the metadata). What is not drawn yet, and said
in the render's metadata (:func:`above_params`): the parts of meshes above
the water, the sky's colour changing across it and lamps.
"""

from __future__ import annotations

import functools

import numpy as np

from aquaspec.colour.sensors import radiance_to_rgb
from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import N_WATER
from aquaspec.light.wave_facets import surface_facets
from aquaspec.scene.occlusion import occlusion_maps
from aquaspec.scene.shadowmap import numpy_shadow_map
from aquaspec.shading.above_meshes import (rays_into_water, seabed_caustics,
                                           surface_reflectance, water_to_hits)
from aquaspec.shading.above_water import sea_from_above, sky_radiance_above, sky_shape

#: What the view from above leaves out (in its metadata).
NOT_DRAWN = ("the parts of meshes above the water",
             "the scene's shadow in the water's light (seen from above; with occlusion the "
             "surfaces' own occlusion is drawn)",
             "the sky's colour changing across it (the clear sky's distribution with a sun "
             "is of luminance, the same at every wavelength)",
             "lamps")


#: A camera within this of ``y = 0`` (m) is at the waterline.
WATERLINE_M = 1e-6


def above_water(camera) -> bool:
    """Whether ``camera`` is above the sea (``position.y`` above the waterline)."""
    return float(np.asarray(camera.position, dtype=float)[1]) > WATERLINE_M


def at_waterline(camera) -> bool:
    """Whether ``camera``'s centre is on the surface (half-and-half, :func:`waterline_sky`)."""
    return abs(float(np.asarray(camera.position, dtype=float)[1])) <= WATERLINE_M


def in_air_view(camera) -> bool:
    """Whether ``camera`` sees through the air at all (above the sea or at the
    waterline): its render takes the flat surface. A camera at the waterline
    that sees no water is refused here (:func:`check_waterline_view`), before
    any work."""
    if camera is not None and at_waterline(camera):
        check_waterline_view(camera)
        return True
    return camera is not None and above_water(camera)


def check_layers_view(camera) -> None:
    """Refuse image-formation layers (:mod:`aquaspec.rendering.layers`) for a
    camera above the sea: they are of rays through water from the camera."""
    if camera is not None and above_water(camera):
        raise AquaspecError("image-formation layers (backscatter, transmission, range) are "
                            "of a camera under water; a camera above the sea has none yet "
                            "(accepted: layers=False, or a camera under the surface)")


def check_waterline_view(camera) -> np.ndarray:
    """The rays going up (H, W) of ``camera`` at the waterline, or an error
    if that is all of them (the half-and-half view needs water)."""
    up = camera.ray_directions()[..., 1] > 0
    if up.all():
        raise AquaspecError("the camera at the waterline sees no water: every ray of its view "
                            "goes up; accepted: a view with rays below the horizon (look down "
                            "or widen the field of view), or a camera above the sea (y > 0)")
    return up


def waterline_sky(setup, camera, linear, radiance=None):
    """The half-and-half frame of a camera on the surface (its lens half in
    water, as behind a dome port at the waterline): rays going up leave from
    the surface straight into the air and see the sky
    (:func:`aquaspec.shading.above_water.sky_radiance_above` times
    :func:`~aquaspec.shading.above_water.sky_shape`: uniform overcast, the
    CIE clear sky about the sun with one), rays
    going down see the water as rendered from depth 0. Returns ``(linear,
    radiance)`` with the upper rays replaced (``radiance`` None stays None).
    Needs the flat surface (the light field the water's half is lit by)."""
    if setup.surface != "flat":
        raise AquaspecError("a camera at the waterline sees the sea through the real surface: "
                            f"surface 'flat' (got {setup.surface!r})")
    up = check_waterline_view(camera)
    med = setup.medium([])
    shape = sky_shape(setup.sun_inputs(caustics=False))
    sky = (sky_radiance_above(setup.lightfield_tables(), med["e0"])[None, :]
           * shape(camera.ray_directions()[up])[:, None])
    linear = np.array(linear, dtype=np.float64, copy=True)
    linear[up] = sky @ np.asarray(med["response_weights"], dtype=np.float64)
    if radiance is not None:
        radiance = np.array(radiance, dtype=np.float64, copy=True)
        radiance[up] = sky
    return linear, radiance


def check_above(setup, view, backend: str, optics=None) -> None:
    """Refuse what the view from above cannot do, naming it."""
    if optics is not None:
        raise AquaspecError("a camera model's port looks into water; a camera above the sea "
                            "takes none yet (accepted: camera_model=None)")
    check_above_setup(setup, from_rgbd=view.from_rgbd)
    if backend not in ("numpy", "gpu"):
        raise AquaspecError(f"backend {backend!r}; accepted: gpu, numpy")


def check_above_setup(setup, *, from_rgbd: bool) -> None:
    """Refuse a setup (or an RGB-D photograph) the view from above cannot
    take, naming it; shared with the live view's (:mod:`aquaspec.rendering.live_above`)."""
    if setup.ms_model != "lightfield":
        raise AquaspecError(f"a camera above the sea needs the light-field model (ms_model "
                            f"{setup.ms_model!r}): the water's colour from above is its "
                            "radiance looking down from the surface")
    if setup.surface != "flat":
        raise AquaspecError("a camera above the sea sees it through the real surface: "
                            f"surface 'flat' (got {setup.surface!r})")
    if from_rgbd:
        raise AquaspecError("an RGB-D photograph is taken under water; a camera above the sea "
                            "needs a scene (or the built-in one)")
    if setup.lamps:
        raise AquaspecError("lamps light the water around a camera under water; a camera "
                            "above the sea takes none (accepted: lamps=())")


def shade_above(setup, view, backend: str, return_radiance: bool, say, optics=None):
    """``(linear camera RGB (H, W, 3), band radiance or None)`` of the sea seen
    from ``view.camera`` above it (:func:`check_above` first, with the
    camera model ``optics``): on the GPU (:class:`aquaspec.gpu.passes.above.AbovePass`)
    or in NumPy (``backend="numpy"``, when the band radiance is asked for,
    or when :func:`shaded_in_numpy` says the frame needs it)."""
    check_above(setup, view, backend, optics)
    cam = view.camera
    numpy = backend == "numpy" or return_radiance or shaded_in_numpy(setup, view)
    where = "NumPy" if numpy else "GPU"
    say(f"the sea seen from {float(cam.position[1]):g} m above it, {cam.width}x{cam.height} "
        f"pixels x {setup.bands.n} bands ({where})")
    med = setup.medium([])
    tables = setup.lightfield_tables()
    facets = None if setup.waves is None else surface_facets(setup.waves)
    if where == "GPU":
        gpu = _above_pass(cam.width, cam.height)
        gpu.set_medium(tables, a=med["a"], b=med["b"], e0=med["e0"],
                       response_weights=med["response_weights"],
                       sun=setup.sun_inputs(caustics=False), facets=facets)
        return gpu.render(cam).astype(np.float64), None
    caustics = setup.light.sun is not None and setup.waves is not None
    sun = setup.sun_inputs(caustics=caustics)
    under = None
    # The refracted rays, once for the meshes and the seabed's caustics.
    rays = rays_into_water(cam, facets) if _has_meshes(view) or caustics else None
    if _has_meshes(view):
        say("ray casting the refracted rays into the scene (NumPy)")
        shadow = None if sun is None else numpy_shadow_map(view.scene, cam,
                                                           setup.light.sun.to_sun)
        occlusion = None
        if setup.occlusion:
            say("the scene's occlusion maps (NumPy)")
            occlusion = occlusion_maps(view.scene, cam)
        under = water_to_hits(view.scene, cam, tables, **_water_kw(setup, view.scene), sun=sun,
                              sun_shadow=shadow, facets=facets, occlusion=occlusion,
                              rays=rays)
    radiance = sea_from_above(cam, tables, a=med["a"], b=med["b"], e0=med["e0"],
                              sun=sun, facets=facets, under=under)
    if caustics:
        radiance = radiance + (1.0 - surface_reflectance(cam, facets))[..., None] / N_WATER ** 2 \
            * seabed_caustics(cam, tables, sun, facets=facets,
                              skip=None if under is None else under[0], rays=rays)
    linear = radiance_to_rgb(radiance, med["response_weights"])
    return linear, (radiance if return_radiance else None)


def _water_kw(setup, scene) -> dict:
    """The water's and the scene's materials' band inputs of :func:`water_to_hits`."""
    med = setup.medium(scene.materials)
    return {k: med[k] for k in ("a", "b", "e0", "material_bands", "sigmoid_centers_t")}


def _has_meshes(view) -> bool:
    """Whether the view has a scene whose meshes may lie under the water."""
    scene = getattr(view, "scene", None)
    return scene is not None and bool(getattr(scene, "meshes", None))


def shaded_in_numpy(setup, view) -> bool:
    """Whether the view from above needs the NumPy path whatever the backend:
    meshes under the water (ray cast), or the sun's caustics under waves on
    the light field's seabed (the GPU pass draws neither yet)."""
    caustics = (setup.light.sun is not None and setup.waves is not None
                and bool(np.isfinite(setup.lightfield_tables().seabed_depth_m)))
    return _has_meshes(view) or caustics


@functools.lru_cache(maxsize=2)
def _above_pass(width: int, height: int):
    """The GPU pass of the view from above at one size, compiled once and kept
    for the next renders (``aquaspec synth`` makes many of one size)."""
    from aquaspec.gpu.device import get_device   # deferred: wgpu only on the GPU path
    from aquaspec.gpu.passes.above import AbovePass
    return AbovePass(get_device()[1], width, height)


def above_params(view) -> dict:
    """The render's metadata entry for a camera above the sea or at the
    waterline (``{}`` below it)."""
    if at_waterline(view.camera):
        return {"waterline": {"model": "half-and-half: rays going up see the sky in air "
                                       "(uniform, E0 s / (t_d pi)), rays going down the water "
                                       "rendered from depth 0 under the flat surface",
                              "not_drawn": ["anything above the water but the sky",
                                            "the sun's disc", "the meniscus on the port"]}}
    if not above_water(view.camera):
        return {}
    return {"above_water": {
        "height_m": float(view.camera.position[1]),
        "model": "aquaspec.shading.above_water.sea_from_above: R(mu) L_sky + (1 - R(mu)) / "
                 "n^2 L_w(0, t), the light field looking down from just below the flat surface"
                 " (with a sun: plus its beam scattered once along t, and its glint; with "
                 "waves: each ray through the wave tile's facet, the glint as Cox & Munk's "
                 "glitter over the unresolved slopes)",
        **({"meshes": "the scene's meshes under the water: the refracted rays ray cast into "
                      "the scene and shaded in NumPy (aquaspec.shading.above_meshes), with the "
                      "sun's shadow map and, under waves, its caustics"}
           if _has_meshes(view) else {}),
        "not_drawn": list(NOT_DRAWN)}}
