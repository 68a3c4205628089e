"""``render()``: one image in one call, from water, light and camera to pixels.

Data flows one way: spectral data (water, light, sensor, bands) -> scene ->
G-buffer (GPU rasteriser, or an RGB-D image) -> deferred spectral pass (GPU,
or its NumPy reference) -> linear camera RGB -> display. :func:`render`
reads as those steps, each a function of this module:

1. ``_spectral_setup``: water, sensor, light and model on the bands
   (:class:`aquaspec.rendering.setup.SpectralSetup`), checked before any
   geometry work; the waves' caustics are computed here.
2. ``_view``: what the camera sees (the built-in scene, a mesh, the
   caller's scene, or an RGB-D photograph's G-buffer), then
   ``_with_seabed_plane`` (a mesh stands on the seabed it is given, a plane
   the camera sees), ``_with_seabed`` (the light field's lower boundary)
   and ``_white_patch_reference`` (the grey card a white-patch balance
   needs, checked before any shading).
3. Shading, with the sun: ``_shade_on_gpu`` (a
   :class:`aquaspec.rendering.renderer.Renderer` rasterises, shades and adds
   the sun) or ``_shade_in_numpy`` (ray cast, the sun's NumPy shadow map,
   :func:`aquaspec.shading.shade.shade_gbuffer`).
4. ``_layers``: with ``layers=True``, the image-formation layers
   (:mod:`aquaspec.rendering.layers`), the sun's visibility on the surfaces
   included (``_sun_visibility``).
5. ``_display``: white balance, colour matrix, exposure, tone map
   (:func:`aquaspec.colour.display.to_display`), and ``_params``, every
   parameter for the sidecar.

A :class:`aquaspec.rendering.renderer.Renderer` keeps the passes for many frames.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.display import display_settings, to_display
from aquaspec.colour.sensors import Sensor, get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.gpu.device import adapter_info
from aquaspec.scene.raycast import raycast_gbuffer
from aquaspec.io.layers_file import LAYER_NAMES
from aquaspec.light.lamp import parse_lamps
from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG, SurfaceLight, surface_light
from aquaspec.light.waves import Waves
from aquaspec.medium.water import DEFAULT_SOURCE, Water, get_water
from aquaspec.rendering.above import (above_params, above_water, check_layers_view,
                                      in_air_view, shade_above)
from aquaspec.rendering.appearance import (WHITE_CARD_DISTANCE_M, check_depth,  # noqa: F401
                                           colour_of_setup, white_card)
from aquaspec.rendering.camera_model import camera_view, through_camera
from aquaspec.rendering.lamps import add_gpu_lamps, gpu_lamp_light, lamp_params, numpy_lamp_terms
from aquaspec.rendering.layers import black_gbuffer, image_layers
from aquaspec.rendering.limits import check_render_memory
from aquaspec.rendering.marine_snow import add_marine_snow, parse_marine_snow
from aquaspec.rendering.renderer import Renderer
from aquaspec.rendering.result import RenderResult
from aquaspec.rendering.setup import SpectralSetup, render_surface
from aquaspec.rendering.surface_view import surface_seen_from_water
from aquaspec.scene.builtin import scene_for_render
from aquaspec.scene.camera import Camera, parse_size
from aquaspec.scene.gbuffer import GBuffer
from aquaspec.scene.rgbd import gbuffer_from_rgbd, load_rgbd
from aquaspec.scene.seabed import plane_radius_m, with_seabed_plane
from aquaspec.scene.shadowmap import DEFAULT_MAP_RADIUS_M, DEFAULT_MAP_SIZE, numpy_shadow_map
from aquaspec.scene.occlusion import occlusion_maps, visible_surface_occluders
from aquaspec.shading.shade import shade_gbuffer
from aquaspec.shading.sun import surface_visibility
from aquaspec.transport import monzon2022 as model
from aquaspec.transport.froxels import froxel_description
from aquaspec.transport.models import DEFAULT_MS_MODEL, MONZON2022

BACKENDS = ("gpu", "numpy")
def as_waves(waves, wave_time=None):
    """``render(waves=, wave_time=)`` as a :class:`aquaspec.light.waves.Waves`
    or None: None, a ``Waves``, or a wind speed in m/s (``Waves(wind_speed)``);
    ``wave_time`` (s), if given, is its instant."""
    if wave_time is not None:
        if waves is None:
            raise AquaspecError(f"wave_time={wave_time!r} is the waves' instant: it needs "
                                "waves (a wind speed or a Waves)")
        if isinstance(wave_time, bool) or not isinstance(wave_time, (int, float)):
            raise AquaspecError(f"wave_time={wave_time!r}; accepted: seconds, a finite number")
        return dataclasses.replace(as_waves(waves), time_s=float(wave_time))
    if waves is None:
        return None
    if isinstance(waves, Waves):
        return waves
    if isinstance(waves, (int, float)) and not isinstance(waves, bool):
        return Waves(float(waves))
    raise AquaspecError(f"waves={waves!r}; accepted: None, a wind speed in m/s or an "
                        "aquaspec.light.waves.Waves")


def render(*, water="IB", source: str = DEFAULT_SOURCE, depth_m: float = 5.0,
           sensor="human", camspec=None, bands: int = 16, wavelength_range=(400.0, 700.0),
           size=(1280, 720), scene=None, camera: Camera | None = None, mesh=None, albedo=None,
           builtin: str | None = None, rgbd=None, light="overcast", irradiance_w_m2=None,
           sun_elevation_deg=60.0,
           sun_azimuth_deg=None, sun_shadow_map: int | None = None, waves=None,
           wave_time: float | None = None, camera_model=None, marine_snow=None,
           ambient: str = model.DEFAULT_AMBIENT, outside: str = "error",
           ms_model: str = DEFAULT_MS_MODEL, phase: str = "petzold",
           forward_cone_deg: float | None = None, cone_spread: bool | None = None,
           spread_scattering: str = "single", ambient_shadow: bool = False,
           occlusion: bool = False, seabed="scene", lamps=(), surface=None,
           exposure="auto", white_balance="none", tonemap="filmic",
           colour_matrix="auto", return_radiance: bool = False, layers: bool = False,
           backend: str = "gpu", progress=None, renderer: Renderer | None = None
           ) -> RenderResult:
    """Render one image.

    Parameters
    ----------
    water : str or Water
        Jerlov type (``"IB"``), a CSV path, or a :class:`Water`.
    source : str
        Data set for Jerlov types.
    depth_m : float
        Camera depth below the surface, m (built-in scene and meshes).
    sensor : str or Sensor
        ``"human"``, a built-in camera, a camera of ``camspec``, or a CSV.
    bands : int
        Number of wavelength bands over ``wavelength_range`` (nm).
    size : (int, int) or "WxH"
    scene, camera : Scene and Camera, optional
        Your own scene; otherwise the built-in one (or ``mesh``).
    mesh : path, optional
        An OBJ/PLY/glTF/GLB placed in front of the camera at ``depth_m``.
    albedo : 3 floats, optional
        Linear RGB albedo replacing the mesh's colours.
    builtin : str, optional
        The built-in scene shown without ``scene``, ``mesh`` or ``rgbd``
        (:func:`aquaspec.scene.builtin.scene_for_render`).
    rgbd : (image, depth, intrinsics), optional
        An RGB image (path or array), a metric depth map (path or array, m)
        and pinhole intrinsics ``(fx, fy, cx, cy)``: a photograph becomes an
        underwater one with the camera at ``depth_m``.
    light : str or SurfaceLight
        ``overcast``, ``d65``, ``sun-sky`` or ``none`` (no daylight: the deep
        sea or night, lit by ``lamps`` alone; see :mod:`aquaspec.light.sky`).
        ``sun-sky`` has a sun (at ``sun_elevation_deg``, ``sun_azimuth_deg``):
        its refracted beam lights the surfaces, is shadowed by the scene and
        is scattered once towards the camera (:mod:`aquaspec.transport.sun_scattering`).
    lamps : sequence of Lamp or str
        Lamps or ``--lamp`` specs (``"rov-pair"``): :mod:`aquaspec.rendering.lamps`.
    sun_shadow_map : int, optional
        Side of the sun's shadow map in texels (default
        :data:`aquaspec.scene.shadowmap.DEFAULT_MAP_SIZE`); shadows are resolved within
        :data:`aquaspec.scene.shadowmap.DEFAULT_MAP_RADIUS_M` of the camera. RGB-D images cast no
        sun shadows (they have no geometry behind the visible surfaces).
    waves : aquaspec.light.waves.Waves or float, optional
        A wind sea on the surface (a wind speed in m/s stands for
        ``Waves(wind_speed)``): the sun's beam is focused into caustics on the
        surfaces and in the water (:mod:`aquaspec.light.caustics`). Needs a sun.
    wave_time : float, optional
        The waves' instant, s (replaces ``waves.time_s``; for many instants of one sea keep a
        :class:`aquaspec.rendering.renderer.Renderer` and use its ``set_wave_time``).
    ambient : str
        Ambient irradiance model of the seeds' model
        (:data:`aquaspec.transport.monzon2022.AMBIENT_MODELS`).
    ms_model : str
        Multiple-scattering model (:data:`aquaspec.transport.models.MS_MODELS`):
        ``"lightfield"`` (the default; with phase function ``phase``;
        scattering within ``forward_cone_deg`` of forward stays in the beam
        towards surfaces, see :func:`aquaspec.transport.lightfield.bake.lightfield_tables`;
        None: 15, or 40 with ``cone_spread``; ``cone_spread`` spreads that
        light over the image from where the cone points,
        :mod:`aquaspec.transport.lightfield.conespread`; None: on) or ``"monzon2022"``
        (thesis Eq. 4.7; alias ``"seeds"``).
    spread_scattering : {"single", "multiple"}
        With ``cone_spread``: the cone's light scattered once, or a Poisson
        number of times with mean ``f b S`` per pixel and band
        (:func:`aquaspec.transport.lightfield.bake.lightfield_tables`).
    ambient_shadow : bool
        Subtract the scene's first-order shadow in the water's light field
        (:mod:`aquaspec.transport.lightfield.shadow`; goes with ``spread_scattering="multiple"``).
        Integrated in NumPy from the G-buffer with either backend (the GPU's
        image has it subtracted in camera RGB): seconds per image.
    surface : {None, "index-matched", "flat"}
        The surface seen from below (light field): ``flat`` the real interface,
        ``index-matched`` none (:data:`aquaspec.rendering.setup.SURFACE_MODELS`); None
        (default): ``flat`` with the light field, ``index-matched`` with the seeds' model
        (:func:`aquaspec.rendering.setup.render_surface`). A camera above the sea or at the
        waterline always has the flat surface (:mod:`aquaspec.rendering.above`).
    occlusion : bool
        The scene's occlusion of the ambient light field (light-field model, scenes and meshes):
        surfaces under a ledge or before a wall get the light of the directions they see
        (:mod:`aquaspec.transport.lightfield.occlusion`; GPU and NumPy) and, with
        ``backend="numpy"``, the water in the occluders' shadow scatters less
        (:mod:`aquaspec.transport.lightfield.water_occlusion`). RGB-D images hold no geometry
        behind what they show: their visible surface is the occluder
        (:func:`aquaspec.scene.occlusion.visible_surface_occluders`).
    seabed : "scene", None or Seabed
        The light field's lower boundary (:class:`aquaspec.scene.seabed.Seabed`): ``"scene"`` takes
        the scene's (the built-in scene's sand; none for meshes, RGB-D images and scenes without
        one), None is deep water. It must lie below the camera. A ``mesh`` given a Seabed also
        stands on it: a flat plane of its reflectance that the camera sees, out to where the water
        hides it (:func:`aquaspec.scene.seabed.with_seabed_plane`), with either multiple-scattering
        model. The built-in scene keeps its sand as the geometry, an RGB-D photograph its own
        surfaces, and a ``scene`` of yours its own meshes: for them the Seabed is the boundary
        alone.
    outside : {"error", "zero"}
        Sensor response outside its range.
    exposure : "auto" or float EV; white_balance, tonemap : str
        Display settings (:func:`aquaspec.colour.display.to_display`).
        ``white_balance="white-patch"`` neutralises an 18 % grey card held
        1 m in front of the camera, facing it (a diver's custom white
        balance; :func:`white_card`), lit as the scene is, sun included;
        ``"grey-world"`` equalises the image's channel means.
    colour_matrix : "auto", None or (3, 3)
        Camera RGB -> linear sRGB for display: ``"auto"`` fits one on the
        ColorChecker under D65 (:meth:`aquaspec.colour.sensors.Sensor.srgb_matrix`;
        identity for the human sensor); None shows camera RGB as it is. The
        linear output stays camera RGB either way.
    return_radiance : bool
        Also return the per-band radiance.
    layers : bool
        Also return the image-formation layers (:mod:`aquaspec.rendering.layers`: the
        backscatter, the direct signal, the surfaces' own light and albedo,
        the transmission and the range), for restoration research. The
        backscatter is the image shaded again with every surface black
        (with ``ambient_shadow``, seconds more).
    backend : {"gpu", "numpy"}
        The WGSL passes through wgpu, or the NumPy reference.
    progress : callable, optional
        Called with a short message at each stage.
    camera_model : str or aquaspec.optics.presets.CameraModel, optional
        A real camera's port, lens and noisy sensor (:mod:`aquaspec.rendering.camera_model`).
    marine_snow : None, density per m^3, "DENSITY[,SEED]" or MarineSnow
        Particles drawn over the image (:mod:`aquaspec.rendering.marine_snow`; off by default).
    renderer : Renderer, optional
        A :class:`aquaspec.rendering.renderer.Renderer` of the image's size and
        band count to shade with (``backend="gpu"``): kept by the caller
        across renders, its compiled passes and uploaded tables are reused
        (``aquaspec synth``'s workers). None: one is made for this image.
    """
    say = progress or (lambda msg: None)
    if backend not in BACKENDS:
        raise AquaspecError(f"backend {backend!r} is unknown; accepted: {', '.join(BACKENDS)}")
    depth = check_depth(depth_m)
    snow = parse_marine_snow(marine_snow)
    width, height = parse_size(size)
    if rgbd is None:
        check_render_memory(bands, width, height, ms_model=ms_model, backend=backend)
    t0 = time.perf_counter()
    setup, map_size = _spectral_setup(
        water=water, source=source, sensor=sensor, camspec=camspec, bands=bands,
        wavelength_range=wavelength_range, light=light, irradiance_w_m2=irradiance_w_m2,
        sun_elevation_deg=sun_elevation_deg, sun_azimuth_deg=sun_azimuth_deg,
        sun_shadow_map=sun_shadow_map, waves=as_waves(waves, wave_time), ambient=ambient,
        outside=outside,
        ms_model=ms_model, phase=phase, forward_cone_deg=forward_cone_deg,
        cone_spread=cone_spread, spread_scattering=spread_scattering,
        ambient_shadow=ambient_shadow, occlusion=occlusion, say=say, lamps=lamps,
        surface="flat" if in_air_view(camera) else render_surface(surface, ms_model))
    view = _view(scene=scene, camera=camera, mesh=mesh, albedo=albedo, rgbd=rgbd,
                 depth_m=depth, width=width, height=height, say=say, builtin=builtin)
    view, optics = camera_view(view, camera_model, setup)
    if rgbd is not None:
        check_render_memory(bands, view.camera.width, view.camera.height, ms_model=ms_model,
                            backend=backend)
    view = _with_seabed_plane(view, seabed, setup)
    setup = _with_seabed(setup, seabed, view)
    reference, white_card_info = _white_patch_reference(setup, view.camera, white_balance)
    if above_water(view.camera):
        shaded = _Shaded(*shade_above(setup, view, backend, return_radiance, say, optics), None)
    elif backend == "gpu":
        shaded = _shade_on_gpu(setup, view, map_size, return_radiance, say, renderer)
    else:
        shaded = _shade_in_numpy(setup, view, map_size, return_radiance, say)
    shaded = surface_seen_from_water(setup, view, shaded, backend)
    shaded, snow_params = add_marine_snow(snow, shaded, setup, view, optics, backend,
                                          say, above=above_water(view.camera))
    _check_finite_image(shaded.linear)
    layer_set = _layers(setup, view, shaded, backend, say) if layers else None
    shaded, raw, optics_params = through_camera(optics, shaded, setup, view, say)
    display, info = _display(shaded.linear, setup.sensor, exposure=exposure,
                             white_balance=white_balance, reference=reference,
                             tonemap=tonemap, colour_matrix=colour_matrix)
    params = _params(setup, depth, view, backend, info, t0, white_card_info, map_size,
                     layer_set is not None)
    return RenderResult(display, shaded.linear, shaded.radiance, shaded.gbuffer,
                        {**params, **optics_params, **above_params(view), **snow_params},
                        layer_set, raw)


def _spectral_setup(*, water, source, sensor, camspec, bands, wavelength_range, light,
                    irradiance_w_m2, sun_elevation_deg, sun_azimuth_deg, sun_shadow_map,
                    waves, ambient, outside, ms_model, phase, forward_cone_deg, cone_spread,
                    spread_scattering, ambient_shadow, say, occlusion=False, lamps=(),
                    surface="index-matched"):
    """Step 1: the :class:`SpectralSetup` of :func:`render`'s arguments and the
    sun's shadow-map size; its ranges are checked (and the waves' caustics
    computed) before any geometry work."""
    water_obj = water if isinstance(water, Water) else get_water(water, source)
    sensor_obj = sensor if isinstance(sensor, Sensor) else get_sensor(sensor, camspec)
    light_obj = light if isinstance(light, SurfaceLight) else surface_light(
        light, total_w_m2=irradiance_w_m2, sun_elevation_deg=sun_elevation_deg,
        sun_azimuth_deg=DEFAULT_SUN_AZIMUTH_DEG if sun_azimuth_deg is None else sun_azimuth_deg)
    map_size = DEFAULT_MAP_SIZE if sun_shadow_map is None else sun_shadow_map
    setup = SpectralSetup(water_obj, sensor_obj, light_obj, Bands(bands, *wavelength_range),
                          ambient, outside, ms_model, phase,
                          forward_cone_deg=forward_cone_deg, cone_spread=cone_spread,
                          spread_scattering=spread_scattering, ambient_shadow=ambient_shadow,
                          occlusion=occlusion, surface=surface,
                          waves=as_waves(waves), lamps=parse_lamps(lamps))
    setup.medium([])  # fail early on ranges before any geometry work
    if setup.waves is not None:
        wv = setup.waves
        say(f"caustics of a {wv.wind_speed:g} m/s sea ({wv.tile_m:g} m tile, "
            f"{wv.grid}x{wv.grid} samples) under the sun")
        setup.sun_inputs()
    return setup, map_size


@dataclass
class _View:
    """What the camera sees: a scene to rasterise or ray cast, or a G-buffer
    made from an RGB-D photograph (``from_rgbd``)."""

    scene: object
    camera: Camera
    gbuffer: GBuffer | None
    from_rgbd: bool
    description: dict


def _view(*, scene, camera, mesh, albedo, rgbd, depth_m, width, height, say,
          builtin=None) -> _View:
    """Step 2: the scene and camera of :func:`render`'s arguments, or the
    G-buffer of its RGB-D photograph."""
    if builtin is not None and (scene is not None or mesh is not None or rgbd is not None):
        raise AquaspecError(f"builtin={builtin!r} names a built-in scene; it cannot be "
                            "combined with scene=, mesh= or rgbd=")
    if rgbd is not None:
        image, depth_map, intrinsics = rgbd
        source_desc = {}
        if isinstance(image, (str,)) or hasattr(image, "__fspath__"):
            source_desc = {"rgbd_image": str(image), "rgbd_depth": str(depth_map)}
            image, depth_map = load_rgbd(image, depth_map)
        say("building the G-buffer from the RGB-D image")
        gbuffer = gbuffer_from_rgbd(image, depth_map, intrinsics, camera_depth_m=depth_m)
        return _View(scene, gbuffer.camera, gbuffer, True,
                     {"kind": "rgbd", "intrinsics": list(map(float, intrinsics)),
                      **source_desc})
    if scene is None:
        say("building the scene")
        scene, default_cam = scene_for_render(mesh, depth_m, width, height, albedo, builtin)
        return _View(scene, camera or default_cam, None, False,
                     {"kind": "builtin" if mesh is None else "mesh",
                      **({"mesh": str(mesh)} if mesh is not None else {}),
                      **getattr(scene, "info", {})})
    camera = camera or scene.camera
    if camera is None:
        raise AquaspecError("a user scene needs a camera (scene.camera or camera=)")
    return _View(scene, camera, None, False,
                 {"kind": "user", "meshes": len(scene.meshes), **getattr(scene, "info", {})})


def _with_seabed(setup: SpectralSetup, seabed, view: _View) -> SpectralSetup:
    """``setup`` with the light field's lower boundary: ``seabed``, or the
    scene's for ``"scene"``; it must lie below the camera."""
    bed = (getattr(view.scene, "seabed", None) if isinstance(seabed, str) and seabed == "scene"
           else seabed)
    if bed is not None and not hasattr(bed, "albedo_on"):
        raise AquaspecError(f"seabed={seabed!r}; accepted: 'scene', None or an "
                            "aquaspec.scene.seabed.Seabed")
    if bed is not None and setup.ms_model == "lightfield":
        _check_below_camera(bed, view.camera)
        setup = dataclasses.replace(setup, seabed=bed)
    return setup


