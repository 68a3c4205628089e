"""The GPU renderer: the passes of a frame, kept alive from frame to frame.

:class:`Renderer` owns one image size's GPU passes (the rasteriser, the
seeds' or the light field's shading pass, the sun's passes and the shadow
rays), uploads a :class:`aquaspec.rendering.setup.SpectralSetup` to them when
it changes, and records a frame: rasterise (or take a G-buffer made
elsewhere), shade, add the sun, read back linear camera RGB.
:func:`aquaspec.rendering.api.render` makes one for one image; the
interactive viewer and ``aquaspec bench`` keep one for many frames.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from aquaspec.colour.display import display_settings
from aquaspec.colour.sensors import radiance_to_rgb
from aquaspec.errors import AquaspecError
from aquaspec.gpu.buffers import read_buffer
from aquaspec.gpu.passes.deferred import DeferredPass
from aquaspec.gpu.passes.display import DisplayPass
from aquaspec.gpu.passes.lightfield import LightfieldPass
from aquaspec.gpu.passes.occlusion import DEFAULT_SCALE, OcclusionPass
from aquaspec.gpu.passes.raster import RasterPass
from aquaspec.gpu.passes.shadow_rays import ShadowRays
from aquaspec.gpu.passes.caustics import CausticLoopPass
from aquaspec.gpu.passes.sun import SunPass
from aquaspec.light.caustics import DEFAULT_LOOP_FRAMES, caustic_loop
from aquaspec.rendering.lamps import lamps_before_shading, lamps_shaded
from aquaspec.rendering.above import above_water
from aquaspec.rendering.live_above import LiveAbove, check_live_above
from aquaspec.rendering.live_camera import LiveCamera
from aquaspec.rendering.live_surface import LiveSurface, surface_drawn
from aquaspec.rendering.marine_snow import LiveSnow, parse_marine_snow
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import Camera, check_size
from aquaspec.scene.gbuffer import GBuffer
from aquaspec.scene.occlusion import (DEFAULT_DIRECTIONS, DEFAULT_OCCLUSION_MAP_SIZE,
                                      occluder_triangles, occlusion_layout)
from aquaspec.scene.shadowmap import BIAS_TEXELS, DEFAULT_MAP_SIZE, NORMAL_OFFSET_TEXELS
from aquaspec.shading.shade import scene_shadow
from aquaspec.transport.lightfield.occlusion import weights_from_tables


def _same(key, other) -> bool:
    """Whether two ``(setup, materials)`` keys hold the very same objects."""
    return (other is not None and key[0] is other[0] and len(key[1]) == len(other[1])
            and all(a is b for a, b in zip(key[1], other[1])))


def _check_moved_only(own: Camera, camera: Camera) -> None:
    """Refuse ``camera`` unless it is ``own`` moved: a G-buffer made elsewhere
    (an RGB-D photograph) holds distances along its own rays only."""
    same_view = ((camera.width, camera.height) == (own.width, own.height)
                 and np.allclose([camera.fx, camera.fy, camera.cx, camera.cy],
                                 [own.fx, own.fy, own.cx, own.cy])
                 and np.allclose(camera.forward, own.forward)
                 and np.allclose(camera.true_up, own.true_up))
    if not same_view:
        raise AquaspecError("a G-buffer made elsewhere (an RGB-D photograph) is seen only "
                            "along its own rays: the camera may move, not turn, zoom or "
                            "change size")


def _seen_from(gbuffer: GBuffer, camera: Camera) -> GBuffer:
    """``gbuffer`` with ``camera``, its own camera moved (:func:`_check_moved_only`)."""
    if camera is gbuffer.camera:
        return gbuffer
    _check_moved_only(gbuffer.camera, camera)
    return dataclasses.replace(gbuffer, camera=camera)


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
        self._display = None        # DisplayPass of frames with the sun (set_display)
        self._last_display = None
        self._surface = None        # LiveSurface, made when a frame first sees the surface
        self._above = None          # LiveAbove, made for a first camera above the sea
        #: Live frames draw the surface seen from below where render() does
        #: (:mod:`aquaspec.rendering.live_surface`); False leaves it out.
        self.surface_from_below = True
        #: The waves' time of the next frames' caustics, s (:meth:`set_wave_time`).
        self.wave_time_s = None
        self._wave_loop = None      # CausticLoopPass of the moving sea
        self._loop_options = (DEFAULT_LOOP_FRAMES, True, False)
        #: The scene's occlusion of the ambient light (:meth:`set_occlusion`): options or None.
        self.occlusion_options = None
        self.occlusion = None       # OcclusionPass, made when first needed
        self._occ_cache = {}
        self._shown_gbuffer = None  # the host G-buffer whose textures the frames read
        #: Live frames through a camera model (:meth:`set_camera_model`), or None.
        self.live_camera = None
        #: Marine snow over the live frames (:meth:`set_marine_snow`), or None.
        self.snow = None
        self._snow_kept = None
        #: The lamps' pass of the last render_scene / render_gbuffer, recorded
        #: before its shading (aquaspec.rendering.lamps.lamps_before_shading), or None.
        self.lamp_pass = None

    def set_spectral(self, setup: SpectralSetup, materials) -> None:
        """Upload ``setup``'s medium for a scene of ``materials`` to the shading
        pass (the light field's or the seeds'), unless it is there already."""
        # The key holds the objects themselves: an id() alone may be reused
        # by a new setup once the old one is freed.
        key = (setup, tuple(materials))
        if not _same(key, self._medium_key):
            self._use_lightfield = setup.ms_model == "lightfield"
            if self._use_lightfield:
                if self.lightfield is None:
                    self.lightfield = LightfieldPass(self.deferred.gbuffer)
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
        size = self.sun_map_size or DEFAULT_MAP_SIZE
        if self.sun is None or self.sun.map_size != size:
            self.sun = SunPass(self.deferred.device, self.width, self.height,
                               self.deferred.n_bands, map_size=size)
            self._sun_key = None
        key = (setup, tuple(materials))
        if not _same(key, self._sun_key):
            medium = setup.medium(materials)
            self.sun.set_inputs(sun, response_weights=medium["response_weights"],
                                material_bands=medium["material_bands"],
                                sigmoid_centers_t=medium["sigmoid_centers_t"])
            self._sun_key = key
        return self.sun

    def set_wave_time(self, time_s: float | None, *, frames: int = DEFAULT_LOOP_FRAMES,
                      smooth: bool = True, progressive: bool = False) -> None:
        """Move the waves: the next frames' caustics are the setup's sea at
        ``time_s`` seconds, read from its loop
        (:func:`aquaspec.light.caustics.caustic_loop`, ``frames`` per period;
        built on the CPU once per sea state and sun, each frame kept in the
        cache) and mixed on the GPU per frame
        (:class:`aquaspec.gpu.passes.caustics.CausticLoopPass`; ``smooth=False``
        copies the nearest frame). None: the setup's own still map.
        ``progressive``: do not wait for a new loop; until it is built in the
        background, frames read between the loop's frames built so far (at
        first only ``t = 0``'s, the still map: live views)."""
        self.wave_time_s = None if time_s is None else float(time_s)
        self._loop_options = (frames, bool(smooth), bool(progressive))
        if self.wave_time_s is None:
            self._sun_key = None    # the still map goes back on the next frame

    def _advance_waves(self, encoder, setup: SpectralSetup) -> bool:
        """Record the caustics at :attr:`wave_time_s` for the sun pass
        (:meth:`set_wave_time`); False: the waves stand still."""
        if self.wave_time_s is None or setup.waves is None:
            return False
        frames, smooth, progressive = self._loop_options
        sun = setup.light.sun
        loop = caustic_loop(setup.waves, sun.elevation_deg, sun.azimuth_deg, frames=frames,
                            n_water=sun.n_water, background=progressive,
                            scatter=setup.sun_inputs().caustics.scatter)
        if self._wave_loop is None or self._wave_loop.loop is not loop:
            self._wave_loop = CausticLoopPass(self.deferred.device, loop)
        self._wave_loop.smooth = smooth
        self._wave_loop.encode(encoder, self.wave_time_s)
        self.sun.use_caustic_texture(self._wave_loop.view, self._wave_loop.geometry,
                                     loop.band_scale)
        return True

    def render_scene(self, scene, camera: Camera, setup: SpectralSetup,
                     progress=None) -> np.ndarray:
        """Rasterise and shade on the GPU; returns linear camera RGB (H, W, 3) float32.

        ``scene`` may also be a :class:`~aquaspec.scene.gbuffer.GBuffer` made
        elsewhere (an RGB-D photograph), seen from ``camera`` as in
        :meth:`encode_frame`.

        With ``setup.ambient_shadow`` the frame's G-buffer is read back and the
        scene's shadow in the light field subtracted (:meth:`subtract_shadow`,
        which calls ``progress`` with a short message per step).
        """
        if isinstance(scene, GBuffer):
            return self.render_gbuffer(_seen_from(scene, camera), setup, progress)
        self._check_camera(camera)
        self.set_spectral(setup, scene.materials)
        sun = self._sun_pass(setup, scene.materials)
        enc = self.deferred.device.create_command_encoder()
        self.raster.render_to(self.deferred.gbuffer, scene, camera, encoder=enc)
        self._shown_gbuffer = None
        if sun is not None:
            self._advance_waves(enc, setup)
        lamps_before_shading(self, enc, setup, camera, scene.materials, scene)
        self.encode_shading(enc, sun, camera, scene)
        self.deferred.device.queue.submit([enc.finish()])
        lamps_shaded(self)
        rgb = self._shading_pass().read_rgb()
        if setup.ambient_shadow:
            gbuffer = self.raster.read_gbuffer(scene, camera, self.deferred.gbuffer.textures)
            rgb = self.subtract_shadow(rgb, gbuffer, setup, progress)
        return rgb

    def render_gbuffer(self, gbuffer: GBuffer, setup: SpectralSetup,
                       progress=None, *, sun_scene=None, occluders=None) -> np.ndarray:
        """Shade a G-buffer made elsewhere (e.g. RGB-D) on the GPU (and subtract
        the shadow with ``setup.ambient_shadow``, as :meth:`render_scene`).

        With a sun, ``sun_scene`` (the scene the G-buffer shows, if any)
        casts the sun's shadows; without it nothing does. With
        :meth:`set_occlusion`, ``occluders`` (a scene; default ``sun_scene``)
        occlude the ambient light, e.g. an RGB-D image's visible surface
        (:func:`aquaspec.scene.occlusion.visible_surface_occluders`).
        """
        self._check_camera(gbuffer.camera)
        self.set_spectral(setup, gbuffer.materials)
        self.deferred.gbuffer.upload(gbuffer)
        self._shown_gbuffer = None
        sun = self._sun_pass(setup, gbuffer.materials)
        enc = self.deferred.device.create_command_encoder()
        if sun is not None:
            self._advance_waves(enc, setup)
        lamps_before_shading(self, enc, setup, gbuffer.camera, gbuffer.materials, sun_scene)
        self.encode_shading(enc, sun, gbuffer.camera, sun_scene,
                            occluders=sun_scene if occluders is None else occluders)
        self.deferred.device.queue.submit([enc.finish()])
        lamps_shaded(self)
        rgb = self._shading_pass().read_rgb()
        if setup.ambient_shadow:
            rgb = self.subtract_shadow(rgb, gbuffer, setup, progress)
        return rgb

    def set_occlusion(self, enabled: bool, *, directions: int = DEFAULT_DIRECTIONS,
                      scale: int = DEFAULT_SCALE,
                      map_size: int = DEFAULT_OCCLUSION_MAP_SIZE) -> None:
        """Occlude the ambient light field on the scene's surfaces in the
        frames from now on (light-field model, scenes with meshes; RGB-D
        G-buffers have no geometry behind what they show and get none):
        ``directions`` maps of ``map_size`` texels
        (:func:`aquaspec.scene.occlusion.occlusion_layout`, drawn once for a
        static scene), factors on cells of ``scale`` pixels
        (:class:`aquaspec.gpu.passes.occlusion.OcclusionPass`, computed again
        when the camera moves). The water's own shadow
        (:mod:`aquaspec.transport.lightfield.water_occlusion`) is NumPy only."""
        if not enabled:
            self.occlusion_options = None
            return
        if self.occlusion is None or self.occlusion.scale != scale:
            self.occlusion = OcclusionPass(self.deferred.device, self.width, self.height,
                                           self.deferred.n_bands, scale=scale)
        self.occlusion_options = (int(directions), int(map_size))

    def encode_occlusion_now(self, scene, camera) -> bool:
        """Compute the occlusion factors of the G-buffer now (submitted); whether there are any."""
        enc = self.deferred.device.create_command_encoder()
        out = self.encode_occlusion(enc, camera, scene)
        self.deferred.device.queue.submit([enc.finish()])
        return out

    def encode_occlusion(self, encoder, camera, scene, timestamp_writes=None) -> bool:
        """Record the occlusion factors for this frame (:meth:`set_occlusion`)
        of the G-buffer; whether there are any."""
        if self.occlusion_options is None or not self._use_lightfield or scene is None:
            return False
        directions, map_size = self.occlusion_options
        tables = self.lightfield.tables
        key = (id(scene), directions)
        if self._occ_cache.get("scene") != key:
            self._occ_cache = {"scene": key, "scene_ref": scene,
                               "triangles": occluder_triangles(scene)}
        tris = self._occ_cache["triangles"]
        if len(tris.corners) == 0:
            return False
        # The maps' geometry follows the camera's position only (snapped to
        # cells): made again when it moves, not every frame.
        where = (tuple(camera.position), map_size)
        if self._occ_cache.get("where") != where:
            self._occ_cache["where"] = where
            self._occ_cache["layout"] = occlusion_layout(scene, camera, directions=directions,
                                                         size=map_size, triangles=tris)
        layout = self._occ_cache["layout"]
        if self._occ_cache.get("tables") is not tables:
            a, b = self.lightfield.band_coefficients
            self._occ_cache["tables"] = tables
            self._occ_cache["weights"] = weights_from_tables(
                tables, layout.directions, layout.solid_angle, a=a, b=b)
        self.occlusion.set_weights(self._occ_cache["weights"])
        self.occlusion.encode(encoder, self.deferred.gbuffer, layout,
                              normal_offset_texels=NORMAL_OFFSET_TEXELS, bias_texels=BIAS_TEXELS,
                              timestamp_writes=timestamp_writes)
        return True

    def encode_shading(self, encoder, sun, camera, shadow_scene, *, split=None,
                       display: bool = False, occluders=None):
        """Record the shading of the G-buffer and, with ``sun`` (a
        :class:`~aquaspec.gpu.passes.sun.SunPass` with its inputs set), the sun:
        its shadow map of ``shadow_scene`` (None: nothing shadowed) and its
        froxels, then the light field's shading with the sun's light in its
        band loop (the display transform fused with ``display``), or the seeds'
        shading followed by the sun's per-pixel pass (linear RGB only).
        ``split`` as in :meth:`encode_frame` (``"sun shadow"``, ``"sun
        froxels"``, ``"shading"`` or with ``display`` ``"shading+display"``; seeds'
        model: ``"shading"``, ``"sun shadow"``, ``"sun"``); returns the encoder
        last returned by it."""
        split = split or (lambda name, enc: enc)
        shading = self._shading_pass()
        fused = sun is not None and self._use_lightfield
        if self.lightfield is not None:
            self.lightfield.set_sun(sun if fused else None)
            occluded = self.encode_occlusion(encoder, camera, shadow_scene if occluders is None
                                             else occluders)
            self.lightfield.set_occlusion(self.occlusion if occluded else None)
            if occluded:
                encoder = split("occlusion", encoder)
        if sun is None or fused:
            if sun is not None:
                if shadow_scene is not None:
                    sun.encode_shadow_map(encoder, self.raster, shadow_scene, camera)
                else:
                    sun.no_shadows()
                encoder = split("sun shadow", encoder)
                sun.encode_froxels(encoder, camera)
                encoder = split("sun froxels", encoder)
            shading.encode(encoder, display=display)
            return split("shading+display" if display else "shading", encoder)
        if display:
            raise AquaspecError("the seeds' shading adds the sun after it: no fused display")
        shading.encode(encoder)
        encoder = split("shading", encoder)
        if shadow_scene is not None:
            sun.encode_shadow_map(encoder, self.raster, shadow_scene, camera)
        else:
            sun.no_shadows()
        encoder = split("sun shadow", encoder)
        sun.encode(encoder, camera, self.deferred.gbuffer.textures, shading.rgb_buffer)
        return split("sun", encoder)

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
        if self._shadow_rays is None:
            self._shadow_rays = ShadowRays(self.deferred.device, self.deferred.n_bands)
        medium = setup.medium(gbuffer.materials)
        dl = scene_shadow(gbuffer, **medium, lightfield=setup.lightfield_tables(),
                          progress=progress, rays=self._shadow_rays)
        drgb = radiance_to_rgb(dl.reshape(-1, dl.shape[-1]), medium["response_weights"])
        return (rgb - drgb.reshape(rgb.shape)).astype(rgb.dtype)

    # ------------------------------------------------------------ live frames
    def set_camera_model(self, model, *, metered_green=None) -> None:
        """Show :meth:`encode_frame`'s frames through a camera model (a preset
        name or :class:`aquaspec.optics.presets.CameraModel`; None: the pinhole):
        :mod:`aquaspec.rendering.live_camera`. Its exposure is metered by
        :meth:`auto_display`, or given as ``metered_green`` (another
        renderer's ``live_camera.metered_green``)."""
        if model is None:
            self.live_camera = None
            return
        if self.live_camera is None or self.live_camera.spec != model:
            self.live_camera = LiveCamera(model, self.width, self.height, self.deferred.device)
        if metered_green is not None:
            self.live_camera.metered_green = metered_green

    def set_marine_snow(self, snow, time_s: float | None = None) -> None:
        """Draw marine snow over :meth:`encode_frame`'s frames (a
        :class:`aquaspec.scene.particles.MarineSnow` or a ``--marine-snow`` spec;
        None: none), its particles drifted to ``time_s`` seconds
        (:class:`aquaspec.rendering.marine_snow.LiveSnow`)."""
        if snow is None:
            self.snow = None
            return
        spec = parse_marine_snow(snow)
        if self.snow is None or self.snow.snow != spec:
            # The last one is kept while the snow is off: switching back costs no compile.
            kept = self._snow_kept
            self.snow = kept if kept is not None and kept.snow == spec else LiveSnow(
                spec, self.deferred.device, self.width, self.height)
            self._snow_kept = self.snow
            if self._display is not None and self._display.settings is not None:
                self.snow.gpu.set_display(**self._display.settings)
        if time_s is not None:
            self.snow.time_s = float(time_s)

    def set_display(self, settings: dict) -> None:
        """Display settings (``exposure_ev``, ``white_balance_gains``, ``matrix``,
        ``tonemap``, as :func:`aquaspec.colour.display.display_settings` gives
        them) for :meth:`encode_frame`; call after :meth:`set_spectral`."""
        keys = ("exposure_ev", "white_balance_gains", "matrix", "tonemap")
        kw = {k: settings[k] for k in keys if k in settings}
        self._shading_pass().set_display(**kw)
        if self._display is None:
            self._display = DisplayPass(self.width, self.height, device=self.deferred.device)
        self._display.set_settings(**kw)
        if self.snow is not None:
            self.snow.gpu.set_display(**kw)
        if self.live_camera is not None:
            self.live_camera.display.set_settings(**kw)

    def auto_display(self, scene, camera: Camera, setup: SpectralSetup) -> dict:
        """Render one linear frame and take the display settings from it
        (automatic exposure and grey-world gains), as a live view starts."""
        live = self.live_camera
        rgb = (self._above_pass(scene, setup).render(setup, camera, self.wave_time_s)
               if above_water(camera) else self.render_scene(
                   scene, camera if live is None else live.shading_camera(camera, setup), setup))
        if live is not None:
            live.meter(rgb)
        settings = display_settings(rgb)
        settings.setdefault("tonemap", "filmic")
        self.set_display(settings)
        return settings

    def encode_frame(self, encoder, scene, camera: Camera, setup: SpectralSetup, *,
                     split=None):
        """Record one displayed frame into ``encoder``: rasterise ``scene`` for
        ``camera``, shade (the light field's water table is rebuilt on the GPU
        when the camera's depth changed), add the sun, apply the display
        transform of :meth:`set_display`. Nothing is read back
        (:meth:`read_display` reads the 8-bit image); this is the frame of a
        live view and of ``aquaspec bench --motion``.

        ``split(name, encoder)``, if given, is called after each pass
        (``"geometry"``, then ``"shading+display"`` without the sun, or
        ``"waves"`` when they move (:meth:`set_wave_time`), then with the light
        field ``"sun shadow"``, ``"sun froxels"``, ``"shading+display"`` (the sun
        added and the display fused in it), with the seeds' model ``"shading"``,
        ``"sun shadow"``, ``"sun"``, ``"display"``; with :meth:`set_camera_model`
        the shading unfused, then ``"camera+display"``; with :meth:`set_marine_snow`
        and the light field ``"particles"`` (the splat) before the shading, which
        composes them in its fused display; with a camera model the shading
        unfused, then ``"particles"`` and ``"camera+display"``; where a still render adds the
        surface seen from below (:mod:`aquaspec.rendering.live_surface`: the
        waves' window and the sun's disc; at the waterline the sky) the shading
        unfused, then ``"surface"``, then ``"display"`` or the passes above; with
        a camera above the sea ``"above"``, ``"display"``: :mod:`aquaspec.rendering.live_above`)
        and returns the encoder for the next one: a benchmark submits and times
        each pass with it. Returns the encoder last returned by ``split``
        (``encoder`` itself without it).

        ``scene`` may instead be a :class:`~aquaspec.scene.gbuffer.GBuffer`
        made elsewhere (an RGB-D photograph): it is uploaded once and shaded
        as seen from ``camera``, which must be its camera moved (its
        direction, size and intrinsics kept: e.g. the same view at another
        depth); there is no geometry pass, and nothing shadows the sun.
        """
        split = split or (lambda name, enc: enc)
        self._check_camera(camera)
        if above_water(camera):
            above = self._above_pass(scene, setup, display=True)
            above.encode(encoder, setup, camera, self.wave_time_s)
            return self._encode_display(split("above", encoder), above.rgb_buffer, split)
        live, sensor_camera = self.live_camera, camera
        if live is not None:
            camera = live.shading_camera(camera, setup)
        self.set_spectral(setup, scene.materials)
        sun = self._sun_pass(setup, scene.materials)
        shading = self._shading_pass()
        if shading.display_settings is None:
            raise AquaspecError("no display settings: call set_display() or auto_display() "
                                "before encode_frame()")
        if isinstance(scene, GBuffer):
            self._show_gbuffer(scene, camera)
            scene = None
        else:
            self.raster.render_to(self.deferred.gbuffer, scene, camera, encoder=encoder)
            self._shown_gbuffer = None
            encoder = split("geometry", encoder)
        if sun is not None and self._advance_waves(encoder, setup):
            encoder = split("waves", encoder)
        surface = self._surface_pass(setup, camera)
        fused_snow = (self.snow is not None and live is None and surface is None
                      and self._use_lightfield)
        if self.lightfield is not None:
            self.lightfield.set_snow(self.snow.gpu if fused_snow else None)
        if fused_snow:
            # Splatted now, composed in the light field's fused display (one pass less).
            self.snow.encode_splat(encoder, self.deferred.gbuffer.textures["surface"], camera,
                                   setup)
            encoder = split("particles", encoder)
        if live is not None or (self.snow is not None and not fused_snow) or surface is not None:
            encoder = self.encode_shading(encoder, sun, camera, scene, split=split)
            if surface is not None:
                surface.encode(encoder, setup, camera, self.deferred.gbuffer.textures["surface"],
                               shading.rgb_buffer, self.wave_time_s)
                encoder = split("surface", encoder)
            if live is None and self.snow is None:
                return self._encode_display(encoder, shading.rgb_buffer, split)
            if self.snow is not None:
                # Without a camera model the composition rides on the display's pass.
                self.snow.encode(encoder, shading.rgb_buffer,
                                 self.deferred.gbuffer.textures["surface"], camera, setup,
                                 display=live is None)
                if live is None:
                    self._last_display = self.snow.gpu
                    return split("particles+display", encoder)
                encoder = split("particles", encoder)
            live.encode(encoder, shading.rgb_buffer, self.deferred.gbuffer, sensor_camera, setup)
            self._last_display = live.display
            return split("camera+display", encoder)
        if sun is None or self._use_lightfield:
            # The sun's light in the shading pass's band loop, the display fused.
            encoder = self.encode_shading(encoder, sun, camera, scene, split=split,
                                          display=True)
            self._last_display = shading
            return encoder
        encoder = self.encode_shading(encoder, sun, camera, scene, split=split)
        return self._encode_display(encoder, shading.rgb_buffer, split)

    def _encode_display(self, encoder, rgb_buffer, split):
        """Record the display pass of linear ``rgb_buffer``; ``split``'s encoder."""
        self._display.use_input(rgb_buffer)
        self._display.encode(encoder)
        self._last_display = self._display
        return split("display", encoder)

    def _above_pass(self, scene, setup: SpectralSetup, display=False) -> LiveAbove:
        """The view from above (made when first needed), checked
        (:func:`~aquaspec.rendering.live_above.check_live_above`, ``display``: its settings)."""
        check_live_above(setup, scene, camera_model=self.live_camera, marine_snow=self.snow)
        if display and self._display is None:
            raise AquaspecError("no display settings: call set_display() or auto_display() "
                                "before encode_frame()")
        if self._above is None:
            self._above = LiveAbove(self.deferred.device, self.width, self.height)
        return self._above

    def _surface_pass(self, setup: SpectralSetup, camera: Camera):
        """The frame's :class:`LiveSurface` (made when first needed), or None where
        none is drawn (:func:`aquaspec.rendering.live_surface.surface_drawn`)."""
        if not (self.surface_from_below and surface_drawn(setup, camera)):
            return None
        if self._surface is None:
            self._surface = LiveSurface(self.deferred.device, self.width, self.height)
        return self._surface

    def _show_gbuffer(self, gbuffer: GBuffer, camera: Camera) -> None:
        """Have the shading read ``gbuffer`` seen from ``camera`` (uploaded only
        when it is another G-buffer; the camera set when it moved)."""
        if self._shown_gbuffer is not gbuffer:
            self.deferred.gbuffer.upload(_seen_from(gbuffer, camera))
            self._shown_gbuffer = gbuffer
        elif not np.array_equal(self.deferred.gbuffer.camera.position, camera.position):
            _check_moved_only(gbuffer.camera, camera)
            self.deferred.gbuffer.set_camera(camera)

    def draw_frame(self, scene, camera: Camera, setup: SpectralSetup, *, split=None) -> None:
        """Record one displayed frame (:meth:`encode_frame`, ``split`` as
        there), submit it and wait until the GPU has finished it."""
        dev = self.deferred.device
        encoder = self.encode_frame(dev.create_command_encoder(), scene, camera, setup,
                                    split=split)
        dev.queue.submit([encoder.finish()])
        self.wait()

    def wait(self) -> None:
        """Block until the GPU has finished the work submitted so far."""
        read_buffer(self.deferred.device, self._shading_pass().output.status_buffer,
                    np.uint32, (4,))

    def display_buffer(self):
        """The GPU buffer holding the last :meth:`encode_frame`'s 8-bit image
        (packed RGBA8, row by row: what :meth:`read_display` reads), for a
        pass that shows it without a read-back (a live view's present pass)."""
        if self._last_display is None:
            raise AquaspecError("no frame yet: encode one with encode_frame() first")
        if isinstance(self._last_display, DisplayPass):
            return self._last_display.output_buffer
        return self._last_display.output.display_buffer

    def read_display(self) -> np.ndarray:
        """The 8-bit display image (H, W, 3) of the last :meth:`encode_frame`."""
        if self._last_display is None:
            raise AquaspecError("no frame yet: submit one from encode_frame() first")
        if isinstance(self._last_display, DisplayPass):
            return self._last_display.read()
        return self._last_display.read_display()

    def read_radiance(self) -> np.ndarray:
        """The last frame's per-band radiance (H, W, n), with ``debug_radiance``."""
        return self.deferred.read_radiance()

    def _check_camera(self, camera):
        if (camera.width, camera.height) != (self.width, self.height):
            raise AquaspecError(f"camera is {camera.width}x{camera.height}; this renderer "
                                f"was made for {self.width}x{self.height}")
