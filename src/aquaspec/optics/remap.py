"""A port's image made from a pinhole render in water, resampled per band.

The renderer is a pinhole (central) camera. A flat port
(:class:`aquaspec.optics.flat_port.FlatPort`) is not: its rays in water are
bent by the window (Snell at both faces, per wavelength) and shifted
sideways. Its image is made in two steps:

1. render a pinhole image *in water* from the pupil, with the sensor's
   principal point and a longer focal length ``f / ratio``
   (:func:`water_intrinsics`: ``ratio`` about 1/1.34, the field of view in
   water) so that every sensor pixel's water ray falls inside it for
   surfaces at least ``min_distance_m`` away;
2. for each sensor pixel and each band, find where its water ray meets the
   rendered surface and read that band's radiance there (bilinear):
   :func:`port_coordinates`. The surface's axial depth ``z`` comes from the
   pinhole G-buffer; the ray's point at depth ``z`` is seen by the pinhole
   at radial tangent ``tan theta_w + delta / z``, and ``z`` is read again
   there (a fixed-point iteration, :data:`ITERATIONS` steps; open water is
   at infinity, where the port is central).

What this neglects: a surface seen by the port but hidden from the pupil
(the pupil and the window's exit points are centimetres apart: parallax at
occluding edges only); the depth is read at the nearest pixel, so at a
depth edge a sample may take the wrong side's depth; the glass's
absorption. What the port does to radiance besides geometry (the
``1/n_w^2`` of the basic radiance and the faces' Fresnel losses) is applied
apart: :meth:`aquaspec.optics.flat_port.FlatPort.radiance_factor`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import map_coordinates

from aquaspec.errors import AquaspecError

#: Fixed-point steps of the depth lookup; the change after 3 is below 0.01
#: pixel on smooth surfaces (a shift ``delta/z`` changes ``z`` by ``dz/dx``).
ITERATIONS = 3


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics in pixels (image y down, pixel centres at +0.5)."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @classmethod
    def of(cls, camera) -> "Intrinsics":
        """Those of anything with ``width, height, fx, fy, cx, cy`` (a Camera)."""
        return cls(int(camera.width), int(camera.height), float(camera.fx),
                   float(camera.fy), float(camera.cx), float(camera.cy))

    def tangents(self) -> tuple[np.ndarray, np.ndarray]:
        """``(tan_x, tan_y)`` of every pixel centre, each (H, W)."""
        j = np.arange(self.width) + 0.5
        i = np.arange(self.height) + 0.5
        tx = np.broadcast_to((j[None, :] - self.cx) / self.fx, (self.height, self.width))
        ty = np.broadcast_to((i[:, None] - self.cy) / self.fy, (self.height, self.width))
        return tx, ty


def water_intrinsics(sensor: Intrinsics, port, wavelength_nm, min_distance_m) -> Intrinsics:
    """The pinhole in water that holds every ray of ``port`` behind a camera
    of intrinsics ``sensor`` (same size and principal point, focal lengths
    divided by the port's :meth:`centre_ratio` over ``wavelength_nm``)."""
    ratio = port.centre_ratio(np.asarray(wavelength_nm, dtype=float), min_distance_m)
    return Intrinsics(sensor.width, sensor.height, sensor.fx / ratio, sensor.fy / ratio,
                      sensor.cx, sensor.cy)


def axial_depth(distance_m, water: Intrinsics) -> np.ndarray:
    """Axial depth z (m) of a pinhole G-buffer's ray distances (inf stays inf)."""
    tx, ty = water.tangents()
    return np.asarray(distance_m, dtype=float) / np.sqrt(1.0 + tx * tx + ty * ty)


def port_coordinates(port, sensor: Intrinsics, water: Intrinsics, wavelength_nm: float,
                     z_water=None) -> tuple[np.ndarray, np.ndarray]:
    """Where each sensor pixel's ray, at ``wavelength_nm``, meets the pinhole
    render's surface: ``(row, col)`` array coordinates in the water image
    (pixel centres at integers), each (H, W) of the sensor.

    ``z_water`` is the water image's axial depth (:func:`axial_depth`), or
    None for surfaces at infinity (the central mapping)."""
    tx, ty = sensor.tangents()
    rho = np.hypot(tx, ty)
    safe = np.where(rho > 0, rho, 1.0)
    ux, uy = np.where(rho > 0, tx / safe, 0.0), np.where(rho > 0, ty / safe, 0.0)
    tan_w, delta = port.water_ray(rho, wavelength_nm)

    def at(t):
        return water.cy + water.fy * t * uy - 0.5, water.cx + water.fx * t * ux - 0.5

    row, col = at(tan_w)
    if z_water is None:
        return row, col
    z_water = np.asarray(z_water, dtype=float)
    if z_water.shape != (water.height, water.width):
        raise AquaspecError(f"depth map of shape {z_water.shape}; the water image is "
                            f"{water.height}x{water.width}")
    for _ in range(ITERATIONS):
        r = np.clip(np.rint(row), 0, water.height - 1).astype(np.intp)
        c = np.clip(np.rint(col), 0, water.width - 1).astype(np.intp)
        z = z_water[r, c]
        finite = np.isfinite(z) & (z > 0)
        row, col = at(tan_w + np.where(finite, delta / np.where(finite, z, 1.0), 0.0))
    return row, col


def sample(image, row, col, *, order: int = 1) -> np.ndarray:
    """``image`` (H, W) or (H, W, k) read at ``(row, col)`` (bilinear for
    ``order=1``, nearest for 0; outside the image the edge value)."""
    img = np.asarray(image)
    if img.ndim == 2:
        return map_coordinates(img, [row, col], order=order, mode="nearest")
    return np.stack([map_coordinates(img[..., k], [row, col], order=order, mode="nearest")
                     for k in range(img.shape[-1])], axis=-1)


def port_image(image, wavelength_nm, port, sensor: Intrinsics, water: Intrinsics,
               z_water=None) -> np.ndarray:
    """The port's image: channel ``k`` of the water render ``image`` (H, W, k),
    at wavelength ``wavelength_nm[k]``, resampled where the port's rays of
    that wavelength meet the scene (:func:`port_coordinates`)."""
    img = np.asarray(image, dtype=float)
    wl = np.atleast_1d(np.asarray(wavelength_nm, dtype=float))
    if img.ndim != 3 or img.shape[-1] != wl.size:
        raise AquaspecError(f"image of shape {img.shape} with {wl.size} wavelengths; "
                            "accepted: (H, W, k) with one wavelength per channel")
    out = np.empty((sensor.height, sensor.width, wl.size))
    for k, lam in enumerate(wl):
        row, col = port_coordinates(port, sensor, water, float(lam), z_water)
        out[..., k] = sample(img[..., k], row, col)
    return out
