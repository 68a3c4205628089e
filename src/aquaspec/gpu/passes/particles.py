"""Marine snow on the GPU: the particles' discs splatted and composed over the shaded image.

The particles' light is computed on the host per particle
(:class:`aquaspec.shading.particles.ParticleLight`, :func:`aquaspec.shading.particles.splats`:
N x bands numbers, a few milliseconds for tens of thousands of particles);
this pass draws their discs. WGSL: ``particles.wgsl`` beside this module.

1. Splat (a render pass): one instanced quad per particle, additive
   blending into an ``rgba16float`` accumulation target (the fragment
   weights its pixel by the anti-aliased disc and drops it behind the
   G-buffer's surface), as :func:`aquaspec.shading.particles.splat_image`.
   Camera RGB is multiplied on the host by ``scale = 1 / max(RGB)`` of the
   frame's particles so that half floats hold it (11-bit mantissa: about
   0.05 % per particle).
2. Compose (a compute pass, in place on a ``vec4<f32>`` image buffer, e.g.
   the shading pass's ``rgb_buffer``), as :func:`aquaspec.shading.particles.composite`;
   or, with display settings (:meth:`ParticlePass.set_display`), composed and
   shown in one pass (:mod:`aquaspec.gpu.passes.particles_display`, 8-bit sRGB in
   :attr:`ParticlePass.output`):
   on lavapipe a full-image pass costs about as much as the splat of ten
   thousand particles, so the composition rides on the display's.
"""

from __future__ import annotations

import numpy as np
import wgpu

from aquaspec.errors import AquaspecError
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import create_texture, create_uniform_buffer, read_texture, upload_buffer
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.passes.particles_display import SnowDisplayPass
from aquaspec.gpu.shaders import load_wgsl
from aquaspec.shading.particles import SPLAT_FIELDS

PARAMS = UniformLayout("ParticleParams", [("width", "f32"), ("height", "f32"),
                                          ("inv_scale", "f32"), ("count", "f32")])
#: Format of the accumulation target (blendable in core WebGPU).
ACCUM_FORMAT = wgpu.TextureFormat.rgba16float
WORKGROUP = (8, 8)
_RECORD_BYTES = 4 * len(SPLAT_FIELDS)


class ParticlePass:
    """Splat and compose marine snow on images of ``width`` x ``height``."""

    def __init__(self, device, width: int, height: int):
        self.device, self.width, self.height = device, int(width), int(height)
        self.accum = create_texture(device, width, height, ACCUM_FORMAT, label="snow accum",
                                    usage=wgpu.TextureUsage.RENDER_ATTACHMENT
                                    | wgpu.TextureUsage.TEXTURE_BINDING
                                    | wgpu.TextureUsage.COPY_SRC)
        self.params = create_uniform_buffer(device, PARAMS, label="snow params")
        code = load_wgsl("particles.wgsl", params_struct=PARAMS.wgsl(),
                         params_name=PARAMS.name)
        module = device.create_shader_module(label="particles.wgsl", code=code)
        frag = wgpu.ShaderStage.FRAGMENT
        self._splat_layout = device.create_bind_group_layout(entries=[
            {"binding": 0, "visibility": frag,
             "texture": {"sample_type": wgpu.TextureSampleType.uint,
                         "view_dimension": wgpu.TextureViewDimension.d2}},
            {"binding": 1, "visibility": wgpu.ShaderStage.VERTEX | frag,
             "buffer": {"type": wgpu.BufferBindingType.uniform}}])
        add = {"operation": wgpu.BlendOperation.add, "src_factor": wgpu.BlendFactor.one,
               "dst_factor": wgpu.BlendFactor.one}
        f32x4 = wgpu.VertexFormat.float32x4
        self._splat = device.create_render_pipeline(
            label="snow splat",
            layout=device.create_pipeline_layout(bind_group_layouts=[self._splat_layout]),
            vertex={"module": module, "entry_point": "vs_splat", "buffers": [{
                "array_stride": _RECORD_BYTES, "step_mode": wgpu.VertexStepMode.instance,
                "attributes": [{"format": f32x4, "offset": 0, "shader_location": 0},
                               {"format": f32x4, "offset": 16, "shader_location": 1}]}]},
            primitive={"topology": wgpu.PrimitiveTopology.triangle_list,
                       "cull_mode": wgpu.CullMode.none},
            multisample={"count": 1},
            fragment={"module": module, "entry_point": "fs_splat",
                      "targets": [{"format": ACCUM_FORMAT,
                                   "blend": {"color": add, "alpha": add}}]})
        self._compose_layout = bind_group_layout(device, {2: "float", 3: "write", 4: "uniform"})
        self._compose = compute_pipeline(device, self._compose_layout, code, "particles.wgsl",
                                         entry_point="cs_compose")
        self._instances = None
        self._count = 0
        self._inv_scale = 1.0
        self._splat_group = None
        self._surface = None
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
        peak = float(np.abs(rec[:, 4:7]).max()) if len(rec) else 0.0
        scale = 1.0 / peak if peak > 0 else 1.0
        rec = rec.copy()
        rec[:, 4:7] *= scale
        if len(rec) and (self._instances is None or self._instances.size < rec.nbytes):
            self._instances = self.device.create_buffer(
                label="snow instances", size=max(rec.nbytes, 4096) * 2,
                usage=wgpu.BufferUsage.VERTEX | wgpu.BufferUsage.COPY_DST)
        if len(rec):
            upload_buffer(self.device, self._instances, rec)
        self._count = len(rec)
        self._inv_scale = peak if peak > 0 else 1.0
        u = np.zeros((), PARAMS.dtype)
        u["width"], u["height"] = self.width, self.height
        u["inv_scale"], u["count"] = self._inv_scale, self._count
        upload_buffer(self.device, self.params, u)

    def encode_splat(self, encoder, surface_texture) -> None:
        """Record the splat against the G-buffer's ``surface`` texture (the
        target is cleared first, also with no particles)."""
        if self._splat_group is None or self._surface is not surface_texture:
            self._splat_group = self.device.create_bind_group(
                layout=self._splat_layout, entries=[
                    {"binding": 0, "resource": surface_texture.create_view()},
                    {"binding": 1, "resource": {"buffer": self.params, "offset": 0,
                                                "size": self.params.size}}])
            self._surface = surface_texture
        rp = encoder.begin_render_pass(color_attachments=[{
            "view": self.accum.create_view(), "clear_value": (0, 0, 0, 0),
            "load_op": wgpu.LoadOp.clear, "store_op": wgpu.StoreOp.store}])
        if self._count:
            rp.set_pipeline(self._splat)
            rp.set_bind_group(0, self._splat_group)
            rp.set_vertex_buffer(0, self._instances)
            rp.draw(6, self._count)
        rp.end()

    def encode_compose(self, encoder, rgb_buffer) -> None:
        """Record the composition in place on ``rgb_buffer`` (``vec4<f32>`` per pixel)."""
        if rgb_buffer.size < self.width * self.height * 16:
            raise AquaspecError(f"image buffer of {rgb_buffer.size} bytes; {self.width}x"
                                f"{self.height} vec4<f32> needs {self.width * self.height * 16}")
        if self._compose_group is None or self._target is not rgb_buffer:
            self._compose_group = self.device.create_bind_group(
                layout=self._compose_layout, entries=bind_group_entries(
                    {2: self.accum.create_view(), 3: rgb_buffer, 4: self.params}))
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
        (H, W, 4): camera RGB (the scale taken off) and coverage."""
        acc = read_texture(self.device, self.accum, np.float16, 4).astype(np.float64)
        acc[..., :3] *= self._inv_scale
        return acc
