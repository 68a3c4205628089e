"""The G-buffer: what the shading passes need to know about each pixel.

It can come from rasterising meshes (:mod:`aquaspec.gpu.passes.raster`) or from an
RGB-D image (:mod:`aquaspec.scene.rgbd`); the shading passes do not care which.

Per pixel:

- ``distance``: distance ``S`` in metres from the camera centre to the first
  surface along the pixel's ray; ``inf`` where the ray sees open water.
- ``normal``: unit world-space surface normal (zeros where there is no hit).
- ``material``: index into ``materials``, or :data:`PER_PIXEL` when the
  reflectance comes from the pixel's own ``sigmoid`` coefficients (textures,
  RGB-D photographs).
- ``sigmoid``: Jakob-Hanika (2019) coefficients in normalised wavelength
  (see :func:`aquaspec.colour.reflectance.sigmoid_band_values`).

``materials`` is a list of :class:`aquaspec.colour.reflectance.Reflectance`: measured
spectra stay measured and are band-averaged once per band count.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from aquaspec.colour.reflectance import sigmoid_at
from aquaspec.scene.camera import Camera
from aquaspec.errors import AquaspecError

#: Material index meaning "use this pixel's sigmoid coefficients".
PER_PIXEL = np.uint32(0xFFFFFFFF)


@dataclass
class GBuffer:
    camera: Camera
    distance: np.ndarray            # (H, W) float32, inf = open water
    normal: np.ndarray              # (H, W, 3) float32
    material: np.ndarray            # (H, W) uint32
    sigmoid: np.ndarray             # (H, W, 3) float32
    materials: list = field(default_factory=list)

    def __post_init__(self):
        h, w = self.camera.height, self.camera.width
        self.distance = np.asarray(self.distance, dtype=np.float32)
        self.normal = np.asarray(self.normal, dtype=np.float32)
        self.material = np.asarray(self.material, dtype=np.uint32)
        self.sigmoid = np.asarray(self.sigmoid, dtype=np.float32)
        for name, arr, shape in (("distance", self.distance, (h, w)),
                                 ("normal", self.normal, (h, w, 3)),
                                 ("material", self.material, (h, w)),
                                 ("sigmoid", self.sigmoid, (h, w, 3))):
            if arr.shape != shape:
                raise AquaspecError(f"G-buffer {name} has shape {arr.shape}; "
                                    f"the camera needs {shape}")
        if np.any(np.isnan(self.distance)) or np.any(self.distance < 0):
            raise AquaspecError("G-buffer distance must be >= 0 or inf (open water), never NaN")
        hit = np.isfinite(self.distance)
        used = np.unique(self.material[hit])
        bad = used[(used != PER_PIXEL) & (used >= len(self.materials))]
        if bad.size:
            raise AquaspecError(f"G-buffer uses material index {int(bad[0])} but only "
                                f"{len(self.materials)} materials are defined")

    @property
    def hit(self) -> np.ndarray:
        """(H, W) bool: the ray hit a surface."""
        return np.isfinite(self.distance)

    def resized(self, width: int, height: int) -> "GBuffer":
        """This G-buffer on a ``width`` x ``height`` image of the same view
        (:meth:`Camera.resized`): each pixel takes the values of the pixel
        of this one that holds its centre (nearest, no blending across
        edges; its distance is then read along its own ray)."""
        cam = self.camera.resized(width, height)
        if cam is self.camera:
            return self
        rows = np.minimum(((np.arange(cam.height) + 0.5) * self.camera.height
                           / cam.height).astype(int), self.camera.height - 1)
        cols = np.minimum(((np.arange(cam.width) + 0.5) * self.camera.width
                           / cam.width).astype(int), self.camera.width - 1)
        pick = np.ix_(rows, cols)
        return GBuffer(cam, self.distance[pick], self.normal[pick], self.material[pick],
                       self.sigmoid[pick], list(self.materials))

    def positions(self) -> np.ndarray:
        """(H, W, 3) world positions of the hits (inf where open water)."""
        d = self.camera.ray_directions()
        hit = self.hit
        s = np.where(hit, self.distance, 0.0)[..., None].astype(float)
        return np.where(hit[..., None], self.camera.position + d * s, np.inf)


def hit_reflectance(material, sigmoid, material_bands, t):
    """Band reflectance (P, n) of hit pixels: their material's (``material_bands``
    rows), or with :data:`PER_PIXEL` their sigmoid's at ``t``.
    (The G-buffer holds only defined material indices: GBuffer checks them.)"""
    per_pixel = material == PER_PIXEL
    rho = np.empty((material.size, material_bands.shape[1]))
    rho[per_pixel] = sigmoid_at(sigmoid[per_pixel], t)
    rho[~per_pixel] = material_bands[material[~per_pixel]]
    return rho
