"""The forward cone: its default angle, and its light's exact spread over the image.

Scattering within ``forward_cone_deg`` of forward counts as unscattered along
camera rays that end on a surface (``lightfield_tables(forward_cone_deg=...)``,
:meth:`aquaspec.transport.lightfield.tables.LightfieldTables.pixel_radiance`).
That light comes from where the cone points in the image, not from the
pixel's own surface: :func:`cone_spread_kernel` is its image-space kernel and
:func:`spread_cone_light` the exact convolution, the reference of the image
pyramid the renderer uses (:mod:`aquaspec.transport.lightfield.conespread`).
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.transport.lightfield.tables import ConeTables

#: Forward cone (degrees) used without / with the cone spread over the image:
#: 15 was best for the per-pixel cone (HG 0.92, 10-20 tried); with the spread
#: 40 was best in the Fournier-Forand validation at 4096 samples per pixel
#: (30 and 40 tried: grey +5.8 % and +4.0 %, patches +1.7 % and -0.1 %).
DEFAULT_FORWARD_CONE_DEG = 15.0
SPREAD_FORWARD_CONE_DEG = 40.0

#: Samples of the cone-offset CDF in the tables (geometric towards 0).
CONE_OFFSET_SAMPLES = 256


def forward_cone(cone_deg, cone_spread: bool) -> float:
    """``cone_deg``, or the default for the model (None: 15, or 40 with the spread)."""
    if cone_deg is None:
        return SPREAD_FORWARD_CONE_DEG if cone_spread else DEFAULT_FORWARD_CONE_DEG
    return float(cone_deg)


def cone_offsets(forward_cone_deg: float) -> np.ndarray:
    """The offsets (rad) at which the tables hold the cone's CDF: 0, then
    :data:`CONE_OFFSET_SAMPLES` - 1 geometric up to the cone's half angle."""
    return np.radians(forward_cone_deg) * np.concatenate(
        [[0.0], np.geomspace(1e-5, 1.0, CONE_OFFSET_SAMPLES - 1)])


def cone_spread_kernel(offsets_rad, cdf, pixels_per_radian: float,
                       subsamples: int = 8) -> np.ndarray:
    """The image-space kernel of the forward cone's light, (2r + 1, 2r + 1), summing to 1.

    ``cdf`` is ``P(alpha <= offsets_rad)`` for one band (the apparent angular
    offset, :func:`aquaspec.medium.phase_bands.band_cone_offset_cdf`), radially symmetric,
    turned into pixels with ``pixels_per_radian`` (the camera's ``fy``: the
    small-angle scale at the image centre). Each pixel cell gets the
    density ``F'(r) / (2 pi r)`` integrated on ``subsamples`` x
    ``subsamples`` points; the centre cell gets the rest (the density is
    singular at 0, and most of a forward-peaked cone's light stays in its
    own pixel).
    """
    off = np.asarray(offsets_rad, dtype=float) * float(pixels_per_radian)   # in pixels
    cdf = np.asarray(cdf, dtype=float)
    if not (pixels_per_radian > 0 and np.all(np.diff(off) > 0)):
        raise AquaspecError(f"pixels_per_radian={pixels_per_radian!r}; accepted: > 0")
    r_max = off[-1]
    rad = int(np.ceil(r_max))
    # Density per unit area as a function of radius: dF/dr / (2 pi r), from
    # the CDF's differences (piecewise constant between samples).
    dens = np.diff(cdf) / (np.pi * (off[1:] ** 2 - off[:-1] ** 2))
    sub = (np.arange(subsamples) + 0.5) / subsamples - 0.5
    ax = np.arange(-rad, rad + 1, dtype=float)
    x = (ax[:, None] + sub[None, :]).reshape(-1)
    r = np.hypot(x[:, None], x[None, :])
    k = np.searchsorted(off, r, side="right") - 1
    inside = (k >= 0) & (k < dens.size)
    w = np.where(inside, dens[np.clip(k, 0, dens.size - 1)], 0.0)
    n = ax.size
    kern = w.reshape(n, subsamples, n, subsamples).mean(axis=(1, 3))
    kern[rad, rad] = 0.0
    kern[rad, rad] = max(0.0, 1.0 - kern.sum())
    return kern / kern.sum()


def spread_cone_light(cone_term, cone: ConeTables, pixels_per_radian: float) -> np.ndarray:
    """Convolve the per-pixel forward-cone term (H, W, n) with each band's kernel.

    ``cone``: the light-field tables'
    :attr:`~aquaspec.transport.lightfield.tables.LightfieldTables.cone`. The
    image is extended beyond its border with its edge values (the scene goes
    on past the frame) before the convolution.
    """
    # (Only this exact reference, the tests' yardstick for the pyramid, convolves.)
    # deferred: scipy.signal takes about a second to import
    from scipy.signal import fftconvolve
    c = np.asarray(cone_term, dtype=float)
    out = np.empty_like(c)
    cdf = np.asarray(cone.offset_cdf, dtype=float)
    offsets = np.asarray(cone.offset_rad, dtype=float)
    kernels = {}
    for i in range(c.shape[-1]):
        key = cdf[i].tobytes()
        if key not in kernels:
            kernels[key] = cone_spread_kernel(offsets, cdf[i], pixels_per_radian)
        kern = kernels[key]
        rad = kern.shape[0] // 2
        padded = np.pad(c[..., i], rad, mode="edge")
        out[..., i] = fftconvolve(padded, kern, mode="valid")
    return out