def _check_below_camera(bed, camera) -> float:
    """How far the seabed ``bed`` lies below ``camera``, m (> 0, else an error)."""
    d_cam = -float(camera.position[1])                   # < 0: a camera above the sea
    if float(bed.depth_m) <= d_cam:
        raise AquaspecError(f"the seabed at {float(bed.depth_m):g} m is not below the "
                            f"camera at {d_cam:g} m; accepted: a seabed deeper than "
                            "the camera, or seabed=None")
    return float(bed.depth_m) - d_cam


def _with_seabed_plane(view: _View, seabed, setup: SpectralSetup) -> _View:
    """A mesh given a seabed (a Seabed, not ``"scene"`` or None) stands on it:
    the plane the camera sees (:func:`aquaspec.scene.seabed.with_seabed_plane`)
    where the light field has its lower boundary, reaching under the whole
    mesh and out to where the water hides it. Other views are returned as
    they are (the built-in scene has its sand, an RGB-D photograph its own
    surfaces, a caller's scene its own geometry)."""
    if view.description["kind"] != "mesh" or not hasattr(seabed, "albedo_on"):
        return view
    camera = view.camera
    below = _check_below_camera(seabed, camera)
    # The farthest corner of the scene's bounding box, across the water.
    dx, dz = np.abs(view.scene.bounds()[:, [0, 2]] - camera.position[[0, 2]]).max(axis=0)
    reach = float(np.hypot(dx, dz))
    radius = plane_radius_m(setup.water.on_bands(setup.bands).a, below_camera_m=below,
                            far_m=camera.far, reach_m=reach + 1.0)
    scene = with_seabed_plane(view.scene, seabed, camera, radius)
    return dataclasses.replace(view, scene=scene, description={
        **view.description, "seabed_plane": {**seabed.describe(), "radius_m": radius}})


