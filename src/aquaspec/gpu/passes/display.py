"""The display pass: linear camera RGB -> sRGB RGBA8 on the GPU.

The GPU twin of :func:`aquaspec.colour.display.to_display` for 8-bit output (WGSL:
``display.wgsl`` beside this module, the transform in ``gpu/wgsl/tonemap.wgsl``,
its settings in :mod:`aquaspec.gpu.display_transform`);
``tests/gpu/passes/test_display_pass.py`` holds the two together. The
image-dependent settings (automatic exposure, grey-world gains) are resolved
on the host by :func:`aquaspec.colour.display.display_settings`, or given
directly.

Input: a storage buffer of ``width * height`` ``vec4<f32>`` (RGB, w unused),
pixel ``p = row * width + column``, the layout of
:attr:`aquaspec.gpu.passes.deferred.DeferredPass.rgb_buffer`, so the pass can read
the shading pass's output without a copy (:meth:`DisplayPass.use_input`).
Output: ``width * height`` ``u32`` packed ``r | g << 8 | b << 16 | a << 24``,
bound as a storage buffer (a texture copy for presenting can be added).
"""

from __future__ import annotations

import numpy as np

import wgpu

from aquaspec.colour import display
from aquaspec.scene.camera import check_size
from aquaspec.errors import AquaspecError
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import create_storage_buffer, create_uniform_buffer, read_buffer, upload_buffer
from aquaspec.gpu.device import get_device
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch, submit_pass
from aquaspec.gpu.display_transform import DISPLAY_LAYOUT, TONEMAP_IDS, display_uniform
from aquaspec.gpu.shaders import load_wgsl

WORKGROUP = (8, 8)
B_PARAMS, B_RGB_IN, B_RGBA_OUT, B_STATUS = 0, 1, 2, 3


def shader_source(tonemap: str = "filmic") -> str:
    """WGSL of ``display.wgsl`` with the uniform struct and tone map filled in."""
    return load_wgsl("display.wgsl", display_struct=DISPLAY_LAYOUT.wgsl(),
                     display_struct_name=DISPLAY_LAYOUT.name, tonemap_id=TONEMAP_IDS[tonemap])


