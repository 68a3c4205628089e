"""What a render returns: the display image, the linear image and what else was asked."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from aquaspec.scene.gbuffer import GBuffer


@dataclass
class RenderResult:
    """What :func:`aquaspec.rendering.api.render` returns.

    Attributes
    ----------
    display : ndarray (H, W, 3) uint8
        sRGB-encoded, exposed and tone-mapped image.
    linear_rgb : ndarray (H, W, 3) float
        Linear camera RGB (see :func:`aquaspec.colour.sensors.radiance_to_rgb`).
    radiance : ndarray (H, W, n) or None
        Band radiance, W m^-2 sr^-1 nm^-1, when asked for.
    gbuffer : GBuffer
    params : dict
        Every parameter of the render (for sidecars).
    layers : dict or None
        With ``layers=True``: the image-formation layers
        (:mod:`aquaspec.rendering.layers`: backscatter, direct, surface, albedo,
        transmission, range_m).
    """

    display: np.ndarray
    linear_rgb: np.ndarray
    radiance: np.ndarray | None
    gbuffer: GBuffer | None
    params: dict = field(default_factory=dict)
    layers: dict | None = None