def _white_patch_reference(setup: SpectralSetup, camera: Camera, white_balance):
    """``(reference_rgb, white_card_info)`` of ``white_balance="white-patch"`` (the grey
    card of :func:`white_card`, lit as the scene is), else ``(None, None)``; before any
    shading, so a card the balance cannot use fails now."""
    if white_balance != "white-patch":
        return None, None
    card = white_card(camera)
    reference = colour_of_setup(setup, **card)["grey_card_rgb"]
    info = {"distance_m": card["distance_m"], "view_direction": card["view"].tolist(),
            "camera_rgb": reference}
    try:
        display_settings(np.ones((1, 1, 3)), white_balance="white-patch",
                         reference_rgb=reference, cone_matrix=setup.sensor.cone_matrix())
    except AquaspecError as exc:
        raise AquaspecError(
            f"white_balance='white-patch': the grey card 1 m ahead has camera RGB "
            f"{', '.join(f'{x:.3g}' for x in reference)} for sensor "
            f"{setup.sensor.name!r}, which cannot be balanced ({exc}); accepted: "
            "white_balance 'grey-world' or 'none', or a shallower scene") from None
    return reference, info


@dataclass
class _Shaded:
    """Step 3's outcome: the linear image (and band radiance when asked), the
    G-buffer where it was made on the CPU side, and what the layers reuse:
    the GPU renderer, or the NumPy shadow map of the sun."""

    linear: np.ndarray
    radiance: np.ndarray | None
    gbuffer: GBuffer | None
    renderer: Renderer | None = None
    sun_shadow: tuple | None = None
    lamps: object = None        # the lamps' GPU pass, or shade_gbuffer's lamp arguments
    surface_change: np.ndarray | None = None    # the waves' change seen from below


