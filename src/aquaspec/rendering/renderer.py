"""The rendering API: scene or RGB-D image -> G-buffer -> spectral shading -> images.

Data flows one way: spectral data (water, light, sensor, bands) -> scene ->
G-buffer (GPU rasteriser, or an RGB-D image) -> deferred spectral pass (GPU,
or its NumPy reference) -> linear camera RGB -> display.

:func:`render` is the one-call entry point; :class:`Renderer` keeps the GPU
passes alive for many frames (the interactive viewer and ``aquaspec bench``).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from aquaspec.transport import monzon2022 as model
from aquaspec.rendering.appearance import check_depth
from aquaspec.colour.bands import Bands
from aquaspec.scene.camera import Camera, check_size
from aquaspec.errors import AquaspecError
from aquaspec.scene.gbuffer import GBuffer
from aquaspec.light.sky import SurfaceLight, surface_light
from aquaspec.colour.reflectance import normalised_wavelength
from aquaspec.colour.sensors import Sensor, get_sensor
from aquaspec.medium.water import DEFAULT_SOURCE, Water, get_water

BACKENDS = ("gpu", "numpy")
#: Distance of the grey card used as reference by ``white_balance="white-patch"``.
WHITE_CARD_DISTANCE_M = 1.0


def white_card(camera: Camera) -> dict:
    """Where ``white_balance="white-patch"``'s grey card is: the diver's custom
    white balance, a card held :data:`WHITE_CARD_DISTANCE_M` in front of the
    camera along its view, facing it (keyword arguments of
    :func:`aquaspec.rendering.appearance.colour_of_setup`). Where that would be above
    the water (a camera near the surface looking up) the card is held level
    with the camera instead, in the view's compass direction."""
    from aquaspec.shading.shade import camera_depth
    depth = camera_depth(camera)
    view = np.asarray(camera.forward, dtype=float)
    if depth - WHITE_CARD_DISTANCE_M * view[1] < 0:
        flat = np.array([view[0], 0.0, view[2]])
        norm = np.linalg.norm(flat)
        view = flat / norm if norm > 1e-6 else np.array([0.0, 0.0, -1.0])
    return {"depth_m": depth, "distance_m": WHITE_CARD_DISTANCE_M, "view": view}


