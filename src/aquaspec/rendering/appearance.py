"""Everyday answers without rendering an image.

"What colour is water X at depth Y for camera Z?": the camera RGB of open
water (seen horizontally, or along any view) and of a grey card facing the
camera, from the NumPy models the renderer uses (:mod:`aquaspec.transport.monzon2022`,
:mod:`aquaspec.transport.lightfield.solve`, :mod:`aquaspec.transport.sun_scattering`).
"""

from __future__ import annotations

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import Sensor
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import SurfaceLight, surface_light
from aquaspec.colour.sensors import radiance_to_rgb
from aquaspec.light.sun import surface_irradiance
from aquaspec.medium.water import Water
from aquaspec.rendering.setup import SpectralSetup, render_surface
from aquaspec.scene.camera import Camera, camera_depth
from aquaspec.transport import monzon2022 as model
from aquaspec.transport.models import DEFAULT_MS_MODEL, MONZON2022, ms_model_name
from aquaspec.transport.sun_scattering import phase_from_log_table, single_scattering_open

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
    """The canonical name of a multiple-scattering model
    (:func:`aquaspec.transport.models.ms_model_name`)."""
    return ms_model_name(name)


def check_distance(distance_m):
    d = check_depth(distance_m, "distance", "from the camera")
    if d <= 0:
        raise AquaspecError(f"distance {distance_m!r} m must be > 0")
    return d


#: The horizontal view of ``aquaspec colour``: along -z, the direction sun
#: azimuths are measured from (azimuth 0 puts the sun ahead, 180 behind).
HORIZONTAL_VIEW = (0.0, 0.0, -1.0)


def check_view(view) -> np.ndarray:
    """A view direction (3,), normalised; any non-zero finite vector."""
    try:
        v = np.asarray(view, dtype=float).reshape(3)
    except (TypeError, ValueError):
        raise AquaspecError(f"view direction {view!r} is not accepted; give three numbers "
                            "(x, y, z), y up") from None
    norm = float(np.linalg.norm(v))
    if not np.isfinite(norm) or norm == 0.0:
        raise AquaspecError(f"view direction {view!r} is not accepted; give a non-zero, "
                            "finite (x, y, z), y up")
    return v / norm


def view_from_elevation(elevation_deg) -> np.ndarray:
    """The view ``elevation_deg`` above the horizontal (-90 straight down ..
    90 straight up), in the vertical plane of :data:`HORIZONTAL_VIEW`."""
    try:
        e = float(elevation_deg)
    except (TypeError, ValueError):
        raise AquaspecError(f"view elevation {elevation_deg!r} is not a number; give "
                            "degrees from -90 (down) to 90 (up)") from None
    if not -90.0 <= e <= 90.0:
        raise AquaspecError(f"view elevation {elevation_deg!r} degrees is not accepted; "
                            "give -90 (down) to 90 (up)")
    r = np.radians(e)
    return np.array([0.0, np.sin(r), -np.cos(r)])


def water_colour(water: Water, sensor: Sensor, bands: Bands, *, depth_m: float,
                 distance_m: float, light: SurfaceLight | None = None,
                 ambient: str = model.DEFAULT_AMBIENT, outside: str = "error",
                 ms_model: str = DEFAULT_MS_MODEL, phase: str = "petzold",
                 forward_cone_deg: float = 15.0, view=HORIZONTAL_VIEW,
                 surface: str | None = None) -> dict:
    """Camera RGB of open water and of a grey card at ``distance_m``, seen along ``view``.

    ``ms_model`` picks the multiple-scattering model
    (:data:`aquaspec.transport.models.MS_MODELS`): ``"monzon2022"`` (alias ``"seeds"``;
    thesis Eq. 4.7 with the
    database Kd and ``ambient``) or ``"lightfield"`` (the discrete-ordinates
    light field of :mod:`aquaspec.transport.lightfield.solve` with phase function ``phase``).
    ``view`` (3,), y up, defaults to the horizontal :data:`HORIZONTAL_VIEW`;
    the card faces the camera. A light with a sun (``sun-sky``) is treated as
    the renderer treats it (:func:`colour_of_setup`). ``surface``: as
    :func:`aquaspec.rendering.api.render`'s (None: the flat surface with the
    light field, :func:`aquaspec.rendering.setup.render_surface`).

    Returns a dict with ``water_rgb``, ``grey_card_rgb`` (linear camera RGB,
    lists of 3 floats) and every parameter used.
    """
    check_ms_model(ms_model)
    setup = SpectralSetup(water, sensor, light or surface_light("overcast"), bands,
                          ambient=ambient, outside=outside, ms_model=ms_model, phase=phase,
                          forward_cone_deg=forward_cone_deg, cone_spread=False,
                          surface=render_surface(surface, ms_model))
    return colour_of_setup(setup, depth_m=depth_m, distance_m=distance_m, view=view)


