"""Material band reflectances on the GPU, shared by the shading passes.

The table has one row per material and ``ceil(n / 4)`` vec4 per row, band
``i`` in component ``i % 4`` of vec4 ``i // 4`` (zeros past the last band);
``gpu/wgsl/materials.wgsl`` reads it. It lives in a uniform buffer of
:data:`UNIFORM_VEC4` vec4 (64 KiB, WebGPU's default binding limit) when it
fits, else in a storage buffer; both are always bound (binding 3 storage,
binding 5 uniform) and the shader's ``MATERIALS_IN_UNIFORM`` constant picks
one.

Why: on lavapipe each pixel's reflectance in each band, read as a scalar
from a storage buffer, was the largest single cost of the band loop (the
light-field pass at 1280x720, 8 bands: 3.8 ms of 21 ms, measured by
leaving it out). Both shading passes read one vec4 per pixel
for four bands. From :data:`GROUPED_MIN_BANDS` bands their loops take four
bands per iteration (the band body written out four times): at 1280x720
both the light field's and the seeds' frames were 2-3 ms faster with 16
bands and 7-9 ms faster with 32 (about 45 -> 37 ms) than with a band per
iteration. Below it a loop over the vec4s holds a loop over their bands:
1-1.4 ms faster than a band per iteration with 3 and 8 bands, where the
written-out bodies had been 1-2 ms slower.
"""

from __future__ import annotations

import numpy as np

from aquaspec.gpu.buffers import create_storage_buffer, create_uniform_buffer, upload_buffer

#: vec4 entries of the uniform material table (64 KiB).
UNIFORM_VEC4 = 4096
#: Band count from which the band loops take four bands per iteration, the
#: band body written out four times (compile-time in both shading passes,
#: ``materials.wgsl``; below it, nested loops).
GROUPED_MIN_BANDS = 16
#: Bindings of the table (both shading passes leave these numbers free).
B_MATERIAL_STORAGE, B_MATERIAL_UNIFORM = 3, 5


def material_groups(material_bands, n_bands: int) -> np.ndarray:
    """``(M, n)`` reflectances -> ``(M * ceil(n / 4), 4)`` float32 rows of four bands."""
    mb = np.asarray(material_bands, dtype=np.float32).reshape(-1, int(n_bands))
    groups = -(-int(n_bands) // 4)
    out = np.zeros((mb.shape[0], groups * 4), dtype=np.float32)
    out[:, :n_bands] = mb
    return out.reshape(-1, 4)


class MaterialTable:
    """The two buffers of the material table and which one the shader reads."""

    def __init__(self, device, label: str):
        self.device = device
        self.label = label
        self.uniform = create_uniform_buffer(device, UNIFORM_VEC4 * 16, label=f"{label} (uniform)")
        self.storage = create_storage_buffer(device, 16, label=f"{label} (storage)")
        #: Whether the current table is in the uniform buffer.
        self.in_uniform = True
        #: Incremented when :attr:`storage` is replaced (bind groups must be rebuilt).
        self.version = 0

    def upload(self, material_bands, n_bands: int) -> None:
        table = material_groups(material_bands, n_bands)
        self.in_uniform = table.shape[0] <= UNIFORM_VEC4
        if not table.size:
            return
        if self.in_uniform:
            upload_buffer(self.device, self.uniform, table)
            return
        if table.nbytes > self.storage.size:
            self.storage = create_storage_buffer(self.device, table.nbytes,
                                                 label=f"{self.label} (storage)")
            self.version += 1
        upload_buffer(self.device, self.storage, table)

    @staticmethod
    def layout() -> dict:
        """Binding kinds for :func:`aquaspec.gpu.bindings.bind_group_layout`."""
        return {B_MATERIAL_STORAGE: "read", B_MATERIAL_UNIFORM: "uniform"}

    def resources(self) -> dict:
        return {B_MATERIAL_STORAGE: self.storage, B_MATERIAL_UNIFORM: self.uniform}

    def template(self) -> dict:
        """Template values of ``materials.wgsl``."""
        return {"materials_in_uniform": "true" if self.in_uniform else "false",
                "material_uniform_vec4": UNIFORM_VEC4, "grouped_min_bands": GROUPED_MIN_BANDS}