@dataclass(frozen=True)
class SpectralSetup:
    """Everything per band the shading needs: water, light, sensor on ``bands``."""

    water: Water
    sensor: Sensor
    light: SurfaceLight
    bands: Bands
    ambient: str = model.DEFAULT_AMBIENT
    outside: str = "error"
    ms_model: str = model.DEFAULT_MS_MODEL
    phase: str = "petzold"
    #: Parameters of the phase function, e.g. ``(("g", 0.92),)`` for ``hg``.
    phase_params: tuple = ()
    #: Forward cone counted as unscattered towards targets (light field),
    #: degrees; None: the model's default (:func:`aquaspec.transport.lightfield.solve.forward_cone`:
    #: 15, or 40 with ``cone_spread``).
    forward_cone_deg: float | None = None
    #: Spread the cone's light over the image from where the cone points
    #: (:mod:`aquaspec.transport.lightfield.conespread`, an image pyramid; GPU and NumPy); None:
    #: the model's default (:func:`aquaspec.transport.monzon2022.cone_spread_for`: on for the
    #: light field).
    cone_spread: bool | None = None
    #: With ``cone_spread``: the cone's light scattered once (``"single"``) or
    #: a Poisson number of times (``"multiple"``; :mod:`aquaspec.transport.lightfield.conespread`).
    spread_scattering: str = "single"
    #: The scene's first-order shadow in the light field (:mod:`aquaspec.transport.lightfield.shadow`;
    #: planned in NumPy from the G-buffer, seconds per image; the GPU renderer
    #: integrates its rays on its device: :meth:`Renderer.subtract_shadow`).
    ambient_shadow: bool = False
    #: The light field's lower boundary (:class:`aquaspec.transport.lightfield.solve.Seabed`);
    #: None: deep water. The seeds' model has none.
    seabed: object = None
    #: A wind-roughened surface (:class:`aquaspec.light.caustics.Waves`) focusing the
    #: sun's beam into caustics; None: a flat surface. Needs a sun.
    waves: object = None

    def __post_init__(self):
        object.__setattr__(self, "cone_spread",
                           model.cone_spread_for(self.ms_model, self.cone_spread))
        if self.waves is not None and self.light.sun is None:
            raise AquaspecError("waves focus the sun's beam into caustics: they need a light "
                                "with a sun (light 'sun-sky')")
        if self.ambient_shadow and self.ms_model != "lightfield":
            raise AquaspecError(f"ambient_shadow is part of the light-field model; ms_model="
                                f"{self.ms_model!r}; accepted: 'lightfield'")

    @property
    def cone_deg(self) -> float:
        """The forward cone in degrees, ``forward_cone_deg`` or the model's default."""
        from aquaspec.transport.lightfield.solve import forward_cone
        return forward_cone(self.forward_cone_deg, self.cone_spread)

    def lightfield_tables(self) -> dict | None:
        """Light-field tables for ``ms_model="lightfield"`` (None for the seeds' model).

        With a sun (``light.sun``) the field is the sky's and the sun's
        diffuse light, still per unit of the whole ``E0``.
        """
        if self.ms_model != "lightfield":
            return None
        cached = self.__dict__.get("_tables")
        if cached is None:
            from aquaspec.transport.lightfield.solve import lightfield_tables
            bed = ({} if self.seabed is None else
                   {"seabed_depth_m": float(self.seabed.depth_m),
                    "seabed_albedo": self.seabed.albedo_on(self.bands)})
            if self.light.sun is not None:
                e0 = self.light.on_bands(self.bands)
                bed = {**bed, "sun_mu0": self.light.sun.mu0,
                       "sun_fraction": np.clip(self.light.sun_horizontal_on(self.bands)
                                               / np.where(e0 > 0, e0, 1.0), 0.0, 1.0)}
            cached = lightfield_tables(self.water.on_bands(self.bands), phase=self.phase,
                                       forward_cone_deg=self.cone_deg,
                                       cone_spread=self.cone_spread,
                                       spread_scattering=self.spread_scattering,
                                       ambient_shadow=self.ambient_shadow,
                                       **bed, **dict(self.phase_params))
            object.__setattr__(self, "_tables", cached)
        return cached

    def sun_inputs(self):
        """What the sun's terms need per band (:class:`aquaspec.light.sun.SunInputs`),
        or None without a sun.

        The beam's extinction is the light field's delta-M ``c*`` (its diffuse
        field complements that beam) or ``c`` for the seeds' model; on the way
        to the camera the sun's light has the extinction the surfaces' light
        has (``c - f b`` with the light field's forward cone, else ``c``).
        """
        sun = self.light.sun
        if sun is None:
            return None
        cached = self.__dict__.get("_sun")
        if cached is None:
            from aquaspec.light.sun import SunInputs, phase_table
            bw = self.water.on_bands(self.bands)
            a, b = np.asarray(bw.a, dtype=float), np.asarray(bw.b, dtype=float)
            c = a + b
            tables = self.lightfield_tables()
            if tables is None:
                c_sun = c_view = c
            else:
                from aquaspec.transport.lightfield.solve import _beam_extinction
                c_sun = np.asarray(tables["beam_extinction"], dtype=float)
                c_view = _beam_extinction(tables, a, b)
            caustics = None
            if self.waves is not None:
                from aquaspec.light.caustics import cached_caustic_map
                caustics = cached_caustic_map(self.waves, sun.elevation_deg, sun.azimuth_deg,
                                              n_water=sun.n_water)
            cached = SunInputs(beam0=sun.beam_on(self.bands), c_sun=c_sun, c_view=c_view, b=b,
                               log_phase=phase_table(self.phase, b=b,
                                                     wavelength_nm=self.bands.centers_nm,
                                                     **dict(self.phase_params)),
                               to_sun=sun.to_sun, caustics=caustics)
            object.__setattr__(self, "_sun", cached)
        return cached

    def medium(self, materials) -> dict:
        """Keyword arguments of ``shade_gbuffer`` / ``DeferredPass.set_medium``."""
        bw = self.water.on_bands(self.bands)
        mb = (np.stack([m.on_bands(self.bands) for m in materials]) if materials
              else np.zeros((0, self.bands.n)))
        return dict(a=bw.a, b=bw.b, kd=bw.kd, e0=self.light.on_bands(self.bands),
                    response_weights=self.sensor.band_weights(self.bands, outside=self.outside),
                    material_bands=mb,
                    sigmoid_centers_t=normalised_wavelength(self.bands.centers_nm),
                    ambient=self.ambient)

    def describe(self) -> dict:
        model_params = ({"ambient_model": self.ambient} if self.ms_model == "seeds"
                        else {"phase": self.phase, **dict(self.phase_params),
                              "forward_cone_deg": self.cone_deg,
                              "cone_spread": self.cone_spread,
                              "spread_scattering": self.spread_scattering,
                              "ambient_shadow": self.ambient_shadow,
                              "seabed": None if self.seabed is None
                              else self.seabed.describe()})
        return {"water": self.water.describe(), "sensor": self.sensor.describe(),
                "light": self.light.describe(), "bands": self.bands.describe(),
                "ms_model": self.ms_model, **model_params,
                "sensor_outside_range": self.outside,
                **({} if self.waves is None else {"caustics": self.sun_inputs().caustics
                                                  .describe()})}


