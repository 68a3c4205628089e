"""The scene's occlusion of the ambient light field on the GPU (surfaces).

Twin of :func:`aquaspec.transport.lightfield.occlusion.occlusion_factor` on
the maps of :func:`aquaspec.scene.occlusion.occlusion_maps`: the same
directions, occluders and map geometry
(:func:`aquaspec.scene.occlusion.occlusion_layout`), the maps drawn here
through :class:`aquaspec.gpu.passes.depth_maps.DepthMapArray` (closed
occluders with the faces towards the receivers only, ``cull="toward"``),
then ``occlusion.wgsl`` beside this module writes the factor ``O_i`` per
band for a grid of ``scale`` x ``scale`` pixel cells (each cell's centre
pixel) into an ``rgba16float`` array texture (layer ``g``: bands ``4g ..
4g + 3``), which the light-field pass samples bilinearly
(:class:`aquaspec.gpu.passes.lightfield.LightfieldPass.set_occlusion`).

What it costs: the maps are drawn once for a static scene (kept while the
layout, that is the scene, the directions and the camera's map cell, does
not change); the factors are computed again when the camera or the
G-buffer changes (:meth:`OcclusionPass.encode` keeps them otherwise).
A moving occluder means drawing the K maps again (:meth:`forget`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import wgpu

from aquaspec.errors import AquaspecError
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import create_storage_buffer, create_uniform_buffer, upload_buffer
from aquaspec.gpu.camera import CAMERA_FIELDS, camera_fields
from aquaspec.gpu.dispatch import compute_pipeline
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.passes.depth_maps import DepthMapArray, spec_key
from aquaspec.gpu.shaders import load_wgsl

PARAMS_LAYOUT = UniformLayout("OcclusionParams", CAMERA_FIELDS + [
    ("width", "u32"), ("height", "u32"), ("out_width", "u32"), ("out_height", "u32"),
    ("max_depth", "f32"), ("seabed_depth", "f32"), ("deep", "u32"), ("map_size", "f32"),
    ("normal_offset_texels", "f32"), ("bias_texels", "f32"),
])
#: Default cell side of the factors' grid, pixels (1280x720: 320x180 cells).
DEFAULT_SCALE = 4
#: Bytes per direction record (four vec4<f32>).
_DIRECTION_BYTES = 64
_WORKGROUP = 8


@dataclass
class _TriangleDraw:
    """Occluder triangles as a position-only draw for DepthMapArray."""

    vertex: object
    index: object
    count: int
    cull: str
    stride: int = 12
    index_format: str = wgpu.IndexFormat.uint32
    mode: None = None


def _outward_wound(corners, normals) -> np.ndarray:
    """Triangles (T, 3, 3) reordered so that their counter-clockwise winding
    gives the outward normal."""
    geo = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    flip = np.einsum("ij,ij->i", geo, normals) < 0
    out = corners.copy()
    out[flip, 1], out[flip, 2] = corners[flip, 2], corners[flip, 1]
    return out


class OcclusionPass:
    """Occlusion factors for ``width`` x ``height`` frames of ``n_bands`` on ``device``."""

    def __init__(self, device, width: int, height: int, n_bands: int, *,
                 scale: int = DEFAULT_SCALE):
        if isinstance(scale, bool) or not isinstance(scale, (int, np.integer)) \
                or not 1 <= scale <= 16:
            raise AquaspecError(f"occlusion scale {scale!r}; accepted: an integer 1 ... 16 "
                                "(pixels per cell side)")
        self.device, self.width, self.height = device, int(width), int(height)
        self.n_bands, self.scale = int(n_bands), int(scale)
        self.out_width = -(-self.width // self.scale)
        self.out_height = -(-self.height // self.scale)
        self.layers_out = -(-self.n_bands // 4)
        self._texture = device.create_texture(
            label="occlusion factors", size=(self.out_width, self.out_height, self.layers_out),
            format="rgba16float", usage=wgpu.TextureUsage.STORAGE_BINDING
            | wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_SRC,
            dimension="2d", mip_level_count=1, sample_count=1)
        #: The factors' ``2d-array`` view (what the shading pass samples).
        self.view = self._texture.create_view(dimension="2d-array")
        self._uniform = create_uniform_buffer(device, PARAMS_LAYOUT, label="occlusion params")
        self._layout = bind_group_layout(device, {
            0: "uniform", 1: "uint", 2: "read", 3: "read", 4: "read", 5: "depth_array",
            6: "storage_rgba16float_array", 7: "nonfiltering_sampler"})
        self._sampler = device.create_sampler(label="occlusion maps", mag_filter="nearest",
                                              min_filter="nearest",
                                              address_mode_u="clamp-to-edge",
                                              address_mode_v="clamp-to-edge")
        self._maps = None
        self._geometry = None      # (triangles object, draws)
        self._weights = None       # (weights object, log-radiance buffer, band buffer)
        self._layout_key = None
        self._dirs = None
        self._pipeline = None
        self._computed = None
        #: Times the factors were computed (the other encodes kept them).
        self.compute_count = 0

    # ---------------------------------------------------------------- inputs
    def _upload_geometry(self, triangles):
        if self._geometry is not None and self._geometry[0] is triangles:
            return self._geometry[1]
        dev = self.device
        draws = []
        for closed in (False, True):
            sel = triangles.closed == closed
            if not np.any(sel):
                continue
            tri = _outward_wound(triangles.corners[sel], triangles.normals[sel])
            vert = np.ascontiguousarray(tri.reshape(-1, 3), np.float32)
            idx = np.arange(len(vert), dtype=np.uint32)
            vb = dev.create_buffer_with_data(data=vert.tobytes(), usage=wgpu.BufferUsage.VERTEX)
            ib = dev.create_buffer_with_data(data=idx.tobytes(), usage=wgpu.BufferUsage.INDEX)
            draws.append(_TriangleDraw(vb, ib, len(idx), "toward" if closed else "none"))
        self._geometry = (triangles, draws)
        return draws

    def set_weights(self, weights) -> None:
        """The light field's radiance on the directions
        (:class:`aquaspec.transport.lightfield.occlusion.OcclusionWeights`)."""
        if self._weights is not None and self._weights[0] is weights:
            return
        if weights.n_bands != self.n_bands:
            raise AquaspecError(f"occlusion weights have {weights.n_bands} bands; this pass "
                                f"{self.n_bands}")
        pad = 4 * self.layers_out
        band = np.zeros((2, pad), np.float32)
        band[0, :self.n_bands] = weights.extinction
        band[1, :self.n_bands] = weights.k_inf
        # Layer g: [c* of bands 4g .. 4g + 3], [k_inf of them].
        band = np.ascontiguousarray(band.reshape(2, self.layers_out, 4).transpose(1, 0, 2))
        lr = np.zeros(weights.log_radiance.shape[:2] + (pad,), np.float32)
        lr[..., :self.n_bands] = weights.log_radiance
        self._weights = (weights,
                         create_storage_buffer(self.device, lr, label="occlusion log radiance"),
                         create_storage_buffer(self.device, band, label="occlusion bands"))
        self._pipeline = None
        self._computed = None

    def _set_layout(self, encoder, layout, raster_free_draws):
        specs = [s for s in layout.specs if s is not None]
        used = len(specs)
        size = specs[0].size if specs else 16
        if self._maps is None or self._maps.layers != max(used, 1) or self._maps.size != size:
            self._maps = DepthMapArray(self.device, size, max(used, 1),
                                       label="occlusion maps")
            self._computed = None
        if specs:
            self._maps.encode(encoder, raster_free_draws, specs)
        key = (tuple(None if s is None else spec_key(s) for s in layout.specs),
               tuple(np.asarray(layout.directions, float).ravel()))
        if key != self._layout_key:
            rec = np.zeros((len(layout.directions), 16), np.float32)
            layer = 0
            for k, (w, om, spec) in enumerate(zip(layout.directions, layout.solid_angle,
                                                  layout.specs)):
                rec[k, 0:3], rec[k, 3] = w, om
                if spec is None:
                    rec[k, 15] = -1.0
                    continue
                rec[k, 4:7], rec[k, 7] = spec.e1, spec.u0
                rec[k, 8:11], rec[k, 11] = spec.e2, spec.v0
                rec[k, 12:16] = spec.texel, spec.h_min, spec.h_max, layer
                layer += 1
            self._dirs = create_storage_buffer(self.device, rec, label="occlusion directions")
            self._layout_key = key
            self._computed = None
        return size

    # ---------------------------------------------------------------- frames
    def encode(self, encoder, gbuffer, layout, *, normal_offset_texels: float,
               bias_texels: float, timestamp_writes=None) -> bool:
        """Record the factors of ``gbuffer`` (its camera and textures,
        :class:`aquaspec.gpu.gbuffer.GBufferTextures`) for ``layout``
        (:func:`aquaspec.scene.occlusion.occlusion_layout`, the scene's); the
        maps are drawn when the layout changed, the factors computed when the
        layout, the weights, the camera or the G-buffer's textures changed
        (a static scene seen by a still camera keeps them). Returns whether
        they were computed."""
        if self._weights is None:
            raise AquaspecError("OcclusionPass needs set_weights() before encode()")
        cam = gbuffer.camera
        if cam is None or (cam.width, cam.height) != (self.width, self.height):
            raise AquaspecError(f"occlusion: the G-buffer's camera must be {self.width}x"
                                f"{self.height}")
        weights = self._weights[0]
        if len(layout.directions) != weights.directions.shape[0]:
            raise AquaspecError(f"occlusion layout of {len(layout.directions)} directions; "
                                f"the weights have {weights.directions.shape[0]}")
        draws = self._upload_geometry(layout.triangles) if len(layout.triangles.corners) else []
        size = self._set_layout(encoder, layout, draws)
        key = (self._layout_key, id(weights), gbuffer.bindings_version,
               tuple(float(x) for x in np.concatenate([
                   cam.position, cam.right, cam.true_up, cam.forward,
                   [cam.fx, cam.fy, cam.cx, cam.cy]])))
        if key == self._computed:
            return False
        upload_buffer(self.device, self._uniform, PARAMS_LAYOUT.pack(
            **camera_fields(cam), width=self.width, height=self.height,
            out_width=self.out_width, out_height=self.out_height,
            max_depth=weights.max_depth_m,
            seabed_depth=min(float(weights.seabed_depth_m), 1e30),
            deep=int(not np.isfinite(weights.seabed_depth_m)), map_size=float(size),
            normal_offset_texels=normal_offset_texels, bias_texels=bias_texels))
        if self._pipeline is None:
            src = load_wgsl("occlusion.wgsl", params_struct=PARAMS_LAYOUT.wgsl(),
                            n_bands=self.n_bands, n_dirs=weights.directions.shape[0],
                            n_depth=weights.log_radiance.shape[0], layers_out=self.layers_out,
                            scale=self.scale)
            self._pipeline = compute_pipeline(self.device, self._layout, src, "occlusion.wgsl")
        group = self.device.create_bind_group(layout=self._layout, entries=bind_group_entries({
            0: self._uniform, 1: gbuffer.textures["surface"], 2: self._dirs,
            3: self._weights[1], 4: self._weights[2], 5: self._maps.view, 6: self.view,
            7: self._sampler}))
        cp = encoder.begin_compute_pass(timestamp_writes=timestamp_writes)
        cp.set_pipeline(self._pipeline)
        cp.set_bind_group(0, group)
        cp.dispatch_workgroups(-(-self.out_width // _WORKGROUP), -(-self.out_height // _WORKGROUP),
                               1)
        cp.end()
        self._computed = key
        self.compute_count += 1
        return True

    def recompute(self) -> None:
        """Compute the factors again on the next :meth:`encode` (the maps are kept)."""
        self._computed = None

    def forget(self) -> None:
        """Draw the maps and compute the factors again on the next
        :meth:`encode` (an occluder moved: its buffers were edited in place)."""
        if self._maps is not None:
            self._maps.forget()
        self._geometry = None
        self._computed = None

    def read(self) -> np.ndarray:
        """The factors (out_height, out_width, n_bands) float32, for tests."""
        w, h, n_layers = self.out_width, self.out_height, self.layers_out
        row = -(-8 * w // 256) * 256
        buf = self.device.create_buffer(size=row * h * n_layers,
                                        usage=wgpu.BufferUsage.COPY_DST
                                        | wgpu.BufferUsage.MAP_READ)
        enc = self.device.create_command_encoder()
        enc.copy_texture_to_buffer({"texture": self._texture, "mip_level": 0,
                                    "origin": (0, 0, 0)},
                                   {"buffer": buf, "offset": 0, "bytes_per_row": row,
                                    "rows_per_image": h}, (w, h, n_layers))
        self.device.queue.submit([enc.finish()])
        buf.map_sync(wgpu.MapMode.READ)
        raw = np.frombuffer(buf.read_mapped(), np.float16).reshape(n_layers, h, row // 2)
        buf.unmap()
        out = raw[:, :, :4 * w].reshape(n_layers, h, w, 4).astype(np.float32)
        return np.moveaxis(out, 0, 2).reshape(h, w, 4 * n_layers)[..., :self.n_bands]