def _shade_on_gpu(setup: SpectralSetup, view: _View, map_size, return_radiance,
                  say, renderer: Renderer | None = None) -> _Shaded:
    """Step 3 on the GPU: rasterise (unless the G-buffer came from an RGB-D
    image), shade, add the sun (:class:`Renderer`) and the lamps."""
    camera = view.camera
    say(f"shading {camera.width}x{camera.height} pixels x {setup.bands.n} bands on the GPU"
        + (" (the scene's shadow in the light field in NumPy)" if setup.ambient_shadow
           else ""))
    if return_radiance and setup.ms_model != MONZON2022:
        raise AquaspecError("per-band radiance from the GPU is available for "
                            "ms_model='seeds'; use backend='numpy' for the light field")
    if renderer is None:
        r = Renderer(camera.width, camera.height, setup.bands.n, debug_radiance=return_radiance)
    else:
        r = _reusable(renderer, camera, setup.bands.n, return_radiance)
    r.sun_map_size = map_size
    r.set_occlusion(setup.occlusion)
    occluders = visible_surface_occluders(view.gbuffer) if (setup.occlusion
                                                             and view.from_rgbd) else None
    if return_radiance and (setup.light.sun is not None or setup.lamps):
        raise AquaspecError("per-band radiance with a sun or lamps is available from "
                            "backend='numpy'")
    if view.gbuffer is None:
        linear = r.render_scene(view.scene, camera, setup, say).astype(np.float64)
    else:
        linear = r.render_gbuffer(view.gbuffer, setup, say,
                                  occluders=occluders).astype(np.float64)
    radiance = r.read_radiance() if return_radiance else None
    return add_gpu_lamps(_Shaded(linear, radiance, view.gbuffer, renderer=r), setup, view, say)