class Renderer:
    """GPU passes for one image size and band count, reused across frames.

    Parameters
    ----------
    width, height : int
    n_bands : int
    debug_radiance : bool
        Keep per-band radiance on the GPU so :meth:`read_radiance` works.
    """

    def __init__(self, width: int, height: int, n_bands: int, *, debug_radiance=False):
        from aquaspec.gpu.passes.deferred import DeferredPass
        from aquaspec.gpu.passes.raster import RasterPass
        self.width, self.height = check_size(width, height)
        self.deferred = DeferredPass(self.width, self.height, n_bands,
                                     debug_radiance=debug_radiance)
        self.raster = RasterPass(self.deferred.device)
        self._medium_key = None
        self.lightfield = None      # LightfieldPass, made when first needed
        self._use_lightfield = False
        self._shadow_rays = None    # ShadowRays, made when first needed
        self.sun = None             # SunPass, made when a light first has a sun
        self._sun_key = None
        #: Shadow-map side for the sun (texels).
        self.sun_map_size = None

    def set_spectral(self, setup: SpectralSetup, materials) -> None:
        key = (id(setup), tuple(id(m) for m in materials))
        if key != self._medium_key:
            self._use_lightfield = setup.ms_model == "lightfield"
            if self._use_lightfield:
                from aquaspec.gpu.passes.lightfield import LightfieldPass
                if self.lightfield is None:
                    self.lightfield = LightfieldPass(self.deferred)
                self.lightfield.set_medium(**setup.medium(materials),
                                           tables=setup.lightfield_tables())
            else:
                self.deferred.set_medium(**setup.medium(materials))
            self._medium_key = key

    def _shading_pass(self):
        return self.lightfield if self._use_lightfield else self.deferred

    def _sun_pass(self, setup: SpectralSetup, materials):
        """The sun pass with ``setup``'s inputs uploaded, or None without a sun."""
        sun = setup.sun_inputs()
        if sun is None:
            return None
        from aquaspec.gpu.passes.sun import SunPass
        from aquaspec.light.sun import DEFAULT_MAP_SIZE
        size = self.sun_map_size or DEFAULT_MAP_SIZE
        if self.sun is None or self.sun.map_size != size:
            self.sun = SunPass(self.deferred.device, self.width, self.height,
                               self.deferred.n_bands, map_size=size)
            self._sun_key = None
        key = (id(setup), tuple(id(m) for m in materials))
        if key != self._sun_key:
            medium = setup.medium(materials)
            self.sun.set_inputs(sun, response_weights=medium["response_weights"],
                                material_bands=medium["material_bands"],
                                sigmoid_centers_t=medium["sigmoid_centers_t"])
            self._sun_key = key
        return self.sun

    def render_scene(self, scene, camera: Camera, setup: SpectralSetup,
                     progress=None) -> np.ndarray:
        """Rasterise and shade on the GPU; returns linear camera RGB (H, W, 3) float32.

        With ``setup.ambient_shadow`` the frame's G-buffer is read back and the
        scene's shadow in the light field subtracted (:meth:`subtract_shadow`,
        which calls ``progress`` with a short message per step).
        """
        self._check_camera(camera)
        self.set_spectral(setup, scene.materials)
        sun = self._sun_pass(setup, scene.materials)
        enc = self.deferred.device.create_command_encoder()
        self.raster.render_to(self.deferred, scene, camera, encoder=enc)
        self._shading_pass().encode(enc)
        if sun is not None:
            sun.encode_shadow_map(enc, self.raster, scene, camera)
            sun.encode(enc, camera, self.deferred.gbuffer_textures,
                       self._shading_pass().rgb_buffer)
        self.deferred.device.queue.submit([enc.finish()])
        rgb = self._shading_pass().read_rgb()
        if setup.ambient_shadow:
            gbuffer = self.raster.read_gbuffer(scene, camera, self.deferred.gbuffer_textures)
            rgb = self.subtract_shadow(rgb, gbuffer, setup, progress)
        return rgb

    def render_gbuffer(self, gbuffer: GBuffer, setup: SpectralSetup,
                       progress=None, *, sun_scene=None) -> np.ndarray:
        """Shade a G-buffer made elsewhere (e.g. RGB-D) on the GPU (and subtract
        the shadow with ``setup.ambient_shadow``, as :meth:`render_scene`).

        With a sun, ``sun_scene`` (the scene the G-buffer shows, if any)
        casts the sun's shadows; without it nothing does.
        """
        self._check_camera(gbuffer.camera)
        self.set_spectral(setup, gbuffer.materials)
        self.deferred.set_gbuffer(gbuffer)
        sun = self._sun_pass(setup, gbuffer.materials)
        if sun is None:
            self._shading_pass().run()
        else:
            enc = self.deferred.device.create_command_encoder()
            self._shading_pass().encode(enc)
            if sun_scene is not None:
                sun.encode_shadow_map(enc, self.raster, sun_scene, gbuffer.camera)
            else:
                sun.no_shadows()
            sun.encode(enc, gbuffer.camera, self.deferred.gbuffer_textures,
                       self._shading_pass().rgb_buffer)
            self.deferred.device.queue.submit([enc.finish()])
        rgb = self._shading_pass().read_rgb()
        if setup.ambient_shadow:
            rgb = self.subtract_shadow(rgb, gbuffer, setup, progress)
        return rgb

    def subtract_shadow(self, rgb: np.ndarray, gbuffer: GBuffer, setup: SpectralSetup,
                        progress=None) -> np.ndarray:
        """``rgb`` minus the scene's shadow in the light field, in camera RGB.

        The term (:func:`aquaspec.shading.shade.scene_shadow`) is planned in NumPy
        from ``gbuffer`` (which pixels take which receivers, the source
        blocks), its receivers' rays are integrated on this renderer's device
        (:class:`aquaspec.gpu.passes.shadow_rays.ShadowRays`), and it is linear in the
        band radiance, so its camera RGB is subtracted from the GPU's image as
        the NumPy model subtracts it from the radiance.
        """
        from aquaspec.gpu.passes.shadow_rays import ShadowRays
        from aquaspec.shading.shade import scene_shadow
        if self._shadow_rays is None:
            self._shadow_rays = ShadowRays(self.deferred.device, self.deferred.n_bands)
        medium = setup.medium(gbuffer.materials)
        dl = scene_shadow(gbuffer, **medium, lightfield=setup.lightfield_tables(),
                          progress=progress, rays=self._shadow_rays)
        drgb = model.radiance_to_rgb(dl.reshape(-1, dl.shape[-1]), medium["response_weights"])
        return (rgb - drgb.reshape(rgb.shape)).astype(rgb.dtype)

    def read_radiance(self) -> np.ndarray:
        return self.deferred.read_radiance()

    def _check_camera(self, camera):
        if (camera.width, camera.height) != (self.width, self.height):
            raise AquaspecError(f"camera is {camera.width}x{camera.height}; this renderer "
                                f"was made for {self.width}x{self.height}")


