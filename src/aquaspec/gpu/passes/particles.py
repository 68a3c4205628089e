"""Marine snow on the GPU: the particles' discs splatted and composed over the shaded image.

The particles' light is computed on the host per particle
(:class:`aquaspec.shading.particles.ParticleLight`, :func:`aquaspec.shading.particles.splats`:
N x bands numbers, a few milliseconds for tens of thousands of particles);
this pass draws their discs. WGSL: ``particles.wgsl`` beside this module.

1. Splat (a compute pass, one invocation per particle): each disc's pixels,
   weighted by the anti-aliased disc and dropped behind the G-buffer's
   surface, added into a buffer (four ``f32`` per pixel held as ``u32``:
   WGSL has no float atomics, so a compare-exchange loop adds them;
   ``gpu/wgsl/snow_splat.wgsl``) copied into the ``rgba32uint`` texture
   :attr:`ParticlePass.accum`, as :func:`aquaspec.shading.particles.splat_image`
   (a texel load cost a fifth of a storage buffer's on lavapipe, for the
   shaders that compose). (An instanced-quad render pass into an
   ``rgba16float`` target did this before; on lavapipe it cost about 3 us
   per particle, triangle set-up, whatever the discs' size: 34 ms for the
   10.9k of ``bench --detail``. Fixed-point sums with ``atomicAdd`` lost
   small and negative camera RGB.) The records are sorted by disc size, so
   that the invocations of a SIMD group loop over about as many pixels.
2. Compose (a compute pass, in place on a ``vec4<f32>`` image buffer, e.g.
   the shading pass's ``rgb_buffer``), as :func:`aquaspec.shading.particles.composite`;
   or, with display settings (:meth:`ParticlePass.set_display`), composed and
   shown in one pass (:mod:`aquaspec.gpu.passes.particles_display`, 8-bit sRGB in
   :attr:`ParticlePass.output`); or by the light field's pass itself
   (:meth:`aquaspec.gpu.passes.lightfield.LightfieldPass.set_snow`, live frames).
"""

from __future__ import annotations

import numpy as np
import wgpu

from aquaspec.errors import AquaspecError
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import (create_storage_buffer, create_texture, create_uniform_buffer,
                                  read_texture, upload_buffer)
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.passes.particles_display import SnowDisplayPass
from aquaspec.gpu.shaders import load_wgsl
from aquaspec.shading.particles import SPLAT_FIELDS

PARAMS = UniformLayout("ParticleParams", [("width", "f32"), ("height", "f32"),
                                          ("count", "f32")])
WORKGROUP = (8, 8)
#: Invocations per workgroup of the splat (one per particle).
SPLAT_WORKGROUP = 64


