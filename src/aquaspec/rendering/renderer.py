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

import numpy as np

from aquaspec.colour.sensors import radiance_to_rgb
from aquaspec.errors import AquaspecError
from aquaspec.gpu.passes.deferred import DeferredPass
from aquaspec.gpu.passes.lightfield import LightfieldPass
from aquaspec.gpu.passes.raster import RasterPass
from aquaspec.gpu.passes.shadow_rays import ShadowRays
from aquaspec.gpu.passes.sun import SunPass
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import Camera, check_size
from aquaspec.scene.gbuffer import GBuffer
from aquaspec.scene.shadowmap import DEFAULT_MAP_SIZE
from aquaspec.shading.shade import scene_shadow


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

    def set_spectral(self, setup: SpectralSetup, materials) -> None:
        """Upload ``setup``'s medium for a scene of ``materials`` to the shading
        pass (the light field's or the seeds'), unless it is there already."""
        key = (id(setup), tuple(id(m) for m in materials))
        if key != self._medium_key:
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
        self.raster.render_to(self.deferred.gbuffer, scene, camera, encoder=enc)
        self._shading_pass().encode(enc)
        if sun is not None:
            sun.encode_shadow_map(enc, self.raster, scene, camera)
            sun.encode(enc, camera, self.deferred.gbuffer.textures,
                       self._shading_pass().rgb_buffer)
        self.deferred.device.queue.submit([enc.finish()])
        rgb = self._shading_pass().read_rgb()
        if setup.ambient_shadow:
            gbuffer = self.raster.read_gbuffer(scene, camera, self.deferred.gbuffer.textures)
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
        self.deferred.gbuffer.upload(gbuffer)
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
            sun.encode(enc, gbuffer.camera, self.deferred.gbuffer.textures,
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
        if self._shadow_rays is None:
            self._shadow_rays = ShadowRays(self.deferred.device, self.deferred.n_bands)
        medium = setup.medium(gbuffer.materials)
        dl = scene_shadow(gbuffer, **medium, lightfield=setup.lightfield_tables(),
                          progress=progress, rays=self._shadow_rays)
        drgb = radiance_to_rgb(dl.reshape(-1, dl.shape[-1]), medium["response_weights"])
        return (rgb - drgb.reshape(rgb.shape)).astype(rgb.dtype)

    def read_radiance(self) -> np.ndarray:
        """The last frame's per-band radiance (H, W, n), with ``debug_radiance``."""
        return self.deferred.read_radiance()

    def _check_camera(self, camera):
        if (camera.width, camera.height) != (self.width, self.height):
            raise AquaspecError(f"camera is {camera.width}x{camera.height}; this renderer "
                                f"was made for {self.width}x{self.height}")
