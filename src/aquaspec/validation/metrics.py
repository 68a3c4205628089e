"""Image error metrics between a reference and a test rendering.

- :func:`rmse`: root-mean-square error of linear camera RGB, also relative
  to the reference's mean.
- :func:`hsv_distance`: the thesis's colour metric (Monzon 2022, section
  6.1): both colours go to HSV, hue and saturation are mapped to the plane
  as ``(S cos H, S sin H)`` (value ignored, since exposure can compensate
  brightness) and the Euclidean distance is taken; 0 (same hue and
  saturation) to 2.
- :func:`ssim`: structural similarity (Wang, Bovik, Sheikh, Simoncelli, IEEE
  TIP 13(4), 2004) on a luminance-like channel, Gaussian window
  (sigma 1.5), K1 = 0.01, K2 = 0.03, data range of the reference.
- :func:`ciede2000`: CIE Delta E 2000 after a common display transform
  (same exposure and colour matrix for both, clipped to the sRGB gamut),
  via colour-science.

Each takes (..., 3) arrays and an optional boolean mask.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter

from aquaspec.errors import AquaspecError


def _pair(ref, test, mask=None):
    ref = np.asarray(ref, dtype=float)
    test = np.asarray(test, dtype=float)
    if ref.shape != test.shape or ref.shape[-1] != 3:
        raise AquaspecError(f"images must have the same (..., 3) shape; got {ref.shape} and "
                            f"{test.shape}")
    if mask is not None:
        mask = np.asarray(mask, dtype=bool)
        if not mask.any():
            raise AquaspecError("the metric mask selects no pixel")
        ref, test = ref[mask], test[mask]
    return ref.reshape(-1, 3), test.reshape(-1, 3)


def rmse(ref, test, mask=None) -> dict:
    """``{"rmse": ..., "rmse_rel": rmse / mean(ref)}`` over pixels and channels."""
    r, t = _pair(ref, test, mask)
    e = float(np.sqrt(np.mean((r - t) ** 2)))
    return {"rmse": e, "rmse_rel": e / max(float(np.mean(np.abs(r))), 1e-300)}


def rgb_to_hsv(rgb):
    """HSV of RGB (..., 3) with hue in radians; negatives clipped to 0 first."""
    rgb = np.clip(np.asarray(rgb, dtype=float), 0.0, None)
    mx = rgb.max(axis=-1)
    mn = rgb.min(axis=-1)
    delta = mx - mn
    safe = np.where(delta > 0, delta, 1.0)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    h = np.where(mx == r, ((g - b) / safe) % 6, np.where(mx == g, (b - r) / safe + 2,
                                                           (r - g) / safe + 4))
    h = np.where(delta > 0, h * (np.pi / 3), 0.0)
    s = np.where(mx > 0, delta / np.where(mx > 0, mx, 1.0), 0.0)
    return np.stack([h, s, mx], axis=-1)


def hsv_distance(ref, test, mask=None) -> float:
    """Mean over pixels of ``|(S cos H, S sin H)_ref - (S cos H, S sin H)_test|``."""
    r, t = _pair(ref, test, mask)
    hr, ht = rgb_to_hsv(r), rgb_to_hsv(t)
    pr = np.stack([hr[:, 1] * np.cos(hr[:, 0]), hr[:, 1] * np.sin(hr[:, 0])], axis=1)
    pt = np.stack([ht[:, 1] * np.cos(ht[:, 0]), ht[:, 1] * np.sin(ht[:, 0])], axis=1)
    return float(np.linalg.norm(pr - pt, axis=1).mean())


def hue_difference_deg(ref, test, mask=None) -> float:
    """Mean absolute hue difference in degrees (on the circle)."""
    r, t = _pair(ref, test, mask)
    d = np.abs(rgb_to_hsv(r)[:, 0] - rgb_to_hsv(t)[:, 0]) % (2 * np.pi)
    return float(np.degrees(np.minimum(d, 2 * np.pi - d)).mean())


def ssim(ref, test, *, sigma: float = 1.5) -> float:
    """Mean SSIM of the channel-mean images (both (H, W, 3))."""
    ref = np.asarray(ref, dtype=float)
    test = np.asarray(test, dtype=float)
    if ref.shape != test.shape or ref.ndim != 3:
        raise AquaspecError(f"SSIM needs two (H, W, 3) images of the same shape; got "
                            f"{ref.shape} and {test.shape}")
    x, y = ref.mean(axis=-1), test.mean(axis=-1)
    rng = float(x.max() - x.min()) or 1.0
    c1, c2 = (0.01 * rng) ** 2, (0.03 * rng) ** 2
    mx, my = gaussian_filter(x, sigma), gaussian_filter(y, sigma)
    sxx = gaussian_filter(x * x, sigma) - mx * mx
    syy = gaussian_filter(y * y, sigma) - my * my
    sxy = gaussian_filter(x * y, sigma) - mx * my
    s = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2))
    return float(s.mean())


def display_lab(rgb, *, scale: float, matrix=None):
    """CIE Lab (D65) of camera RGB after the common display transform.

    ``rgb * scale``, then ``matrix`` (camera RGB -> linear sRGB), clipped to
    [0, 1], read as linear sRGB.
    """
    import colour  # deferred: colour-science takes 1.2-1.5 s to import; only the metrics need it
    x = np.asarray(rgb, dtype=float) * scale
    if matrix is not None:
        x = x @ np.asarray(matrix, dtype=float).T
    x = np.clip(x, 0.0, 1.0)
    xyz = colour.RGB_to_XYZ(x, colour.RGB_COLOURSPACES["sRGB"], apply_cctf_decoding=False)
    return colour.XYZ_to_Lab(xyz, colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])


def ciede2000(ref, test, mask=None, *, matrix=None) -> float:
    """Mean CIEDE2000 after a common display transform.

    The exposure maps the reference's 99th-percentile channel value to 0.9;
    the same scale and colour matrix are applied to both images.
    """
    import colour  # deferred: colour-science takes 1.2-1.5 s to import; only the metrics need it
    r, t = _pair(ref, test, mask)
    scale = 0.9 / max(float(np.percentile(r, 99)), 1e-300)
    de = colour.delta_E(display_lab(r, scale=scale, matrix=matrix),
                        display_lab(t, scale=scale, matrix=matrix), method="CIE 2000")
    return float(np.mean(de))


def all_metrics(ref, test, mask=None, *, matrix=None) -> dict:
    """RMSE (absolute and relative), HSV distance, hue difference, CIEDE2000."""
    out = rmse(ref, test, mask)
    out["hsv"] = hsv_distance(ref, test, mask)
    out["hue_deg"] = hue_difference_deg(ref, test, mask)
    out["ciede2000"] = ciede2000(ref, test, mask, matrix=matrix)
    r, t = _pair(ref, test, mask)
    out["mean_ratio"] = float(t.mean() / max(r.mean(), 1e-300))
    return out