@dataclass
class RenderResult:
    """What :func:`render` returns.

    Attributes
    ----------
    display : ndarray (H, W, 3) uint8
        sRGB-encoded, exposed and tone-mapped image.
    linear_rgb : ndarray (H, W, 3) float
        Linear camera RGB (see :func:`aquaspec.transport.monzon2022.radiance_to_rgb`).
    radiance : ndarray (H, W, n) or None
        Band radiance, W m^-2 sr^-1 nm^-1, when asked for.
    gbuffer : GBuffer
    params : dict
        Every parameter of the render (for sidecars).
    layers : dict or None
        With ``layers=True``: the image-formation layers
        (:mod:`aquaspec.rendering.layers`: backscatter, direct, surface, albedo,
        transmission, range_m).
    """

    display: np.ndarray
    linear_rgb: np.ndarray
    radiance: np.ndarray | None
    gbuffer: GBuffer | None
    params: dict = field(default_factory=dict)
    layers: dict | None = None


def parse_size(text) -> tuple[int, int]:
    """``"WxH"`` -> (W, H), validated (1 to 8192)."""
    if isinstance(text, (tuple, list)) and len(text) == 2:
        return check_size(*text)
    try:
        w, h = (int(x) for x in str(text).lower().split("x"))
    except ValueError:
        raise AquaspecError(f"image size {text!r} is not WIDTHxHEIGHT, e.g. 1280x720") from None
    return check_size(w, h)


