"""Deferred shading with the light-field multiple-scattering model on the GPU.

The ``ms_model="lightfield"`` counterpart of
:class:`aquaspec.gpu.deferred.DeferredPass`: it reads the same storage
G-buffer (``DeferredPass.gbuffer_buffers``, layout in
:mod:`aquaspec.gpu.deferred`) and per band the tables of
:func:`aquaspec.lightfield.lightfield_tables` (``ln F`` over depth x
direction for the in-scattering, ``E(d, n_y)/E0`` for the surfaces). WGSL:
``shaders/lightfield.wgsl``; NumPy reference:
:func:`aquaspec.shading.shade_gbuffer` with ``lightfield=`` tables; the test
``tests/test_gpu_lightfield.py`` holds them together. Deep water only.
"""

from __future__ import annotations

import numpy as np

from ..errors import AquaspecError
from .buffers import (create_storage_buffer, create_uniform_buffer, read_buffer,
                      record_dispatch, submit_pass, upload_buffer)
from .deferred import CAMERA_FIELDS, bind_group_layout, camera_fields
from .layout import UniformLayout
from .shaders import load_wgsl

PARAMS_LAYOUT = UniformLayout("LightfieldParams", CAMERA_FIELDS + [
    ("width", "u32"), ("height", "u32"), ("n_bands", "u32"), ("n_materials", "u32"),
    ("n_depth", "u32"), ("n_mu", "u32"), ("max_depth", "f32"), ("window_cos", "f32"),
    ("depth_o", "f32"),
])


class LightfieldPass:
    """Light-field shading of the G-buffer held by ``deferred`` (a DeferredPass)."""

    def __init__(self, deferred):
        self.deferred = deferred
        dev = self.device = deferred.device
        self.width, self.height = deferred.width, deferred.height
        npix = self.width * self.height
        self._uniform = create_uniform_buffer(dev, PARAMS_LAYOUT, label="lightfield params")
        self.rgb_buffer = create_storage_buffer(dev, npix * 16, label="lightfield rgb")
        self._layout = bind_group_layout(dev, {0: "uniform", 1: "read", 2: "read", 3: "read",
                                               4: "read", 5: "read", 6: "read", 7: "read",
                                               8: "write"})
        src = load_wgsl("lightfield.wgsl", params_struct=PARAMS_LAYOUT.wgsl())
        module = dev.create_shader_module(label="lightfield.wgsl", code=src)
        self._pipeline = dev.create_compute_pipeline(
            label="lightfield", layout=dev.create_pipeline_layout(bind_group_layouts=[self._layout]),
            compute={"module": module, "entry_point": "main"})
        self._buffers = None
        self._shape = None

    def set_medium(self, *, a, b, e0, response_weights, material_bands, sigmoid_centers_t,
                   tables, **_ignored):
        """Upload per-band data and the tables (``kd`` and ``ambient`` are not used)."""
        if np.isfinite(float(tables["seabed_depth_m"][0])):
            raise AquaspecError("the GPU light-field pass supports deep water only (tables "
                                "without a seabed); use backend='numpy' for a seabed")
        a, b, e0 = (np.asarray(x, dtype=float) for x in (a, b, e0))
        w = np.asarray(response_weights, dtype=float)
        n = a.size
        lp = np.ascontiguousarray(tables["ms_log_prefactor"], dtype=np.float32)
        irr = np.ascontiguousarray(tables["irradiance_per_e0"], dtype=np.float32)
        if lp.shape[0] != n:
            raise AquaspecError(f"tables have {lp.shape[0]} bands; the medium has {n}")
        band = np.zeros((n, 3, 4))
        band[:, 0] = np.stack([a + b, b, tables["k_inf"], e0], axis=1)
        band[:, 1, :3] = w
        band[:, 1, 3] = sigmoid_centers_t
        band[:, 2, 0] = tables["sky_radiance_per_e0"]
        band[:, 2, 1] = np.asarray(tables.get("forward_fraction", np.zeros(n))) * b
        mb = np.asarray(material_bands, dtype=np.float32).reshape(-1)
        dev = self.device
        self._buffers = {
            4: create_storage_buffer(dev, band.astype(np.float32), label="lightfield bands"),
            5: create_storage_buffer(dev, mb if mb.size else np.zeros(1, np.float32),
                                     label="lightfield materials"),
            6: create_storage_buffer(dev, lp.reshape(-1), label="lightfield ln F"),
            7: create_storage_buffer(dev, irr.reshape(-1), label="lightfield irradiance"),
        }
        self._shape = dict(n_bands=n, n_materials=int(np.asarray(material_bands).shape[0]),
                           n_depth=lp.shape[1], n_mu=lp.shape[2],
                           max_depth=float(tables["max_depth_m"][0]),
                           window_cos=float(tables["window_cos"][0]))
        self._group = None

    def encode(self, encoder, timestamp_writes=None):
        d = self.deferred
        cam = d.camera
        if cam is None or self._buffers is None:
            raise AquaspecError("LightfieldPass needs a G-buffer (on its DeferredPass) and "
                                "set_medium() before running")
        upload_buffer(self.device, self._uniform, PARAMS_LAYOUT.pack(
            **camera_fields(cam), width=self.width, height=self.height,
            depth_o=-float(cam.position[1]), **self._shape))
        gb = d.gbuffer_buffers
        resources = {0: self._uniform, 1: gb["distance"], 2: gb["surface"], 3: gb["sigmoid"],
                     **self._buffers, 8: self.rgb_buffer}
        group = self.device.create_bind_group(layout=self._layout, entries=[
            {"binding": k, "resource": {"buffer": v, "offset": 0, "size": v.size}}
            for k, v in resources.items()])
        record_dispatch(encoder, self._pipeline, group,
                        (-(-self.width // 8), -(-self.height // 8), 1), timestamp_writes)

    def run(self):
        submit_pass(self.device, self)

    def read_rgb(self) -> np.ndarray:
        rgb = read_buffer(self.device, self.rgb_buffer, np.float32,
                          (self.height, self.width, 4))[..., :3]
        if not np.all(np.isfinite(rgb)):
            raise AquaspecError("the light-field pass produced NaN or infinity")
        return rgb
