"""What both shading passes do alike on the host: their dispatch, outputs and display.

:class:`aquaspec.gpu.passes.deferred.DeferredPass` and
:class:`aquaspec.gpu.passes.lightfield.LightfieldPass` shade a G-buffer with one
compute invocation per :data:`PIXELS_PER_INVOCATION` adjacent pixels of a row
(``gpu/wgsl/shading4.wgsl``) in workgroups of :data:`WORKGROUP`, and write
through a :class:`aquaspec.gpu.shading_output.ShadingOutput` (linear RGB, or
with the display transform fused in, RGBA8). :class:`ShadingPass` holds the
methods that follow from that; a pass sets ``device``, ``width``, ``height``
and ``output``, and defines :meth:`ShadingPass.encode` and
:attr:`ShadingPass.n_materials`.
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError

#: Compute workgroup size (x, y) of the shading passes' WGSL, in invocations.
WORKGROUP = (8, 8)
#: Adjacent pixels of a row shaded by one invocation (vec4 lanes).
PIXELS_PER_INVOCATION = 4


class ShadingPass:
    """Base of the shading passes: dispatch size, ``run``, display settings and the images."""

    #: What the pass is called in error messages.
    label = "shading"

    @property
    def n_materials(self) -> int:
        """Rows of the material table of the last ``set_medium`` (the passes define it)."""
        raise NotImplementedError

    def encode(self, encoder, timestamp_writes=None, *, display: bool = False) -> None:
        """Record the shading into ``encoder`` (the passes define it)."""
        raise NotImplementedError

    @property
    def rgb_buffer(self):
        """Linear camera RGB of the last frame, ``width * height`` vec4<f32> (read by
        the display and sun passes)."""
        return self.output.rgb_buffer

    def set_display(self, **settings) -> None:
        """Settings of the fused display transform (``encode(display=True)``):
        :meth:`aquaspec.gpu.shading_output.ShadingOutput.set_display`."""
        self.output.set_display(**settings)

    @property
    def display_settings(self) -> dict | None:
        """The settings of :meth:`set_display` (None before)."""
        return self.output.display_settings

    def workgroups(self) -> tuple[int, int, int]:
        """Dispatch size covering the image."""
        per_x = WORKGROUP[0] * PIXELS_PER_INVOCATION
        return (-(-self.width // per_x), -(-self.height // WORKGROUP[1]), 1)

    def run(self, display: bool = False) -> None:
        """Shade the current G-buffer (submits; does not wait); ``display`` as in :meth:`encode`."""
        encoder = self.device.create_command_encoder()
        self.encode(encoder, display=display)
        self.device.queue.submit([encoder.finish()])

    def read_display(self) -> np.ndarray:
        """The display image of the last ``run(display=True)``, (H, W, 3) uint8
        (:meth:`aquaspec.gpu.shading_output.ShadingOutput.read_display`)."""
        return self.output.read_display(self.n_materials)

    def read_rgb(self) -> np.ndarray:
        """Linear camera RGB of the last run, (H, W, 3) float32.

        Raises :class:`AquaspecError` if a pixel referenced an undefined
        material or a value is not finite, or if the last run wrote the
        display image instead.
        """
        rgb = self.output.read_rgb(self.n_materials)
        if not np.all(np.isfinite(rgb)):
            i, j = np.argwhere(~np.all(np.isfinite(rgb), axis=-1))[0]
            raise AquaspecError(f"{self.label} produced a non-finite value at pixel "
                                f"({i}, {j}); check the water coefficients and G-buffer")
        return rgb
