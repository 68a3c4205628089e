"""The flat port pass: a port's image resampled from a pinhole render in water, on the GPU.

The GPU twin of :func:`aquaspec.optics.remap.port_image` for camera RGB
(one wavelength per channel; WGSL: ``flat_port.wgsl`` beside this module)
times :meth:`aquaspec.optics.flat_port.FlatPort.radiance_factor` (the
radiance in air),
the cheap per-pixel part of :mod:`aquaspec.rendering.camera_model` a live
view needs. ``tests/optics/test_flat_port_pass.py`` holds the two together.

Inputs: the pinhole render in water, ``vec4<f32>`` per pixel (pixel
``p = row * width + column``; e.g. a shading pass's output through
:meth:`FlatPortPass.use_input`), and its G-buffer
(:class:`aquaspec.gpu.gbuffer.GBufferTextures`: the ray distances, as the
geometry pass left them; none: surfaces at infinity). Output: the sensor's
image, ``vec4<f32>`` per pixel.
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import (create_storage_buffer, create_texture, create_uniform_buffer,
                                  read_buffer, upload_buffer)
from aquaspec.gpu.device import get_device
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch, submit_pass
from aquaspec.gpu.gbuffer import GBUFFER_FORMATS, GBUFFER_USAGE
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.shaders import load_wgsl
from aquaspec.optics.remap import ITERATIONS

WORKGROUP = (8, 8)
B_PARAMS, B_RGB_IN, B_SURFACE, B_RGB_OUT = 0, 1, 2, 3

PORT_LAYOUT = UniformLayout("PortParams", [
    ("n_water", "vec4<f32>"), ("n_glass", "vec4<f32>"),
    ("width", "u32"), ("height", "u32"), ("water_width", "u32"), ("water_height", "u32"),
    ("fx", "f32"), ("fy", "f32"), ("cx", "f32"), ("cy", "f32"),
    ("water_fx", "f32"), ("water_fy", "f32"), ("water_cx", "f32"), ("water_cy", "f32"),
    ("gap_m", "f32"), ("thickness_m", "f32"), ("use_depth", "u32"),
])


class FlatPortPass:
    """A flat port's image of a sensor of intrinsics ``sensor`` from a pinhole
    render of intrinsics ``water`` (:class:`aquaspec.optics.remap.Intrinsics`).

    Per frame: :meth:`set_port` (once per port and wavelengths), the inputs
    (:meth:`upload` / :meth:`use_input`, :meth:`use_gbuffer`), :meth:`run`,
    :meth:`read`.
    """

    def __init__(self, sensor, water, *, device=None):
        if device is None:
            _, device = get_device()
        self.device, self.sensor, self.water = device, sensor, water
        n_in, n_out = water.width * water.height, sensor.width * sensor.height
        self._uniform = create_uniform_buffer(device, PORT_LAYOUT, label="port params")
        self._input = create_storage_buffer(device, n_in * 16, label="port input")
        self._surface = None
        self.output_buffer = create_storage_buffer(device, n_out * 16, label="port output")
        self._layout = bind_group_layout(device, {B_PARAMS: "uniform", B_RGB_IN: "read",
                                                  B_SURFACE: "uint", B_RGB_OUT: "write"})
        self._pipeline = compute_pipeline(
            device, self._layout, load_wgsl("flat_port.wgsl", port_struct=PORT_LAYOUT.wgsl(),
                                            port_struct_name=PORT_LAYOUT.name,
                                            iterations=ITERATIONS), "flat_port.wgsl")
        self._bind_group = None
        self._use_depth = False
        self._port = None
        self._blank = None

    def set_port(self, port, wavelength_nm) -> None:
        """The port (:class:`aquaspec.optics.flat_port.FlatPort`) and each
        channel's wavelength, nm (3)."""
        wl = np.asarray(wavelength_nm, dtype=float)
        if wl.shape != (3,):
            raise AquaspecError(f"wavelengths {wavelength_nm!r}; accepted: one per channel (3)")
        self._port = (port, wl)
        self._upload_params()

    def _upload_params(self):
        port, wl = self._port
        n_w, n_g = port.indices(wl)
        s, w = self.sensor, self.water
        upload_buffer(self.device, self._uniform, PORT_LAYOUT.pack(
            n_water=[*n_w, 1.0], n_glass=[*n_g, 1.0], width=s.width, height=s.height,
            water_width=w.width, water_height=w.height, fx=s.fx, fy=s.fy, cx=s.cx, cy=s.cy,
            water_fx=w.fx, water_fy=w.fy, water_cx=w.cx, water_cy=w.cy, gap_m=port.gap_m,
            thickness_m=port.thickness_m, use_depth=int(self._use_depth)))

    def upload(self, rgb) -> None:
        """Upload the pinhole render in water, (H, W, 3)."""
        arr = np.asarray(rgb)
        if arr.shape != (self.water.height, self.water.width, 3):
            raise AquaspecError(f"image has shape {arr.shape}; the render in water is "
                                f"({self.water.height}, {self.water.width}, 3)")
        rgba = np.zeros((*arr.shape[:2], 4), dtype=np.float32)
        rgba[..., :3] = arr
        upload_buffer(self.device, self._input, rgba)
        self._bind_group = None

    def use_input(self, buffer) -> None:
        """Read a GPU buffer of the render's ``vec4<f32>`` pixels."""
        need = self.water.width * self.water.height * 16
        if buffer.size < need:
            raise AquaspecError(f"input buffer has {buffer.size} bytes; {need} needed")
        self._input = buffer
        self._bind_group = None

    def use_gbuffer(self, gbuffer) -> None:
        """Read the render's depth from ``gbuffer`` (a
        :class:`aquaspec.gpu.gbuffer.GBufferTextures` of the render in water),
        or None: every surface at infinity (the central mapping)."""
        if gbuffer is not None and (gbuffer.width, gbuffer.height) != (self.water.width,
                                                                      self.water.height):
            raise AquaspecError(f"G-buffer of {gbuffer.width}x{gbuffer.height}; the render in "
                                f"water is {self.water.width}x{self.water.height}")
        self._use_depth = gbuffer is not None
        surface = gbuffer.textures["surface"] if gbuffer is not None else self._placeholder()
        if surface is not self._surface:
            self._surface = surface
            self._bind_group = None
        if self._port is not None:
            self._upload_params()

    def _placeholder(self):
        """A 1x1 surface texture to bind when no G-buffer is read."""
        if self._blank is None:
            self._blank = create_texture(self.device, 1, 1, GBUFFER_FORMATS["surface"],
                                         label="port no depth", usage=GBUFFER_USAGE)
        return self._blank

    def encode(self, encoder, timestamp_writes=None) -> None:
        """Record the pass into ``encoder``."""
        if self._port is None:
            raise AquaspecError("no port: call set_port() before running")
        if self._surface is None:
            self.use_gbuffer(None)
        if self._bind_group is None:
            self._bind_group = self.device.create_bind_group(
                layout=self._layout, entries=bind_group_entries({
                    B_PARAMS: self._uniform, B_RGB_IN: self._input, B_SURFACE: self._surface,
                    B_RGB_OUT: self.output_buffer}))
        groups = (-(-self.sensor.width // WORKGROUP[0]), -(-self.sensor.height // WORKGROUP[1]), 1)
        record_dispatch(encoder, self._pipeline, self._bind_group, groups, timestamp_writes)

    def run(self) -> None:
        """Run the pass (submits; does not wait)."""
        submit_pass(self.device, self)

    def read(self) -> np.ndarray:
        """The sensor's image, (H, W, 3) float32."""
        out = read_buffer(self.device, self.output_buffer, np.float32,
                          (self.sensor.height, self.sensor.width, 4))
        return np.ascontiguousarray(out[..., :3])
