"""What a shading pass writes: linear camera RGB, or display RGBA8, and its status.

Both shading passes (:mod:`aquaspec.gpu.passes.deferred`,
:mod:`aquaspec.gpu.passes.lightfield`) write through one
:class:`ShadingOutput`, at the same bindings (:data:`B_RGB`, :data:`B_STATUS`,
:data:`B_DISPLAY`, :data:`B_RGBA`):

==  ==============================  ==============================================
6   storage ``array<vec4<f32>>``    linear camera RGB (w = 1), pixel
                                    ``p = row * width + column``
8   storage ``array<atomic<u32>>``  status: [0] pixels with a material index out
                                    of range; with the display transform [2]
                                    non-finite pixels, [3] the first of them
9   uniform ``DisplayParams``       the fused display transform
                                    (:mod:`aquaspec.gpu.display_transform`)
10  storage ``array<u32>``          display RGBA8 (``display=True``), packed
                                    ``r | g << 8 | b << 16 | a << 24``
==  ==============================  ==============================================

With the display transform fused in (``encode(display=True)``) a pass writes
RGBA8 instead of linear RGB: one pass instead of two, and the linear image
never goes through memory.
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.gpu.buffers import create_storage_buffer, create_uniform_buffer, read_buffer, upload_buffer
from aquaspec.gpu.display_transform import DISPLAY_LAYOUT, display_uniform

B_RGB, B_STATUS, B_DISPLAY, B_RGBA = 6, 8, 9, 10


class ShadingOutput:
    """The output buffers of a ``width`` x ``height`` shading pass and their checks.

    Parameters
    ----------
    device : wgpu.GPUDevice
    width, height : int
    label : str
        Prefix of the buffers' labels (the pass's name).
    """

    def __init__(self, device, width: int, height: int, label: str):
        self.device, self.width, self.height = device, int(width), int(height)
        npix = self.width * self.height
        #: Linear camera RGB, ``width * height`` vec4<f32>.
        self.rgb_buffer = create_storage_buffer(device, npix * 16, label=f"{label} rgb")
        #: The status counters (four u32).
        self.status_buffer = create_storage_buffer(device, 16, label=f"{label} status")
        self.display_uniform = create_uniform_buffer(device, DISPLAY_LAYOUT,
                                                     label=f"{label} display")
        #: Packed RGBA8 output of ``encode(display=True)``, ``width * height`` u32.
        self.display_buffer = create_storage_buffer(device, npix * 4, label=f"{label} rgba8")
        #: The settings of :meth:`set_display` (None before).
        self.display_settings = None
        #: Whether the last frame wrote the display image.
        self.last_display = False

    def resources(self) -> dict:
        """``{binding: buffer}`` of the outputs."""
        return {B_RGB: self.rgb_buffer, B_STATUS: self.status_buffer,
                B_DISPLAY: self.display_uniform, B_RGBA: self.display_buffer}

    @staticmethod
    def layout() -> dict:
        """Binding kinds for :func:`aquaspec.gpu.bindings.bind_group_layout`."""
        return {B_RGB: "write", B_STATUS: "write", B_DISPLAY: "uniform", B_RGBA: "write"}

    def set_display(self, *, exposure_ev, white_balance_gains=(1.0, 1.0, 1.0), matrix=None,
                    tonemap="filmic") -> None:
        """Settings of the fused display transform (``encode(display=True)``).

        The same settings and checks as
        :meth:`aquaspec.gpu.passes.display.DisplayPass.set_settings` (the
        image-dependent ones, automatic exposure and grey-world gains, are
        resolved beforehand, e.g. from an earlier frame, with
        :func:`aquaspec.colour.display.display_settings`).
        """
        data, settings = display_uniform(self.width, self.height, exposure_ev=exposure_ev,
                                         white_balance_gains=white_balance_gains,
                                         matrix=matrix, tonemap=tonemap)
        upload_buffer(self.device, self.display_uniform, data)
        self.display_settings = settings

    def begin_frame(self, encoder, display: bool) -> str | None:
        """Reset the status for a frame; the tone map compiled in (None: linear RGB)."""
        tonemap = None
        if display:
            if self.display_settings is None:
                raise AquaspecError("no display settings: call set_display() before "
                                    "encoding with display=True")
            tonemap = self.display_settings["tonemap"]
            # status[3] is an atomicMin, so it starts at the maximum (a queue
            # write runs before the next submission).
            self.device.queue.write_buffer(self.status_buffer, 0,
                                           np.array([0, 0, 0, 0xFFFFFFFF], np.uint32))
        else:
            encoder.clear_buffer(self.status_buffer, 0, self.status_buffer.size)
        self.last_display = bool(display)
        return tonemap

    def check_materials(self, n_materials: int) -> np.ndarray:
        """The status counters; raises if a pixel used a material index out of range."""
        status = read_buffer(self.device, self.status_buffer, np.uint32, (4,))
        if status[0]:
            raise AquaspecError(f"{int(status[0])} G-buffer pixels use a material index >= "
                                f"{n_materials}, the number of material_bands rows")
        return status

    def read_display(self, n_materials: int) -> np.ndarray:
        """The display image of the last ``run(display=True)``, (H, W, 3) uint8.

        Raises :class:`AquaspecError` if a pixel referenced an undefined
        material, or (with the count and the first pixel) if a value was not
        finite or overflowed after exposure.
        """
        if not self.last_display:
            raise AquaspecError("read_display() needs a run with display=True")
        status = self.check_materials(n_materials)
        if status[2]:
            row, col = divmod(int(status[3]), self.width)
            raise AquaspecError(f"shading produced {int(status[2])} pixel(s) with non-finite "
                                f"values (or overflow after exposure); the first is at "
                                f"(row {row}, column {col}); check the water coefficients "
                                "and G-buffer")
        rgba = read_buffer(self.device, self.display_buffer, np.uint8,
                           (self.height, self.width, 4))
        return np.ascontiguousarray(rgba[..., :3])

    def read_rgb(self, n_materials: int) -> np.ndarray:
        """Linear camera RGB of the last run, (H, W, 3) float32, possibly not finite.

        Raises :class:`AquaspecError` if a pixel referenced an undefined
        material, or if the last run wrote the display image instead.
        """
        if self.last_display:
            raise AquaspecError("the last run wrote the display image (display=True); "
                                "read it with read_display(), or run without display")
        self.check_materials(n_materials)
        rgba = read_buffer(self.device, self.rgb_buffer, np.float32,
                           (self.height, self.width, 4))
        return np.ascontiguousarray(rgba[..., :3])