class DisplayPass:
    """Display transform of a ``width`` x ``height`` linear RGB buffer.

    Per frame: :meth:`set_settings` (or :meth:`set_from_image` to resolve
    them from host pixels as :func:`~aquaspec.colour.display.to_display` does), an
    input via :meth:`upload` or :meth:`use_input`, then :meth:`run` and
    :meth:`read`.

    Parameters
    ----------
    width, height : int
    device : wgpu.GPUDevice, optional
        Default: :func:`aquaspec.gpu.device.get_device`.
    """

    def __init__(self, width: int, height: int, *, device=None):
        self.width, self.height = check_size(width, height)
        if device is None:
            _, device = get_device()
        self.device = device
        npix = self.width * self.height
        self._uniform = create_uniform_buffer(device, DISPLAY_LAYOUT, label="display params")
        self._input = create_storage_buffer(device, npix * 16, label="display input")
        self.output_buffer = create_storage_buffer(device, npix * 4, label="display rgba8")
        self._status = create_storage_buffer(device, 16, label="display status")
        self._layout = bind_group_layout(device, {
            B_PARAMS: "uniform", B_RGB_IN: "read", B_RGBA_OUT: "write", B_STATUS: "write"})
        # One pipeline per tone map (a compile-time constant of the shader),
        # made when first used.
        self._pipelines = {}
        self._bind_group = None
        self.settings = None

    # ---------------------------------------------------------------- inputs
    def set_settings(self, *, exposure_ev, white_balance_gains=(1.0, 1.0, 1.0), matrix=None,
                     tonemap="filmic") -> None:
        """Set the exposure (EV), gains, colour matrix and tone map directly
        (checked by :func:`aquaspec.gpu.display_transform.display_uniform`)."""
        data, self.settings = display_uniform(
            self.width, self.height, exposure_ev=exposure_ev,
            white_balance_gains=white_balance_gains, matrix=matrix, tonemap=tonemap)
        upload_buffer(self.device, self._uniform, data)

    def set_from_image(self, rgb, *, tonemap="filmic", **kwargs) -> dict:
        """Resolve settings from host pixels with :func:`~aquaspec.colour.display.display_settings`.

        ``kwargs`` are those of ``display_settings`` (``exposure``,
        ``white_balance``, ``reference_rgb``, ``matrix``, ``key``,
        ``percentile``). Returns the settings dict (for sidecars).
        """
        s = display.display_settings(rgb, **kwargs)
        self.set_settings(exposure_ev=s["exposure_ev"], white_balance_gains=s["white_balance_gains"],
                          matrix=s["matrix"], tonemap=tonemap)
        s["tonemap"] = tonemap
        return s

    def upload(self, rgb) -> None:
        """Upload host linear RGB (H, W, 3) into the pass's own input buffer."""
        arr = np.asarray(rgb)
        if arr.shape != (self.height, self.width, 3):
            raise AquaspecError(f"image has shape {arr.shape}; this pass was created for "
                                f"({self.height}, {self.width}, 3)")
        rgba = np.zeros((self.height, self.width, 4), dtype=np.float32)
        rgba[..., :3] = arr
        upload_buffer(self.device, self._input, rgba)

    def use_input(self, buffer) -> None:
        """Read a GPU buffer of ``width * height`` ``vec4<f32>`` (e.g. ``DeferredPass.rgb_buffer``)."""
        need = self.width * self.height * 16
        if buffer.size < need:
            raise AquaspecError(f"input buffer has {buffer.size} bytes; {self.width}x"
                                f"{self.height} vec4<f32> needs {need}")
        if not buffer.usage & wgpu.BufferUsage.STORAGE:
            raise AquaspecError("input buffer lacks STORAGE usage")
        self._input = buffer
        self._bind_group = None

    # ------------------------------------------------------------- dispatch
    def pipeline(self, tonemap):
        """The compute pipeline of ``tonemap`` (a compile-time constant; made when first used)."""
        if tonemap not in self._pipelines:
            self._pipelines[tonemap] = compute_pipeline(self.device, self._layout,
                                                        shader_source(tonemap),
                                                        f"display.wgsl {tonemap}")
        return self._pipelines[tonemap]

    def bind_group(self):
        """The bind group (rebuilt when the input buffer changes)."""
        if self._bind_group is None:
            resources = {B_PARAMS: self._uniform, B_RGB_IN: self._input,
                         B_RGBA_OUT: self.output_buffer, B_STATUS: self._status}
            self._bind_group = self.device.create_bind_group(
                layout=self._layout, entries=bind_group_entries(resources))
        return self._bind_group

    def workgroups(self) -> tuple[int, int, int]:
        """Dispatch size covering the image."""
        return (-(-self.width // WORKGROUP[0]), -(-self.height // WORKGROUP[1]), 1)

    def encode(self, encoder, timestamp_writes=None) -> None:
        """Record the display transform into ``encoder``."""
        if self.settings is None:
            raise AquaspecError("no display settings: call set_settings() or "
                                "set_from_image() before running")
        # status[0] counts bad pixels, status[1] is the atomicMin of their
        # index, so it starts at the maximum. (A queue write runs before the
        # next submission, so it cannot be mixed with encoder.clear_buffer.)
        self.device.queue.write_buffer(self._status, 0,
                                       np.array([0, 0xFFFFFFFF, 0, 0], np.uint32))
        record_dispatch(encoder, self.pipeline(self.settings["tonemap"]),
                        self.bind_group(), self.workgroups(), timestamp_writes)

    def run(self) -> None:
        """Run the transform (submits; does not wait)."""
        submit_pass(self.device, self)

    # ------------------------------------------------------------- outputs
    def read(self) -> np.ndarray:
        """The last result as (H, W, 3) uint8.

        Raises :class:`AquaspecError` (with the count and the first pixel) if
        any input value was not finite or overflowed after exposure.
        """
        status = read_buffer(self.device, self._status, np.uint32, (4,))
        if status[0]:
            row, col = divmod(int(status[1]), self.width)
            raise AquaspecError(f"display input has {int(status[0])} pixel(s) with non-finite "
                                f"values (or overflow after exposure); the first is at "
                                f"(row {row}, column {col}); accepted: finite values only")
        rgba = read_buffer(self.device, self.output_buffer, np.uint8,
                           (self.height, self.width, 4))
        return np.ascontiguousarray(rgba[..., :3])