def _scene_for(mesh, depth_m, width, height, albedo):
    from aquaspec.scene.builtin import builtin_scene
    if mesh is None:
        return builtin_scene(depth_m, width=width, height=height)
    from aquaspec.scene.load import load_mesh, place_in_front
    scene = load_mesh(mesh, albedo=albedo)
    scene = place_in_front(scene, depth_m=depth_m, width=width, height=height)
    return scene, scene.camera


def _waves(waves):
    """``render(waves=)``: None, a :class:`aquaspec.light.caustics.Waves` or a wind speed."""
    if waves is None:
        return None
    from aquaspec.light.caustics import Waves
    if isinstance(waves, Waves):
        return waves
    if isinstance(waves, (int, float)) and not isinstance(waves, bool):
        return Waves(float(waves))
    raise AquaspecError(f"waves={waves!r}; accepted: None, a wind speed in m/s or an "
                        "aquaspec.light.caustics.Waves")


def render(*, water="IB", source: str = DEFAULT_SOURCE, depth_m: float = 5.0,
           sensor="human", camspec=None, bands: int = 16, wavelength_range=(400.0, 700.0),
           size=(1280, 720), scene=None, camera: Camera | None = None, mesh=None, albedo=None,
           rgbd=None, light="overcast", irradiance_w_m2=None, sun_elevation_deg=60.0,
           sun_azimuth_deg=None, sun_shadow_map: int | None = None, waves=None,
           ambient: str = model.DEFAULT_AMBIENT, outside: str = "error",
           ms_model: str = model.DEFAULT_MS_MODEL, phase: str = "petzold",
           forward_cone_deg: float | None = None, cone_spread: bool | None = None,
           spread_scattering: str = "single", ambient_shadow: bool = False, seabed="scene",
           exposure="auto", white_balance="none", tonemap="filmic",
           colour_matrix="auto", return_radiance: bool = False, layers: bool = False,
           backend: str = "gpu", progress=None) -> RenderResult:
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
    rgbd : (image, depth, intrinsics), optional
        An RGB image (path or array), a metric depth map (path or array, m)
        and pinhole intrinsics ``(fx, fy, cx, cy)``: a photograph becomes an
        underwater one with the camera at ``depth_m``.
    light : str or SurfaceLight
        ``overcast``, ``d65`` or ``sun-sky`` (see :mod:`aquaspec.light.sky`).
        ``sun-sky`` has a sun (at ``sun_elevation_deg``, ``sun_azimuth_deg``):
        its refracted beam lights the surfaces, is shadowed by the scene and
        is scattered once towards the camera (:mod:`aquaspec.light.sun`).
    sun_shadow_map : int, optional
        Side of the sun's shadow map in texels (default
        :data:`aquaspec.light.sun.DEFAULT_MAP_SIZE`); shadows are resolved within
        :data:`aquaspec.light.sun.DEFAULT_MAP_RADIUS_M` of the camera. RGB-D
        images cast no sun shadows (they have no geometry behind the
        visible surfaces).
    waves : aquaspec.light.caustics.Waves or float, optional
        A wind sea on the surface (a wind speed in m/s stands for
        ``Waves(wind_speed)``): the sun's beam is focused into caustics on the
        surfaces and in the water (:mod:`aquaspec.light.caustics`). Needs a sun.
    ambient : str
        Ambient irradiance model of the seeds' model
        (:data:`aquaspec.transport.monzon2022.AMBIENT_MODELS`).
    ms_model : str
        Multiple-scattering model (:data:`aquaspec.transport.monzon2022.MS_MODELS`):
        ``"lightfield"`` (the default; with phase function ``phase``;
        scattering within ``forward_cone_deg`` of forward stays in the beam
        towards surfaces, see :func:`aquaspec.transport.lightfield.solve.lightfield_tables`;
        None: 15, or 40 with ``cone_spread``; ``cone_spread`` spreads that
        light over the image from where the cone points,
        :mod:`aquaspec.transport.lightfield.conespread`; None: on) or ``"seeds"`` (thesis Eq. 4.7).
    spread_scattering : {"single", "multiple"}
        With ``cone_spread``: the cone's light scattered once, or a Poisson
        number of times with mean ``f b S`` per pixel and band
        (:func:`aquaspec.transport.lightfield.solve.lightfield_tables`).
    ambient_shadow : bool
        Subtract the scene's first-order shadow in the water's light field
        (:mod:`aquaspec.transport.lightfield.shadow`; goes with ``spread_scattering="multiple"``).
        Integrated in NumPy from the G-buffer with either backend (the GPU's
        image has it subtracted in camera RGB): seconds per image.
    seabed : "scene", None or Seabed
        The light field's lower boundary (:class:`aquaspec.transport.lightfield.solve.Seabed`):
        ``"scene"`` takes the scene's (the built-in scene's sand; none for
        meshes, RGB-D images and scenes without one), None is deep water.
        It must lie below the camera.
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
    """
    from aquaspec.colour.display import to_display
    say = progress or (lambda msg: None)
    if backend not in BACKENDS:
        raise AquaspecError(f"backend {backend!r} is unknown; accepted: {', '.join(BACKENDS)}")
    depth = check_depth(depth_m)
    width, height = parse_size(size)
    t0 = time.perf_counter()
    water_obj = water if isinstance(water, Water) else get_water(water, source)
    sensor_obj = sensor if isinstance(sensor, Sensor) else get_sensor(sensor, camspec)
    from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG
    from aquaspec.light.sun import DEFAULT_MAP_SIZE
    light_obj = light if isinstance(light, SurfaceLight) else surface_light(
        light, total_w_m2=irradiance_w_m2, sun_elevation_deg=sun_elevation_deg,
        sun_azimuth_deg=DEFAULT_SUN_AZIMUTH_DEG if sun_azimuth_deg is None else sun_azimuth_deg)
    map_size = DEFAULT_MAP_SIZE if sun_shadow_map is None else sun_shadow_map
    from aquaspec.rendering.appearance import check_ms_model
    setup = SpectralSetup(water_obj, sensor_obj, light_obj, Bands(bands, *wavelength_range),
                          ambient, outside, check_ms_model(ms_model), phase,
                          forward_cone_deg=forward_cone_deg, cone_spread=cone_spread,
                          spread_scattering=spread_scattering, ambient_shadow=ambient_shadow,
                          waves=_waves(waves))
    medium_check = setup.medium([])  # fail early on ranges before any geometry work
    del medium_check
    if setup.waves is not None:
        wv = setup.waves
        say(f"caustics of a {wv.wind_speed:g} m/s sea ({wv.tile_m:g} m tile, "
            f"{wv.grid}x{wv.grid} samples) under the sun")
        setup.sun_inputs()

    gbuffer = None
    source_desc = {}
    if rgbd is not None:
        from aquaspec.scene.rgbd import gbuffer_from_rgbd, load_rgbd
        image, depth_map, intrinsics = rgbd
        if isinstance(image, (str,)) or hasattr(image, "__fspath__"):
            source_desc = {"rgbd_image": str(image), "rgbd_depth": str(depth_map)}
            image, depth_map = load_rgbd(image, depth_map)
        say("building the G-buffer from the RGB-D image")
        gbuffer = gbuffer_from_rgbd(image, depth_map, intrinsics, camera_depth_m=depth)
        camera = gbuffer.camera
        scene_desc = {"kind": "rgbd", "intrinsics": list(map(float, intrinsics)), **source_desc}
    else:
        if scene is None:
            say("building the scene")
            scene, default_cam = _scene_for(mesh, depth, width, height, albedo)
            camera = camera or default_cam
            scene_desc = {"kind": "builtin" if mesh is None else "mesh",
                          **({"mesh": str(mesh)} if mesh is not None else {})}
        else:
            camera = camera or scene.camera
            if camera is None:
                raise AquaspecError("a user scene needs a camera (scene.camera or camera=)")
            scene_desc = {"kind": "user", "meshes": len(scene.meshes)}

    bed = (getattr(scene, "seabed", None) if isinstance(seabed, str) and seabed == "scene"
           else seabed)
    if bed is not None and not hasattr(bed, "albedo_on"):
        raise AquaspecError(f"seabed={seabed!r}; accepted: 'scene', None or an "
                            "aquaspec.transport.lightfield.solve.Seabed")
    if bed is not None and ms_model == "lightfield":
        from aquaspec.shading.shade import camera_depth
        d_cam = camera_depth(camera)
        if float(bed.depth_m) <= d_cam:
            raise AquaspecError(f"the seabed at {float(bed.depth_m):g} m is not below the "
                                f"camera at {d_cam:g} m; accepted: a seabed deeper than "
                                "the camera, or seabed=None")
        setup = dataclasses.replace(setup, seabed=bed)
    reference = white_card_info = None
    if white_balance == "white-patch":
        # Before any shading: a card the balance cannot use fails now.
        from aquaspec.rendering.appearance import colour_of_setup
        from aquaspec.colour.display import display_settings
        card = white_card(camera)
        reference = colour_of_setup(setup, **card)["grey_card_rgb"]
        white_card_info = {"distance_m": card["distance_m"],
                           "view_direction": card["view"].tolist(), "camera_rgb": reference}
        try:
            display_settings(np.ones((1, 1, 3)), white_balance="white-patch",
                             reference_rgb=reference, cone_matrix=setup.sensor.cone_matrix())
        except AquaspecError as exc:
            raise AquaspecError(
                f"white_balance='white-patch': the grey card 1 m ahead has camera RGB "
                f"{', '.join(f'{x:.3g}' for x in reference)} for sensor "
                f"{setup.sensor.name!r}, which cannot be balanced ({exc}); accepted: "
                "white_balance 'grey-world' or 'none', or a shallower scene") from None
    n = setup.bands.n
    radiance = None
    sun_shadow = None
    if backend == "gpu":
        say(f"shading {camera.width}x{camera.height} pixels x {n} bands on the GPU"
            + (" (the scene's shadow in the light field in NumPy)" if ambient_shadow else ""))
        if return_radiance and ms_model != "seeds":
            raise AquaspecError("per-band radiance from the GPU is available for "
                                "ms_model='seeds'; use backend='numpy' for the light field")
        r = Renderer(camera.width, camera.height, n, debug_radiance=return_radiance)
        r.sun_map_size = map_size
        if return_radiance and light_obj.sun is not None:
            raise AquaspecError("per-band radiance with a sun is available from "
                                "backend='numpy'")
        if gbuffer is None:
            linear = r.render_scene(scene, camera, setup, say).astype(np.float64)
            if return_radiance:
                radiance = r.read_radiance()
            gbuffer = None
        else:
            linear = r.render_gbuffer(gbuffer, setup, say).astype(np.float64)
            if return_radiance:
                radiance = r.read_radiance()
    else:
        from aquaspec.gpu.passes.raster import raycast_gbuffer
        from aquaspec.shading.shade import shade_gbuffer
        if gbuffer is None:
            say("ray casting the G-buffer (NumPy)")
            gbuffer = raycast_gbuffer(scene, camera)
        say(f"shading {camera.width}x{camera.height} pixels x {n} bands in NumPy"
            + (" with the scene's shadow in the light field" if ambient_shadow else ""))
        if light_obj.sun is not None and rgbd is None:
            from aquaspec.light.sun import numpy_shadow_map
            say(f"the sun's shadow map, {map_size}x{map_size} texels (NumPy)")
            sun_shadow = numpy_shadow_map(scene, camera, light_obj.sun.to_sun, size=map_size)
        out = shade_gbuffer(gbuffer, **setup.medium(gbuffer.materials),
                            return_radiance=return_radiance,
                            lightfield=setup.lightfield_tables(), progress=say,
                            sun=setup.sun_inputs(), sun_shadow=sun_shadow)
        linear, radiance = out["camera_rgb"], out.get("radiance")
    bad = ~np.isfinite(linear)
    if bad.any():
        i, j = np.argwhere(bad.any(axis=-1))[0]
        raise AquaspecError(f"{int(bad.any(axis=-1).sum())} pixels came out NaN or infinite "
                            f"(first at row {i}, column {j}); this is a bug, please report it "
                            "with the parameters")
    layer_set = None
    if layers:
        from aquaspec.rendering.layers import black_gbuffer, image_layers
        say("image-formation layers: the image again with every surface black")
        if backend == "gpu":
            if gbuffer is None:
                gbuffer = r.raster.read_gbuffer(scene, camera, r.deferred.gbuffer_textures)
            back = r.render_gbuffer(black_gbuffer(gbuffer), setup, say,
                                    sun_scene=scene if rgbd is None else None
                                    ).astype(np.float64)
        else:
            black = black_gbuffer(gbuffer)
            back = shade_gbuffer(black, **setup.medium(black.materials),
                                 lightfield=setup.lightfield_tables(), progress=say,
                                 sun=setup.sun_inputs(), sun_shadow=sun_shadow)["camera_rgb"]
        sun_vis = None
        if light_obj.sun is not None:
            from aquaspec.light.sun import surface_visibility
            caustics = setup.sun_inputs().caustics
            if backend == "gpu":
                shadowed = r.sun is not None and r.sun.shadowed
                sun_vis = surface_visibility(
                    gbuffer, r.sun.read_shadow_map() if shadowed else None,
                    r.sun.spec if shadowed else None, caustics=caustics)
            else:
                sun_vis = surface_visibility(gbuffer, *(sun_shadow or (None, None)),
                                             caustics=caustics)
        layer_set = image_layers(linear, back, gbuffer, setup.medium(gbuffer.materials),
                                 setup.lightfield_tables(), sun=setup.sun_inputs(),
                                 sun_visibility=sun_vis)
    if isinstance(colour_matrix, str):
        if colour_matrix != "auto":
            raise AquaspecError(f"colour_matrix {colour_matrix!r} is not accepted; use 'auto', "
                                "None or a 3x3 matrix")
        colour_matrix = sensor_obj.srgb_matrix()
    display, info = to_display(linear, exposure=exposure, white_balance=white_balance,
                               reference_rgb=reference, tonemap=tonemap, matrix=colour_matrix,
                               cone_matrix=sensor_obj.cone_matrix())
    params = {
        **setup.describe(),
        "depth_m": depth,
        "camera": camera.describe(),
        "scene": scene_desc,
        "backend": backend,
        "display": info,
        "render_seconds": time.perf_counter() - t0,
    }
    if white_card_info is not None:
        params["white_card"] = white_card_info
    if light_obj.sun is not None:
        from aquaspec.light.sun import DEFAULT_MAP_RADIUS_M, FROXEL_SLICES, FROXEL_TILE
        params["sun_rendering"] = {
            "shadow_map_texels": map_size if rgbd is None else None,
            "shadow_radius_m": DEFAULT_MAP_RADIUS_M if rgbd is None else None,
            "single_scattering": f"froxels of {FROXEL_TILE}x{FROXEL_TILE} pixels, "
                                 f"{FROXEL_SLICES} slices",
            "beam_extinction": "c* (delta-M) with the light field, c with the seeds' model"}
    if layer_set is not None:
        from aquaspec.rendering.layers import LAYER_NAMES
        params["layers"] = {"names": list(LAYER_NAMES), "definitions": "aquaspec.rendering.layers: "
                            "linear = direct + backscatter (the image with every surface "
                            "black); surface = rho E(d, n)/pi and albedo = rho E0/pi in camera "
                            "RGB; transmission = RGB(T L_surf)/RGB(L_surf); range_m = S, 0 for "
                            "open water"}
    if backend == "gpu":
        from aquaspec.gpu.device import adapter_info
        params["adapter"] = adapter_info()
    return RenderResult(display, linear, radiance, gbuffer, params, layer_set)
