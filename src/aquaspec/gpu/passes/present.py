"""The present pass: the display image onto a window's surface, on the GPU.

The display transform (the fused one of the shading passes,
:class:`aquaspec.gpu.shading_output.ShadingOutput`, or
:class:`aquaspec.gpu.passes.display.DisplayPass`) writes the 8-bit image into
a storage buffer of ``width * height`` packed ``u32``
(``r | g << 8 | b << 16 | a << 24``, sRGB-encoded). This pass draws one
fullscreen triangle whose fragments read that buffer and write a render
target: the surface texture of a window (``rendercanvas``), or any texture of
a colour format. Nothing is read back to the host. WGSL: ``present.wgsl``
beside this module.

A target of the image's size receives every pixel unchanged (the twin test,
``tests/gpu/passes/test_present_pass.py``, compares it with
:meth:`aquaspec.rendering.renderer.Renderer.read_display` exactly); another
size is sampled nearest-neighbour. A ``-srgb`` target format would encode the
already encoded bytes again, so for one the shader decodes them first (the
hardware's encoding then gives the bytes back, up to rounding): prefer the
plain ``unorm`` format (:func:`plain_format`).

An overlay (:meth:`PresentPass.set_overlay`: a small RGBA8 image such as the
live view's status text, uploaded when it changes) is drawn one to one over
the target's top-left corner, mixed by its alpha.
"""

from __future__ import annotations

import numpy as np
import wgpu

from aquaspec.errors import AquaspecError
from aquaspec.gpu.buffers import create_uniform_buffer, upload_buffer
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.shaders import load_wgsl
from aquaspec.scene.camera import check_size

#: The pass's uniform: the image's and the target's sizes in pixels.
PRESENT_LAYOUT = UniformLayout("PresentParams", [("image_size", "vec2<u32>"),
                                                 ("target_size", "vec2<u32>"),
                                                 ("overlay_size", "vec2<u32>")])
B_PARAMS, B_RGBA8, B_OVERLAY = 0, 1, 2
#: Colour formats a target may have: the 8-bit ones a surface offers.
TARGET_FORMATS = ("bgra8unorm", "rgba8unorm", "bgra8unorm-srgb", "rgba8unorm-srgb")


def plain_format(fmt: str) -> str:
    """``fmt`` without its ``-srgb`` suffix (the bytes written as they are)."""
    return fmt[:-len("-srgb")] if fmt.endswith("-srgb") else fmt


def shader_source(target_format: str) -> str:
    """WGSL of ``present.wgsl`` for a target of ``target_format``."""
    return load_wgsl("present.wgsl", present_struct=PRESENT_LAYOUT.wgsl(),
                     present_struct_name=PRESENT_LAYOUT.name,
                     decode_srgb="true" if target_format.endswith("-srgb") else "false")


