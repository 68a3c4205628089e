"""A camera model on live frames: the port, vignetting and sensor noise on the GPU.

:meth:`aquaspec.rendering.renderer.Renderer.set_camera_model` puts a
:class:`LiveCamera` between a frame's shading and its display transform:

- behind a flat port the frame is rasterised and shaded for the pinhole in
  water (:meth:`LiveCamera.shading_camera`) and resampled through the port
  (:mod:`aquaspec.gpu.passes.flat_port`, the camera-RGB form of
  :func:`aquaspec.optics.remap.port_image`, reading the frame's G-buffer);
- then vignetting and EMVA 1288 noise (:mod:`aquaspec.gpu.passes.camera_sensor`),
  a new noise every frame;
- then the display transform (:class:`aquaspec.gpu.passes.display.DisplayPass`).

The exposure time and ISO are metered as
:func:`aquaspec.rendering.api.render` meters its image, on the mean green
camera RGB of a linear frame (:meth:`LiveCamera.meter`, as the view
starts; kept as :attr:`LiveCamera.metered_green`, which a view hands on to
the renderers of other sizes). Depth of field is not applied to live frames (its NumPy
blur is seconds per frame); the frames are otherwise those of ``render()``
with the same camera model, up to the noise's random numbers.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.gpu.passes.camera_sensor import CameraSensorPass
from aquaspec.gpu.passes.display import DisplayPass
from aquaspec.gpu.passes.flat_port import FlatPortPass
from aquaspec.optics.dome_port import DomePort
from aquaspec.optics.flat_port import FlatPort
from aquaspec.optics.presets import get_camera_model
from aquaspec.optics.remap import Intrinsics, water_intrinsics
from aquaspec.rendering.camera_model import (channel_wavelengths, electrons_per_unit,
                                             exposure_settings)
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import Camera


class LiveCamera:
    """The GPU passes of a camera model for frames of ``width`` x ``height``.

    Parameters
    ----------
    model : str or CameraModel
        A preset name (with settings) or a :class:`aquaspec.optics.presets.CameraModel`.
    width, height : int
    device : wgpu.GPUDevice
    metered_green : float, optional
        The metered mean green camera RGB (:meth:`meter`), if known.
    """

    def __init__(self, model, width: int, height: int, device, metered_green=None):
        #: What the camera model was given as (a preset spec or a CameraModel).
        self.spec = model
        self.model = get_camera_model(model)
        self.width, self.height, self.device = width, height, device
        self.sensor = CameraSensorPass(width, height, device=device)
        #: The display transform after the sensor (settings from the renderer's).
        self.display = DisplayPass(width, height, device=device)
        self._port = None           # (FlatPortPass, its sensor Intrinsics), per intrinsics
        self._lam = None
        #: The mean green camera RGB auto exposure meters on (None: not yet).
        self.metered_green = metered_green
        # (setup, photoelectrons per unit RGB per second, the dome's transmission
        # given to the sensor pass, the port's factor at the centre for metering)
        self._per_unit = None
        #: Frames encoded (each its own noise).
        self.frame = 0

    @property
    def flat(self) -> bool:
        return isinstance(self.model.port, FlatPort)

    def shading_camera(self, camera: Camera, setup: SpectralSetup) -> Camera:
        """The camera to rasterise and shade for ``camera`` (the sensor's):
        the pinhole in water behind a flat port, else ``camera`` itself."""
        if not self.flat:
            return camera
        lam = channel_wavelengths(setup)
        sensor = Intrinsics.of(camera)
        if self._port is None or self._port[1] != sensor or not np.array_equal(lam, self._lam):
            water = water_intrinsics(sensor, self.model.port, setup.bands.centers_nm,
                                     self.model.min_distance_m)
            port = FlatPortPass(sensor, water, device=self.device)
            port.set_port(self.model.port, lam)
            self._port, self._lam = (port, sensor), lam
        water = self._port[0].water
        return dataclasses.replace(camera, fx=water.fx, fy=water.fy)

    def meter(self, linear_rgb) -> None:
        """Meter the exposure on a linear frame (camera RGB of the shading camera)."""
        self.metered_green = float(np.clip(np.asarray(linear_rgb)[..., 1], 0, None).mean())

    def exposure(self, setup: SpectralSetup) -> tuple[np.ndarray, float, float]:
        """``(electrons per unit camera RGB over the exposure, exposure_s, iso)``
        for ``setup``'s sensor and bands."""
        if self.metered_green is None:
            raise AquaspecError("no exposure: meter() a linear frame before encoding frames")
        if self._per_unit is None or self._per_unit[0] is not setup:
            lam = channel_wavelengths(setup)
            port = self.model.port
            # The dome's radiance factor goes in at the sensor pass; the flat
            # port's pass applies its own per pixel (metered at the centre).
            dome = port.radiance_factor(lam) if isinstance(port, DomePort) else np.ones(3)
            meter = (port.radiance_factor(0.0, lam) if isinstance(port, FlatPort) else dome)
            self._per_unit = (setup, electrons_per_unit(self.model, lam, setup), dome, meter)
        _, per_unit, _, meter = self._per_unit
        t, iso = exposure_settings(self.model, self.metered_green * per_unit[1] * meter[1])
        return per_unit * t, t, iso

    def encode(self, encoder, rgb_buffer, gbuffer, camera: Camera,
               setup: SpectralSetup) -> None:
        """Record the port (with ``gbuffer``, the frame's
        :class:`aquaspec.gpu.gbuffer.GBufferTextures`), the sensor and the
        display of the shaded frame in ``rgb_buffer``, for the sensor's ``camera``."""
        per_unit, t, iso = self.exposure(setup)
        source = rgb_buffer
        if self.flat:
            port = self._port[0]
            port.use_input(rgb_buffer)
            port.use_gbuffer(gbuffer)
            port.encode(encoder)
            source = port.output_buffer
        vignetting = self.model.lens.vignetting != "none"
        self.sensor.use_input(source)
        self.sensor.set_exposure(
            self.model.sensor, electrons_per_unit=per_unit, exposure_s=t, iso=iso,
            intrinsics=(camera.fx, camera.fy, camera.cx, camera.cy) if vignetting else None,
            seed=self.model.seed, frame=self.frame, transmission=self._per_unit[2])
        self.sensor.encode(encoder)
        self.display.use_input(self.sensor.linear_buffer)
        self.display.encode(encoder)
        self.frame += 1