def _reusable(renderer: Renderer, camera: Camera, n_bands: int, return_radiance) -> Renderer:
    """``render(renderer=)``: the caller's renderer, if it fits this image."""
    fits = ((renderer.width, renderer.height, renderer.deferred.n_bands)
            == (camera.width, camera.height, n_bands))
    if not fits or (return_radiance and not renderer.deferred.debug_radiance):
        raise AquaspecError(
            f"renderer={renderer.width}x{renderer.height}, {renderer.deferred.n_bands} bands "
            f"cannot shade this {camera.width}x{camera.height} image of {n_bands} bands"
            + (" with return_radiance" if return_radiance else "")
            + "; accepted: a Renderer of the image's size and band count (made with "
            "debug_radiance for return_radiance), or None")
    return renderer


def _shade_in_numpy(setup: SpectralSetup, view: _View, map_size, return_radiance,
                    say) -> _Shaded:
    """Step 3 in NumPy: ray cast the G-buffer (unless it came from an RGB-D
    image), the sun's shadow map, :func:`aquaspec.shading.shade.shade_gbuffer`."""
    camera, gbuffer = view.camera, view.gbuffer
    if gbuffer is None:
        say("ray casting the G-buffer (NumPy)")
        gbuffer = raycast_gbuffer(view.scene, camera)
    say(f"shading {camera.width}x{camera.height} pixels x {setup.bands.n} bands in NumPy"
        + (" with the scene's shadow in the light field" if setup.ambient_shadow else ""))
    sun_shadow = _numpy_sun_shadow(setup, view, map_size, say)
    lamp_kw = numpy_lamp_terms(setup, view, say)
    occlusion = None
    if setup.occlusion:
        say("the scene's occlusion maps (NumPy)")
        occlusion = occlusion_maps(visible_surface_occluders(gbuffer) if view.from_rgbd
                                   else view.scene, camera)
    out = shade_gbuffer(gbuffer, **setup.medium(gbuffer.materials),
                        return_radiance=return_radiance,
                        lightfield=setup.lightfield_tables(), progress=say,
                        sun=setup.sun_inputs(), sun_shadow=sun_shadow, occlusion=occlusion,
                        **lamp_kw)
    return _Shaded(out["camera_rgb"], out.get("radiance"), gbuffer, sun_shadow=sun_shadow,
                   lamps=lamp_kw)


