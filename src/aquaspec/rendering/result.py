"""What a render returns: the display image, the linear image and what else was asked."""

from __future__ import annotations

import io
import math
from dataclasses import dataclass, field

import numpy as np
from PIL import Image

from aquaspec.scene.gbuffer import GBuffer

#: Automatic exposure brightening the image by more than this many stops
#: beyond what the same light needs at the surface is worth a warning: 20
#: stops is about daylight to moonlight, beyond the range a camera's
#: exposure settings cover (a real camera would record black).
DARK_LIFT_EV = 20.0
#: The surface light at which auto exposure of a shallow scene is about 0 EV,
#: W/m^2 over 400-700 nm (measured -3.9 to -0.6 EV near the surface for the
#: built-in sensors, overcast, d65 and sun-sky); the lift of a render is its
#: EV plus log2(irradiance / this).
REFERENCE_IRRADIANCE_W_M2 = 100.0


@dataclass(repr=False)
class RenderResult:
    """What :func:`aquaspec.rendering.api.render` returns.

    In a notebook it shows as its display image (``_repr_png_``); ``repr``
    is a one-line summary.

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
    raw : ndarray (H, W, 3) uint16 or None
        With a camera model: the sensor's digital numbers, black level
        included (:mod:`aquaspec.rendering.camera_model`); ``linear_rgb`` is
        then that noisy frame as linear camera RGB.
    """

    display: np.ndarray
    linear_rgb: np.ndarray
    radiance: np.ndarray | None
    gbuffer: GBuffer | None
    params: dict = field(default_factory=dict)
    layers: dict | None = None
    raw: np.ndarray | None = None

    def __repr__(self) -> str:
        p = self.params
        height, width = np.shape(self.display)[:2]
        parts = [f"{width}x{height}"]
        if "water" in p:
            parts.append(f"water {p['water'].get('name')}")
        if "depth_m" in p:
            parts.append(f"depth {p['depth_m']:g} m")
        if "sensor" in p:
            parts.append(f"sensor {p['sensor'].get('name')}")
        if "bands" in p:
            parts.append(f"{p['bands'].get('n')} bands")
        if "ms_model" in p:
            parts.append(f"model {p['ms_model']}")
        ev = p.get("display", {}).get("exposure_ev")
        if ev is not None:
            parts.append(f"exposure {ev:+.2f} EV")
        return f"RenderResult({', '.join(parts)})"

    def _repr_png_(self) -> bytes:
        """The display image as PNG bytes (how Jupyter shows the result)."""
        buf = io.BytesIO()
        Image.fromarray(np.ascontiguousarray(self.display)).save(buf, format="PNG")
        return buf.getvalue()

    def warnings(self) -> list[str]:
        """What a user should know about the image: it is black (no light
        reached the camera), or auto exposure had to brighten it by more than
        :data:`DARK_LIFT_EV` stops beyond what the light needs at the surface."""
        p = self.params
        where = _where(p)
        if not np.any(np.asarray(self.linear_rgb) > 0):
            return [f"the image is black: no light reaches the camera{where} (the radiance "
                    "is below the floating-point range); a shallower depth or clearer water "
                    "shows the scene"]
        shown = p.get("display", {})
        ev = shown.get("exposure_ev")
        if shown.get("exposure_mode") != "auto" or ev is None:
            return []
        irradiance = p.get("light", {}).get("total_w_m2_400_700") or REFERENCE_IRRADIANCE_W_M2
        lift = ev + math.log2(irradiance / REFERENCE_IRRADIANCE_W_M2)
        if lift <= DARK_LIFT_EV:
            return []
        return [f"auto exposure brightened the image by {ev:+.1f} EV, {lift:.0f} stops more "
                f"than this light needs at the surface: almost no daylight reaches the "
                f"camera{where}, where a camera would record black; give a fixed exposure "
                "(--exposure EV, e.g. 0) to see it as dark as it is"]


def _where(params) -> str:
    """" at 1000 m in water IB" from a render's parameters (what is known of it)."""
    depth = params.get("depth_m")
    water = params.get("water", {}).get("name")
    return ((f" at {depth:g} m" if depth is not None else "")
            + (f" in water {water}" if water else ""))
