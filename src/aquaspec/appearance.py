"""Everyday answers without rendering an image.

"What colour is water X at depth Y for camera Z?": the camera RGB of open
water seen horizontally and of a grey card facing the camera, from the
NumPy model (:mod:`aquaspec.model`).
"""

from __future__ import annotations

import numpy as np

from . import model
from .bands import Bands
from .errors import AquaspecError
from .light import SurfaceLight, surface_light
from .sensors import Sensor
from .water import Water

GREY_CARD_REFLECTANCE = 0.18


def check_depth(depth_m, name="depth", what="below the surface"):
    """Validate a depth below the surface (or another length, ``name`` metres
    ``what``) in metres (>= 0, finite)."""
    try:
        d = float(depth_m)
    except (TypeError, ValueError):
        raise AquaspecError(f"{name} {depth_m!r} is not a number; give metres {what} "
                            "(>= 0)") from None
    if not np.isfinite(d) or d < 0:
        raise AquaspecError(f"{name} {depth_m!r} m is not accepted; give metres {what}, "
                            ">= 0 and finite")
    return d


def check_ms_model(name):
    if name not in model.MS_MODELS:
        raise AquaspecError(f"unknown multiple-scattering model {name!r}; known: "
                            f"{', '.join(model.MS_MODELS)}")
    return name


def check_distance(distance_m):
    d = check_depth(distance_m, "distance", "from the camera")
    if d <= 0:
        raise AquaspecError(f"distance {distance_m!r} m must be > 0")
    return d


def water_colour(water: Water, sensor: Sensor, bands: Bands, *, depth_m: float,
                 distance_m: float, light: SurfaceLight | None = None,
                 ambient: str = model.DEFAULT_AMBIENT, outside: str = "error",
                 ms_model: str = model.DEFAULT_MS_MODEL, phase: str = "petzold",
                 forward_cone_deg: float = 15.0) -> dict:
    """Camera RGB of open water (horizontal view) and of a grey card at ``distance_m``.

    ``ms_model`` picks the multiple-scattering model
    (:data:`aquaspec.model.MS_MODELS`): ``"seeds"`` (thesis Eq. 4.7 with the
    database Kd and ``ambient``) or ``"lightfield"`` (the discrete-ordinates
    light field of :mod:`aquaspec.lightfield` with phase function ``phase``).

    Returns a dict with ``water_rgb``, ``grey_card_rgb`` (linear camera RGB,
    lists of 3 floats) and every parameter used.
    """
    depth = check_depth(depth_m)
    dist = check_distance(distance_m)
    light = light or surface_light("overcast")
    bw = water.on_bands(bands)
    e0 = light.on_bands(bands)
    weights = sensor.band_weights(bands, outside=outside)
    check_ms_model(ms_model)
    if ms_model == "seeds":
        def radiance(**kw):
            return model.pixel_radiance(a=bw.a, b=bw.b, kd=bw.kd, e0=e0, depth_o=depth,
                                        v_y=0.0, ambient=ambient, **kw)
    else:
        from .lightfield import lightfield_pixel_radiance, lightfield_tables
        tables = lightfield_tables(bw, phase=phase, forward_cone_deg=forward_cone_deg)

        def radiance(**kw):
            return lightfield_pixel_radiance(tables, a=bw.a, b=bw.b, e0=e0, depth_o=depth,
                                             v_y=np.zeros(1), **kw)
    water_l = radiance(s=np.inf)
    card_l = radiance(s=dist, rho=GREY_CARD_REFLECTANCE, surface_depth=np.full(1, depth),
                      n_y=np.zeros(1))
    out = {
        "water_rgb": model.radiance_to_rgb(water_l, weights).tolist(),
        "grey_card_rgb": model.radiance_to_rgb(card_l, weights).tolist(),
        "units": "linear camera RGB: sum over bands of width_nm * radiance (W m^-2 sr^-1 nm^-1)"
                 " * band-averaged response",
        "water": water.describe(),
        "depth_m": depth,
        "distance_m": dist,
        "view": "horizontal",
        "grey_card_reflectance": GREY_CARD_REFLECTANCE,
        "sensor": sensor.describe(),
        "bands": bands.describe(),
        "light": light.describe(),
        "ms_model": ms_model,
        **({"ambient_model": ambient} if ms_model == "seeds"
           else {"phase": phase, "forward_cone_deg": forward_cone_deg}),
    }
    if not all(np.isfinite(out["water_rgb"]) & np.isfinite(out["grey_card_rgb"])):
        raise AquaspecError("the model produced a non-finite colour; please report this input")
    return out