def colour_of_setup(setup, *, depth_m: float, distance_m: float,
                    view=HORIZONTAL_VIEW) -> dict:
    """:func:`water_colour` for a :class:`aquaspec.rendering.setup.SpectralSetup`:
    what its renderer gives one open-water ray and one grey card.

    From a camera at ``depth_m`` looking along ``view``:

    - open water: the model's radiance of the ray to infinity (or to the
      water surface when it looks up);
    - an 18 % grey card ``distance_m`` along the ray, facing the camera
      (normal ``-view``), at depth ``depth_m - distance_m view_y``.

    With a sun (``setup.light.sun``) both get what the renderer adds
    (:mod:`aquaspec.light.sun`): the beam scattered once along the ray, with the
    phase function at the angle between the beam and the view, and on the
    card the beam itself, ``rho/pi E_b(d) max(0, n . l) exp(-c S)``; the
    light field's tables are then those of the sky and the sun's diffuse
    light. Nothing shadows the sun and the surface is flat here (no caustics).
    """
    depth = check_depth(depth_m)
    dist = check_distance(distance_m)
    v = check_view(view)
    v_y = float(v[1])
    card_depth = depth - dist * v_y
    if card_depth < 0:
        raise AquaspecError(f"a card {dist:g} m along the view (up component {v_y:.3g}) from "
                            f"{depth:g} m would be above the water surface; accepted: a "
                            "shorter distance, a flatter view or a deeper camera")
    bw = setup.water.on_bands(setup.bands)
    e0 = setup.e0_on_bands()
    weights = setup.sensor.band_weights(setup.bands, outside=setup.outside)
    tables = setup.lightfield_tables()
    if tables is None:
        def radiance(**kw):
            return model.pixel_radiance(a=bw.a, b=bw.b, kd=bw.kd, e0=e0, depth_o=depth,
                                        v_y=np.full(1, v_y), ambient=setup.ambient, **kw)
    else:
        def radiance(**kw):
            return tables.pixel_radiance(a=bw.a, b=bw.b, e0=e0, depth_o=depth,
                                         v_y=np.full(1, v_y), **kw)
    water_l = radiance(s=np.inf)
    card_l = radiance(s=dist, rho=GREY_CARD_REFLECTANCE, surface_depth=np.full(1, card_depth),
                      n_y=np.full(1, -v_y))
    sun_part = {}
    sun = setup.sun_inputs()
    if sun is not None:
        def scattered(s):
            return single_scattering_open(
                b=sun.b, phase_value=phase_from_log_table(sun.log_phase, v @ sun.to_sun),
                beam0=sun.beam0, c_sun=sun.c_sun, c_view=sun.c_view, depth_o=depth,
                v_y=v_y, s=s, mu0=sun.mu0)
        water_sun = scattered(np.inf)
        card_sun = scattered(dist) + GREY_CARD_REFLECTANCE / np.pi * surface_irradiance(
            sun.beam0, sun.c_sun, card_depth, -v, sun.to_sun) * np.exp(-sun.c_view * dist)
        water_l = water_l + water_sun
        card_l = card_l + card_sun
        sun_part = {"sun_part": {
            "water_rgb": radiance_to_rgb(water_sun, weights).tolist(),
            "grey_card_rgb": radiance_to_rgb(card_sun, weights).tolist(),
            "what": "the sun's beam scattered once along the ray, and on the card the beam "
                    "itself (included in water_rgb and grey_card_rgb)"}}
    out = {
        "water_rgb": radiance_to_rgb(water_l, weights).tolist(),
        "grey_card_rgb": radiance_to_rgb(card_l, weights).tolist(),
        "units": "linear camera RGB: sum over bands of width_nm * radiance (W m^-2 sr^-1 nm^-1)"
                 " * band-averaged response",
        "water": setup.water.describe(),
        "depth_m": depth,
        "distance_m": dist,
        "view_direction": v.tolist(),
        "view_elevation_deg": float(np.degrees(np.arcsin(np.clip(v_y, -1.0, 1.0)))),
        "grey_card_depth_m": card_depth,
        "grey_card_reflectance": GREY_CARD_REFLECTANCE,
        "sensor": setup.sensor.describe(),
        "bands": setup.bands.describe(),
        "light": setup.light.describe(),
        "ms_model": setup.ms_model,
        **({"ambient_model": setup.ambient} if setup.ms_model == MONZON2022
           else {"phase": setup.phase, **dict(setup.phase_params),
                 "forward_cone_deg": setup.cone_deg, "cone_spread": setup.cone_spread}),
        **sun_part,
    }
    if not all(np.isfinite(out["water_rgb"]) & np.isfinite(out["grey_card_rgb"])):
        raise AquaspecError("the model produced a non-finite colour; please report this input")
    return out


#: Distance of the grey card used as reference by ``white_balance="white-patch"``.
WHITE_CARD_DISTANCE_M = 1.0


def white_card(camera: Camera) -> dict:
    """Where ``white_balance="white-patch"``'s grey card is: the diver's custom
    white balance, a card held :data:`WHITE_CARD_DISTANCE_M` in front of the
    camera along its view, facing it (keyword arguments of
    :func:`aquaspec.rendering.appearance.colour_of_setup`). Where that would be above
    the water (a camera near the surface looking up) the card is held level
    with the camera instead, in the view's compass direction."""
    depth = camera_depth(camera)
    view = np.asarray(camera.forward, dtype=float)
    if depth - WHITE_CARD_DISTANCE_M * view[1] < 0:
        flat = np.array([view[0], 0.0, view[2]])
        norm = np.linalg.norm(flat)
        view = flat / norm if norm > 1e-6 else np.array([0.0, 0.0, -1.0])
    return {"depth_m": depth, "distance_m": WHITE_CARD_DISTANCE_M, "view": view}