def _numpy_sun_shadow(setup: SpectralSetup, view: _View, map_size, say):
    """The sun's shadow map of the scene (NumPy), or None without a sun or
    for an RGB-D image (no geometry behind the visible surfaces)."""
    if setup.light.sun is None or view.from_rgbd:
        return None
    say(f"the sun's shadow map, {map_size}x{map_size} texels (NumPy)")
    return numpy_shadow_map(view.scene, view.camera, setup.light.sun.to_sun, size=map_size)


def _check_finite_image(linear) -> None:
    bad = ~np.isfinite(linear)
    if bad.any():
        i, j = np.argwhere(bad.any(axis=-1))[0]
        raise AquaspecError(f"{int(bad.any(axis=-1).sum())} pixels came out NaN or infinite "
                            f"(first at row {i}, column {j}); this is a bug, please report it "
                            "with the parameters")


def _layers(setup: SpectralSetup, view: _View, shaded: _Shaded, backend, say) -> dict:
    """Step 4: the image-formation layers: the backscatter is the image shaded again with
    every surface black (on the GPU from the frame's G-buffer, read back and kept)."""
    check_layers_view(view.camera)
    say("image-formation layers: the image again with every surface black")
    r = shaded.renderer
    if backend == "gpu":
        if shaded.gbuffer is None:
            shaded.gbuffer = r.raster.read_gbuffer(view.scene, view.camera,
                                                   r.deferred.gbuffer.textures)
        back = r.render_gbuffer(black_gbuffer(shaded.gbuffer), setup, say,
                                sun_scene=None if view.from_rgbd else view.scene
                                ).astype(np.float64)
        back += gpu_lamp_light(r, shaded.lamps, view, surfaces=False) if setup.lamps else 0.0
    else:
        black = black_gbuffer(shaded.gbuffer)
        back = shade_gbuffer(black, **setup.medium(black.materials),
                             lightfield=setup.lightfield_tables(), progress=say,
                             sun=setup.sun_inputs(),
                             sun_shadow=shaded.sun_shadow, **shaded.lamps)["camera_rgb"]
    gbuffer, back = shaded.gbuffer, back + (0.0 if shaded.surface_change is None
                                            else shaded.surface_change)
    return image_layers(shaded.linear, back, gbuffer, setup.medium(gbuffer.materials),
                        setup.lightfield_tables(), sun=setup.sun_inputs(),
                        sun_visibility=_sun_visibility(setup, shaded, backend))