class ParticlePass:
    """Splat and compose marine snow on images of ``width`` x ``height``."""

    def __init__(self, device, width: int, height: int):
        self.device, self.width, self.height = device, int(width), int(height)
        # The splat's buffer: four f32 per pixel as u32 (camera RGB, coverage),
        # rows of the width rounded up to 16 pixels (256 bytes,
        # as a copy into a texture needs; gpu/wgsl/snow_accum.wgsl).
        self._row = 16 * -(-self.width // 16)
        self._sums = create_storage_buffer(device, self.height * self._row * 16,
                                           label="snow sums")
        #: The accumulation, copied from the splat's buffer: ``rgba32uint``, one texel per pixel.
        self.accum = create_texture(device, self.width, self.height, "rgba32uint",
                                    label="snow accum",
                                    usage=wgpu.TextureUsage.TEXTURE_BINDING
                                    | wgpu.TextureUsage.COPY_DST | wgpu.TextureUsage.COPY_SRC)
        self.params = create_uniform_buffer(device, PARAMS, label="snow params")
        code = load_wgsl("particles.wgsl", params_struct=PARAMS.wgsl(),
                         params_name=PARAMS.name)
        self._splat_layout = bind_group_layout(device, {0: "uint", 1: "uniform", 2: "read",
                                                        3: "write"})
        self._splat = compute_pipeline(device, self._splat_layout, code, "particles.wgsl",
                                       entry_point="cs_splat")
        self._compose_layout = bind_group_layout(device, {1: "uniform", 4: "uint", 5: "write"})
        self._compose = compute_pipeline(device, self._compose_layout, code, "particles.wgsl",
                                         entry_point="cs_compose")
        self._instances = None
        self._count = 0
        self._splat_group = None
        self._splat_key = None
        self._compose_group = None
        self._target = None
        self._display = None        # SnowDisplayPass, made by set_display
        #: The display image's buffer (``display_buffer``: packed RGBA8), after :meth:`set_display`.
        self.output = None
        self.display_settings = None

    def set_splats(self, records) -> None:
        """Upload the frame's particles (:func:`aquaspec.shading.particles.splats`)."""
        rec = np.ascontiguousarray(records, dtype=np.float32)
        if rec.ndim != 2 or rec.shape[1] != len(SPLAT_FIELDS):
            raise AquaspecError(f"splat records of shape {rec.shape}; accepted: (N, "
                                f"{len(SPLAT_FIELDS)}) as aquaspec.shading.particles.splats")
        if not np.all(np.isfinite(rec)):
            raise AquaspecError("splat records hold non-finite values; accepted: finite "
                                "records as aquaspec.shading.particles.splats gives them")
        # Sorted by disc size: a SIMD group's invocations loop over as many pixels.
        rec = rec[np.argsort(rec[:, 2], kind="stable")]
        if len(rec) and (self._instances is None or self._instances.size < rec.nbytes):
            self._instances = create_storage_buffer(self.device, max(rec.nbytes, 4096) * 2,
                                                    label="snow records")
            self._splat_group = None
        if len(rec):
            upload_buffer(self.device, self._instances, rec)
        self._count = len(rec)
        u = np.zeros((), PARAMS.dtype)
        u["width"], u["height"], u["count"] = self.width, self.height, self._count
        upload_buffer(self.device, self.params, u)

    @property
    def sums(self):
        """The splat's buffer (four u32 per pixel, ``gpu/wgsl/snow_splat.wgsl``'s layout)."""
        return self._sums

    def encode_clear(self, encoder) -> None:
        """Record the clearing of :attr:`sums`."""
        encoder.clear_buffer(self._sums, 0, self._sums.size)

    def encode_copy(self, encoder) -> None:
        """Record the copy of :attr:`sums` into :attr:`accum`."""
        encoder.copy_buffer_to_texture(
            {"buffer": self._sums, "offset": 0, "bytes_per_row": self._row * 16,
             "rows_per_image": self.height},
            {"texture": self.accum, "mip_level": 0, "origin": (0, 0, 0)},
            (self.width, self.height, 1))

    def encode_splat(self, encoder, surface_texture) -> None:
        """Record the splat against the G-buffer's ``surface`` texture into
        :attr:`accum` (cleared first, also with no particles)."""
        self.encode_clear(encoder)
        if self._count:
            if self._splat_group is None or self._splat_key is not surface_texture:
                self._splat_group = self.device.create_bind_group(
                    layout=self._splat_layout, entries=bind_group_entries(
                        {0: surface_texture, 1: self.params, 2: self._instances,
                         3: self._sums}))
                self._splat_key = surface_texture
            groups = -(-self._count // SPLAT_WORKGROUP)
            limit = self.device.limits.get("max-compute-workgroups-per-dimension", 65535)
            if groups > limit:
                raise AquaspecError(f"{self._count} particles in one frame; this device "
                                    f"splats at most {limit * SPLAT_WORKGROUP}")
            record_dispatch(encoder, self._splat, self._splat_group, (groups, 1, 1))
        self.encode_copy(encoder)

    def encode_compose(self, encoder, rgb_buffer) -> None:
        """Record the composition in place on ``rgb_buffer`` (``vec4<f32>`` per pixel)."""
        if rgb_buffer.size < self.width * self.height * 16:
            raise AquaspecError(f"image buffer of {rgb_buffer.size} bytes; {self.width}x"
                                f"{self.height} vec4<f32> needs {self.width * self.height * 16}")
        if self._compose_group is None or self._target is not rgb_buffer:
            self._compose_group = self.device.create_bind_group(
                layout=self._compose_layout, entries=bind_group_entries(
                    {1: self.params, 4: self.accum, 5: rgb_buffer}))
            self._target = rgb_buffer
        record_dispatch(encoder, self._compose, self._compose_group,
                        (-(-self.width // WORKGROUP[0]), -(-self.height // WORKGROUP[1]), 1))

    def encode(self, encoder, surface_texture, rgb_buffer, *, display: bool = False) -> None:
        """Splat and compose (:meth:`set_splats` first); with ``display``
        composed and shown by :meth:`encode_display` (``rgb_buffer`` left as it was)."""
        self.encode_splat(encoder, surface_texture)
        if display:
            self.encode_display(encoder, rgb_buffer)
        else:
            self.encode_compose(encoder, rgb_buffer)

    # ------------------------------------------------------------- display
    def set_display(self, **settings) -> None:
        """Display settings of :meth:`encode_display`
        (:meth:`aquaspec.gpu.passes.particles_display.SnowDisplayPass.set_settings`)."""
        if self._display is None:
            self._display = SnowDisplayPass(self.device, self.width, self.height, self.accum,
                                            self.params, PARAMS)
            self.output = self._display.output
        self._display.set_settings(**settings)
        self.display_settings = self._display.settings

    def encode_display(self, encoder, rgb_buffer) -> None:
        """Record the composition over ``rgb_buffer`` (read only) and the display
        transform into :attr:`output` ``.display_buffer`` (:meth:`set_display` first)."""
        if self._display is None:
            raise AquaspecError("no display settings: call set_display() first")
        self._display.encode(encoder, rgb_buffer)

    def read_display(self) -> np.ndarray:
        """The last :meth:`encode_display` image (H, W, 3) uint8."""
        return self._display.read()

    def read_accumulated(self) -> np.ndarray:
        """The last splat as :func:`aquaspec.shading.particles.splat_image` gives it
        (H, W, 4): camera RGB and coverage."""
        return read_texture(self.device, self.accum, np.uint32, 4).view(np.float32).astype(
            np.float64)
