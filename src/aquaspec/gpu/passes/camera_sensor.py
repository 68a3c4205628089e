"""The camera sensor pass: vignetting and EMVA 1288 noise on the GPU.

The GPU twin of the sensor step of :mod:`aquaspec.rendering.camera_model`
(:meth:`aquaspec.optics.lens.ThinLens.vignetting_factor` and
:meth:`aquaspec.optics.sensor.Emva1288Sensor.capture`; WGSL:
``camera_sensor.wgsl`` beside this module); cheap per-pixel work, so a
live view can show a noisy camera. Its random numbers come from a hash of
(seed, frame, pixel, channel), not NumPy's generator: the two agree in
distribution (``tests/optics/test_camera_sensor_pass.py``), not pixel by
pixel; with ``noise=False`` they agree to the rounding.

Input: a storage buffer of ``width * height`` ``vec4<f32>`` camera RGB
(pixel ``p = row * width + column``; e.g. a shading pass's output, bound
without a copy by :meth:`CameraSensorPass.use_input`). Outputs: the noisy
frame as camera RGB (``vec4<f32>``) and the digital numbers
(``vec4<u32>``, black level included).
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import create_storage_buffer, create_uniform_buffer, read_buffer, upload_buffer
from aquaspec.gpu.device import get_device
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch, submit_pass
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.shaders import load_wgsl
from aquaspec.scene.camera import check_size

WORKGROUP = (8, 8)
B_PARAMS, B_RGB_IN, B_LINEAR_OUT, B_RAW_OUT = 0, 1, 2, 3

SENSOR_LAYOUT = UniformLayout("SensorParams", [
    ("electrons_per_unit", "vec4<f32>"), ("transmission", "vec4<f32>"),
    ("width", "u32"), ("height", "u32"), ("seed", "u32"), ("frame", "u32"),
    ("fx", "f32"), ("fy", "f32"), ("cx", "f32"), ("cy", "f32"),
    ("dark_e", "f32"), ("read_noise_e", "f32"), ("full_well_e", "f32"), ("gain", "f32"),
    ("black_dn", "f32"), ("max_dn", "f32"), ("vignetting", "u32"), ("noise", "u32"),
])


class CameraSensorPass:
    """Vignetting and sensor noise of a ``width`` x ``height`` camera RGB buffer.

    Per frame: :meth:`set_exposure`, an input (:meth:`upload` or
    :meth:`use_input`), :meth:`run`, then :meth:`read_linear` / :meth:`read_raw`.
    """

    def __init__(self, width: int, height: int, *, device=None):
        self.width, self.height = check_size(width, height)
        if device is None:
            _, device = get_device()
        self.device = device
        npix = self.width * self.height
        self._uniform = create_uniform_buffer(device, SENSOR_LAYOUT, label="sensor params")
        self._input = create_storage_buffer(device, npix * 16, label="sensor input")
        self.linear_buffer = create_storage_buffer(device, npix * 16, label="sensor linear")
        self.raw_buffer = create_storage_buffer(device, npix * 16, label="sensor raw")
        self._layout = bind_group_layout(device, {B_PARAMS: "uniform", B_RGB_IN: "read",
                                                  B_LINEAR_OUT: "write", B_RAW_OUT: "write"})
        self._pipeline = compute_pipeline(
            device, self._layout, load_wgsl("camera_sensor.wgsl",
                                            sensor_struct=SENSOR_LAYOUT.wgsl(),
                                            sensor_struct_name=SENSOR_LAYOUT.name),
            "camera_sensor.wgsl")
        self._bind_group = None
        self.settings = None

    def set_exposure(self, sensor, *, electrons_per_unit, exposure_s: float, iso: float,
                     intrinsics=None, seed: int = 0, frame: int = 0, noise: bool = True,
                     transmission=(1.0, 1.0, 1.0)) -> None:
        """The frame's settings.

        Parameters
        ----------
        sensor : aquaspec.optics.sensor.Emva1288Sensor
        electrons_per_unit : 3 floats
            Mean photoelectrons per unit camera RGB over the exposure (e-),
            :func:`aquaspec.optics.exposure.electron_rate` times the time.
        exposure_s, iso : float
        intrinsics : (fx, fy, cx, cy), optional
            With them, cos^4 vignetting of the chief rays; None: none.
        seed, frame : int
            The noise's seed and frame number (a new frame, new noise).
        noise : bool
            False: the mean signal, rounded (for tests).
        transmission : 3 floats
            Scales the input camera RGB per channel before the sensor (a dome
            port's :meth:`aquaspec.optics.dome_port.DomePort.radiance_factor`).
        """
        e = np.asarray(electrons_per_unit, dtype=float).reshape(3)
        if not np.all(np.isfinite(e)) or np.any(e <= 0):
            raise AquaspecError(f"electrons per unit RGB {e.tolist()}; accepted: positive "
                                "finite numbers")
        k = sensor.gain(iso)
        fx, fy, cx, cy = intrinsics if intrinsics is not None else (1.0, 1.0, 0.0, 0.0)
        data = SENSOR_LAYOUT.pack(
            electrons_per_unit=[*e, 0.0], transmission=[*np.asarray(transmission, float), 1.0],
            width=self.width, height=self.height,
            seed=int(seed) & 0xFFFFFFFF, frame=int(frame) & 0xFFFFFFFF,
            fx=fx, fy=fy, cx=cx, cy=cy, dark_e=sensor.dark_current_e_per_s * exposure_s,
            read_noise_e=sensor.dark_noise_e, full_well_e=sensor.full_well_e, gain=k,
            black_dn=sensor.black_level_dn, max_dn=float(sensor.max_dn),
            vignetting=int(intrinsics is not None), noise=int(bool(noise)))
        upload_buffer(self.device, self._uniform, data)
        self.settings = {"exposure_s": exposure_s, "iso": iso, "gain_dn_per_e": k}

    def upload(self, rgb) -> None:
        """Upload host camera RGB (H, W, 3) into the pass's own input buffer."""
        arr = np.asarray(rgb)
        if arr.shape != (self.height, self.width, 3):
            raise AquaspecError(f"image has shape {arr.shape}; this pass was created for "
                                f"({self.height}, {self.width}, 3)")
        rgba = np.zeros((self.height, self.width, 4), dtype=np.float32)
        rgba[..., :3] = arr
        upload_buffer(self.device, self._input, rgba)
        self._bind_group = None

    def use_input(self, buffer) -> None:
        """Read a GPU buffer of ``width * height`` ``vec4<f32>``."""
        need = self.width * self.height * 16
        if buffer.size < need:
            raise AquaspecError(f"input buffer has {buffer.size} bytes; {self.width}x"
                                f"{self.height} vec4<f32> needs {need}")
        self._input = buffer
        self._bind_group = None

    def encode(self, encoder, timestamp_writes=None) -> None:
        """Record the pass into ``encoder``."""
        if self.settings is None:
            raise AquaspecError("no exposure: call set_exposure() before running")
        if self._bind_group is None:
            self._bind_group = self.device.create_bind_group(
                layout=self._layout, entries=bind_group_entries({
                    B_PARAMS: self._uniform, B_RGB_IN: self._input,
                    B_LINEAR_OUT: self.linear_buffer, B_RAW_OUT: self.raw_buffer}))
        groups = (-(-self.width // WORKGROUP[0]), -(-self.height // WORKGROUP[1]), 1)
        record_dispatch(encoder, self._pipeline, self._bind_group, groups, timestamp_writes)

    def run(self) -> None:
        """Run the pass (submits; does not wait)."""
        submit_pass(self.device, self)

    def read_linear(self) -> np.ndarray:
        """The noisy frame as camera RGB, (H, W, 3) float32."""
        out = read_buffer(self.device, self.linear_buffer, np.float32, (self.height, self.width, 4))
        return np.ascontiguousarray(out[..., :3])

    def read_raw(self) -> np.ndarray:
        """The digital numbers, (H, W, 3) uint16."""
        out = read_buffer(self.device, self.raw_buffer, np.uint32, (self.height, self.width, 4))
        return out[..., :3].astype(np.uint16)