def _sun_visibility(setup: SpectralSetup, shaded: _Shaded, backend):
    """The share of the sun's beam each visible surface gets (shadows and
    caustics; :func:`aquaspec.shading.sun.surface_visibility`), or None without a sun."""
    if setup.light.sun is None:
        return None
    caustics = setup.sun_inputs().caustics
    if backend == "gpu":
        r = shaded.renderer
        shadowed = r.sun is not None and r.sun.shadowed
        return surface_visibility(shaded.gbuffer, r.sun.read_shadow_map() if shadowed else None,
                                  r.sun.spec if shadowed else None, caustics=caustics)
    return surface_visibility(shaded.gbuffer, *(shaded.sun_shadow or (None, None)),
                              caustics=caustics)


def _display(linear, sensor: Sensor, *, exposure, white_balance, reference, tonemap,
             colour_matrix):
    """Step 5: the display image of the linear one and what was done
    (:func:`aquaspec.colour.display.to_display`)."""
    if isinstance(colour_matrix, str):
        if colour_matrix != "auto":
            raise AquaspecError(f"colour_matrix {colour_matrix!r} is not accepted; use 'auto', "
                                "None or a 3x3 matrix")
        colour_matrix = sensor.srgb_matrix()
    return to_display(linear, exposure=exposure, white_balance=white_balance,
                      reference_rgb=reference, tonemap=tonemap, matrix=colour_matrix,
                      cone_matrix=sensor.cone_matrix())


