"""The lens: a thin lens's depth of field and its natural vignetting.

A thin lens of focal length ``f`` at f-number ``N`` (aperture diameter
``A = f / N``) focused on a point at distance ``z_f`` images a point at
distance ``z`` (both along the axis, in front of the lens; behind a port,
the port's *virtual* image distances) as a blur circle of diameter::

    c = A f |z - z_f| / (z (z_f - f))                                   (1)

on the sensor (the thin-lens equation ``1/f = 1/z + 1/z'`` and similar
triangles in the cone behind the lens; e.g. Potmesil & Chakravarty, "A
lens and aperture camera model for synthetic image generation", SIGGRAPH
1981, Eq. 6). In image pixels ``c / p`` with ``p = f / f_px`` the pixel's
size on the sensor for the camera's focal length ``f_px`` in pixels.

The blur is applied by gathering (:func:`defocus`): the image is blurred
with discs of a ladder of radii and each pixel takes its own radius's
blend of the two nearest. A gather does not model partial occlusion: at a
depth edge a blurred background takes in some of a sharp foreground
(a halo of a few pixels), and a blurred foreground does not spread over a
sharp background.

Natural vignetting (the ``cos^4`` law): the irradiance of a pixel whose
chief ray leaves the pupil at ``theta`` off axis falls as ``cos^4 theta``
(e.g. Kerr, "Derivation of the cos^4 law", 2007; Ray, *Applied Photographic
Optics*, 3rd ed., Sec. 9.5). Mechanical vignetting of real zooms is not
modelled.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError

#: Blur-circle radii (pixels) of the gather's ladder; larger are clamped.
RADII_PX = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 11.0, 16.0, 22.0, 32.0)
VIGNETTING_MODELS = ("cos4", "none")


@dataclass(frozen=True)
class ThinLens:
    """Focal length, aperture and focus of a thin lens.

    Parameters
    ----------
    focal_length_mm : float
    f_number : float
        ``N``: aperture diameter ``f / N`` (0.7 to 64).
    focus_distance_m : float
        The object distance in water the diver or the rig focused on, along
        the axis, m (the port turns it into the lens's virtual focus).
    transmittance : float
        The lens's transmission (0 to 1).
    vignetting : {"cos4", "none"}
    """

    focal_length_mm: float = 18.0
    f_number: float = 8.0
    focus_distance_m: float = 2.0
    transmittance: float = 0.9
    vignetting: str = "cos4"

    def __post_init__(self):
        for name, lo, hi in (("focal_length_mm", 1.0, 2000.0), ("f_number", 0.7, 64.0),
                             ("focus_distance_m", 0.05, 1e4), ("transmittance", 0.0, 1.0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not lo <= v <= hi:
                raise AquaspecError(f"lens {name}={v!r}; accepted: {lo:g} to {hi:g}")
        if self.vignetting not in VIGNETTING_MODELS:
            raise AquaspecError(f"vignetting {self.vignetting!r}; accepted: "
                                f"{', '.join(VIGNETTING_MODELS)}")

    def blur_diameter_px(self, z_m, z_focus_m: float, f_px: float) -> np.ndarray:
        """Eq. (1) in pixels of a camera of focal length ``f_px`` pixels;
        ``z_m`` may be inf (open water: the blur of infinity)."""
        f = self.focal_length_mm * 1e-3
        if not z_focus_m > f:
            raise AquaspecError(f"focus at {z_focus_m!r} m is inside the focal length "
                                f"({f:g} m); accepted: a focus distance beyond it")
        z = np.asarray(z_m, dtype=float)
        rel = np.where(np.isfinite(z), np.abs(1.0 - z_focus_m / np.where(np.isfinite(z), z,
                                                                          1.0)), 1.0)
        c = (f / self.f_number) * f / (z_focus_m - f) * rel
        return c * f_px / f

    def vignetting_factor(self, tan_x, tan_y) -> np.ndarray:
        """Relative irradiance of the pixels of chief-ray tangents ``tan_x, tan_y``."""
        if self.vignetting == "none":
            return np.ones(np.broadcast(tan_x, tan_y).shape)
        return 1.0 / (1.0 + np.asarray(tan_x) ** 2 + np.asarray(tan_y) ** 2) ** 2

    def describe(self) -> dict:
        return {"focal_length_mm": self.focal_length_mm, "f_number": self.f_number,
                "focus_distance_m": self.focus_distance_m,
                "transmittance": self.transmittance, "vignetting": self.vignetting,
                "depth_of_field": "thin lens, gathered disc blur (no partial occlusion)"}


def _disc(radius: float) -> np.ndarray:
    """A normalised disc kernel, its edge anti-aliased over one pixel."""
    n = int(np.ceil(radius + 1))
    y, x = np.mgrid[-n:n + 1, -n:n + 1]
    k = np.clip(radius + 0.5 - np.hypot(x, y), 0.0, 1.0)
    return k / k.sum()


def defocus(image, diameter_px) -> np.ndarray:
    """``image`` (H, W, k) blurred per pixel by a disc of diameter
    ``diameter_px`` (H, W), by gathering over :data:`RADII_PX`."""
    img = np.asarray(image, dtype=float)
    radius = np.clip(0.5 * np.asarray(diameter_px, dtype=float), 0.0, RADII_PX[-1])
    if radius.shape != img.shape[:2]:
        raise AquaspecError(f"blur map of shape {radius.shape} for an image of {img.shape}")
    top = int(np.searchsorted(RADII_PX, radius.max()))
    ladder = RADII_PX[:top + 1] if top < len(RADII_PX) else RADII_PX
    if len(ladder) == 1:
        return img.copy()
    pad = int(np.ceil(ladder[-1] + 1))
    padded = np.pad(img, ((pad, pad), (pad, pad), (0, 0)), mode="reflect")
    h, w = img.shape[:2]
    idx = np.clip(np.searchsorted(ladder, radius, side="right") - 1, 0, len(ladder) - 2)
    steps = np.asarray(ladder)
    t = np.clip((radius - steps[idx]) / (steps[idx + 1] - steps[idx]), 0.0, 1.0)
    # Each level is added with its weight in the blend of the two levels
    # around a pixel's radius, so only one blurred image is held at a time.
    out = np.where(idx == 0, 1.0 - t, 0.0)[..., None] * img
    shape = padded.shape[:2]
    spectrum = np.fft.rfft2(padded, axes=(0, 1))
    for k, r in enumerate(ladder[1:], start=1):
        weight = np.where(idx == k, 1.0 - t, 0.0) + np.where(idx == k - 1, t, 0.0)
        if not weight.any():
            continue
        # The disc centred on the origin of a periodic grid: a circular
        # convolution, exact inside the reflected border of ``pad`` pixels.
        kernel = _disc(r)
        n = kernel.shape[0] // 2
        grid = np.zeros(shape)
        grid[:n + 1, :n + 1] = kernel[n:, n:]
        grid[:n + 1, -n:] = kernel[n:, :n]
        grid[-n:, :n + 1] = kernel[:n, n:]
        grid[-n:, -n:] = kernel[:n, :n]
        blurred = np.fft.irfft2(spectrum * np.fft.rfft2(grid)[..., None], s=shape, axes=(0, 1))
        out += weight[..., None] * blurred[pad:pad + h, pad:pad + w]
    return out