class PresentPass:
    """Draws a packed RGBA8 display buffer onto render targets of one format.

    Parameters
    ----------
    device : wgpu.GPUDevice
        The device that owns the display buffer (the renderer's).
    target_format : str
        The targets' texture format, one of :data:`TARGET_FORMATS`.
    """

    def __init__(self, device, target_format: str):
        if target_format not in TARGET_FORMATS:
            raise AquaspecError(f"present target format {target_format!r}; accepted: "
                                + ", ".join(TARGET_FORMATS))
        self.device = device
        self.target_format = target_format
        self._uniform = create_uniform_buffer(device, PRESENT_LAYOUT, label="present params")
        visibility = wgpu.ShaderStage.FRAGMENT
        self._layout = device.create_bind_group_layout(entries=[
            {"binding": B_PARAMS, "visibility": visibility,
             "buffer": {"type": wgpu.BufferBindingType.uniform}},
            {"binding": B_RGBA8, "visibility": visibility,
             "buffer": {"type": wgpu.BufferBindingType.read_only_storage}},
            {"binding": B_OVERLAY, "visibility": visibility,
             "texture": {"sample_type": wgpu.TextureSampleType.float,
                         "view_dimension": wgpu.TextureViewDimension.d2}}])
        module = device.create_shader_module(label="present.wgsl",
                                             code=shader_source(target_format))
        self._pipeline = device.create_render_pipeline(
            label="present",
            layout=device.create_pipeline_layout(bind_group_layouts=[self._layout]),
            vertex={"module": module, "entry_point": "vs_main", "buffers": []},
            primitive={"topology": wgpu.PrimitiveTopology.triangle_list,
                       "cull_mode": wgpu.CullMode.none},
            depth_stencil=None,
            multisample={"count": 1},
            fragment={"module": module, "entry_point": "fs_main",
                      "targets": [{"format": target_format}]})
        self._source = None
        self._bind_group = None
        self.overlay_size = (0, 0)
        self._overlay = None
        self.set_overlay(None)

    def set_overlay(self, rgba) -> None:
        """Draw ``rgba`` ((h, w, 4) uint8, straight alpha, sRGB-encoded) over
        the targets' top-left corner from now on; None: no overlay."""
        if rgba is None:
            data, self.overlay_size = np.zeros((1, 1, 4), np.uint8), (0, 0)
        else:
            data = np.ascontiguousarray(rgba)
            if data.dtype != np.uint8 or data.ndim != 3 or data.shape[2] != 4 \
                    or 0 in data.shape:
                raise AquaspecError(f"overlay has dtype {data.dtype} and shape {data.shape}; "
                                    "accepted: uint8 (height, width, 4)")
            self.overlay_size = (data.shape[1], data.shape[0])
        h, w = data.shape[:2]
        if self._overlay is None or tuple(self._overlay.size[:2]) != (w, h):
            self._overlay = self.device.create_texture(
                label="present overlay", size=(w, h, 1), format=wgpu.TextureFormat.rgba8unorm,
                usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST)
            self._source = None         # the bind group names the texture
        self.device.queue.write_texture(
            {"texture": self._overlay, "mip_level": 0, "origin": (0, 0, 0)}, data,
            {"offset": 0, "bytes_per_row": w * 4, "rows_per_image": h}, (w, h, 1))

    def _bind(self, source):
        if source is not self._source:
            self._bind_group = self.device.create_bind_group(layout=self._layout, entries=[
                {"binding": B_PARAMS, "resource": {"buffer": self._uniform, "offset": 0,
                                                   "size": self._uniform.size}},
                {"binding": B_RGBA8, "resource": {"buffer": source, "offset": 0,
                                                  "size": source.size}},
                {"binding": B_OVERLAY, "resource": self._overlay.create_view()}])
            self._source = source
        return self._bind_group

    def encode(self, encoder, source, image_size, target) -> None:
        """Record drawing ``source`` onto ``target`` into ``encoder``.

        Parameters
        ----------
        encoder : wgpu.GPUCommandEncoder
        source : wgpu.GPUBuffer
            The packed display image, at least ``width * height * 4`` bytes.
        image_size : (int, int)
            The image's ``(width, height)`` in pixels.
        target : wgpu.GPUTexture
            A 2-D texture of :attr:`target_format` with ``RENDER_ATTACHMENT``
            usage (e.g. ``context.get_current_texture()``).
        """
        width, height = check_size(*image_size)
        if source.size < width * height * 4:
            raise AquaspecError(f"display buffer has {source.size} bytes; a {width}x{height} "
                                f"RGBA8 image needs {width * height * 4}")
        if target.format != self.target_format:
            raise AquaspecError(f"target texture format {target.format!r}; this pass was "
                                f"made for {self.target_format!r}")
        params = np.zeros((), PRESENT_LAYOUT.dtype)
        params["image_size"] = (width, height)
        params["target_size"] = (target.size[0], target.size[1])
        params["overlay_size"] = self.overlay_size
        # A queue write lands before the next submission: one present per submission.
        upload_buffer(self.device, self._uniform, params)
        rp = encoder.begin_render_pass(color_attachments=[{
            "view": target.create_view(), "resolve_target": None,
            "clear_value": (0.0, 0.0, 0.0, 1.0),
            "load_op": wgpu.LoadOp.clear, "store_op": wgpu.StoreOp.store}])
        rp.set_pipeline(self._pipeline)
        rp.set_bind_group(0, self._bind(source))
        rp.draw(3, 1, 0, 0)
        rp.end()