def _params(setup: SpectralSetup, depth, view: _View, backend, display_info, t0,
            white_card_info, map_size, with_layers: bool) -> dict:
    """Every parameter of the render, for its metadata."""
    params = {
        **setup.describe(),
        "depth_m": depth,
        "camera": view.camera.describe(),
        "scene": view.description,
        "backend": backend,
        "display": display_info,
        "render_seconds": time.perf_counter() - t0,
    }
    if white_card_info is not None:
        params["white_card"] = white_card_info
    if setup.light.sun is not None:
        params["sun_rendering"] = {
            "shadow_map_texels": None if view.from_rgbd else map_size,
            "shadow_radius_m": None if view.from_rgbd else DEFAULT_MAP_RADIUS_M,
            "single_scattering": froxel_description(view.camera.width),
            "beam_extinction": "c* (delta-M) with the light field, c with the seeds' model"}
    params.update(lamp_params(setup, view))
    if with_layers:
        params["layers"] = {"names": list(LAYER_NAMES), "definitions": "aquaspec.rendering.layers: "
                            "linear = direct + backscatter (the image with every surface "
                            "black); surface = rho E(d, n)/pi and albedo = rho E0/pi in camera "
                            "RGB; transmission = RGB(T L_surf)/RGB(L_surf); range_m = S, 0 for "
                            "open water"}
    if backend == "gpu":
        params["adapter"] = adapter_info()
    return params
