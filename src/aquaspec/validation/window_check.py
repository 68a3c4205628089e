"""Snell's window seen from below: aquaspec's flat surface against the path tracer.

The scene (issue 30's first acceptance line): open water, a camera at
``depth_m`` looking straight up with a field of view wide enough for the
whole window (its half-angle is 48.75 degrees at n = 1.33) and the mirrored
water around it. Both renderers get the same water (a, b and phase function) and the same overcast
sky *above* the surface:

- the reference (:func:`aquaspec.validation.reference.render_reference`,
  ``surface="flat"``): a smooth Mitsuba ``dielectric`` water surface (air
  above, n = 1.33 below), a uniform sky of radiance ``E_sky / pi`` in air;
- aquaspec (``SpectralSetup(surface="flat")``, the NumPy reference of the
  GPU passes): its input is the downwelling irradiance just below the
  surface, ``E0``, which under that sky is ``E0 = t_d E_sky / s`` with
  ``t_d`` the share of a uniform sky that the surface lets in
  (:func:`aquaspec.medium.interface.diffuse_transmittance`, 0.934) and ``s``
  the sky's share of ``E0`` in aquaspec's own light field (the rest is the
  water's light that the surface mirrors back down,
  :meth:`~aquaspec.transport.lightfield.tables.LightfieldTables.sky_share`).

The image is split by the angle from the zenith: *inside* the window (up
component ``v_y`` more than :data:`EDGE_MARGIN` above the window's cosine),
*outside* it (more than the margin below: the water below, mirrored by
total internal reflection), and the *edge* itself is found in both images
as the steepest drop of the radiance along the centre row. Compared per
region: the mean band radiance and camera RGB (ratio aquaspec / reference
per channel, hue difference). Optionally (``meter_spp``) the reference's
``E0`` is measured too, with an irradiance meter just below its surface
(:func:`aquaspec.validation.meters.measure_downwelling`), and compared with
the ``E0`` aquaspec predicts.

:func:`compare_mirror` checks the scene mirrored in the surface from below
(:mod:`aquaspec.shading.below_mirror`): a bright box near the surface seen
by total internal reflection, the same surface and sky.
"""

from __future__ import annotations

import time

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.reflectance import Reflectance
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import surface_light
from aquaspec.medium.interface import snell_window_cos
from aquaspec.medium.water import load_water
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import Camera
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.scene.raycast import raycast_gbuffer
from aquaspec.shading.above_water import e0_below
from aquaspec.shading.below_mirror import mirror_hits, mirrored_camera, scene_in_mirror
from aquaspec.shading.shade import shade_gbuffer
from aquaspec.validation import metrics
from aquaspec.validation.meters import measure_downwelling
from aquaspec.validation.reference import (REFERENCE_BANDS, bands_to_rgb, lightfield_phase,
                                           render_reference)
from aquaspec.validation.scenes import cuboid

#: The camera's depth (m) and field of view (degrees, square image).
DEPTH_M = 5.0
FOV_DEG = 120.0
#: Pixels within this much of the window's cosine (in ``v_y``) are neither
#: inside nor outside (the edge is a pixel wide; a pixel's footprint spans it).
EDGE_MARGIN = 0.05
#: Phase functions this check takes (the reference's names).
PHASES = ("isotropic", "petzold")


def up_camera(depth_m: float = DEPTH_M, size: int = 64, fov_deg: float = FOV_DEG) -> Camera:
    """A square camera at ``depth_m`` looking straight up (image top towards -z)."""
    if not depth_m > 0:
        raise AquaspecError(f"depth {depth_m!r} m; the camera must be under water (> 0 m)")
    p = np.array([0.0, -float(depth_m), 0.0])
    return Camera.look_at(p, p + [0.0, 1.0, 0.0], width=size, height=size, fov_y_deg=fov_deg,
                          up=(0.0, 0.0, -1.0))


def open_water(camera: Camera) -> Scene:
    """Open water for the G-buffer: one small grey square 20 m below the
    camera, out of its view (a scene needs a mesh)."""
    y = float(camera.position[1]) - 20.0
    quad = Mesh(np.array([[-1.0, y, -1.0], [1.0, y, -1.0], [1.0, y, 1.0], [-1.0, y, 1.0]]),
                np.array([[0, 2, 1], [0, 3, 2]]), np.tile([0.0, 1.0, 0.0], (4, 1)), 0)
    return Scene(meshes=[quad], materials=[Reflectance.constant(0.2)], camera=camera)


def regions(camera: Camera, margin: float = EDGE_MARGIN) -> dict:
    """Boolean masks ``inside``, ``outside`` (of Snell's window) and
    ``zenith`` (within 18 degrees of straight up)."""
    v_y = camera.ray_directions()[..., 1]
    edge = snell_window_cos()
    return {"inside": v_y > edge + margin, "outside": (v_y < edge - margin) & (v_y > 0),
            "zenith": v_y > np.cos(np.radians(18.0))}


def edge_column(radiance_row) -> float:
    """Where the radiance along a row drops fastest, in pixels (sub-pixel:
    the midpoint between the two pixels of the steepest step), on the
    row's left half."""
    row = np.asarray(radiance_row, dtype=float)
    half = row[: row.size // 2]
    step = np.diff(half)
    k = int(np.argmax(step))                   # rising from outside (left) to inside
    return k + 0.5 + 0.5                        # pixel centres at k + 0.5 and k + 1.5


def snell_edge_column(camera: Camera) -> float:
    """Where Snell's window's edge crosses the centre row, in pixels from the left."""
    theta_c = np.arccos(snell_window_cos())
    return camera.cx - camera.fx * np.tan(theta_c)


def aquaspec_radiance(camera: Camera, water, sky, phase: str, bands: Bands = REFERENCE_BANDS):
    """aquaspec's band radiance (H, W, n) under the flat surface, with ``E0``
    from the sky above it (module docstring), and that ``E0`` (n,)."""
    method, params = lightfield_phase(phase)
    setup = SpectralSetup(water, get_sensor("human"), sky, bands, surface="flat",
                          phase=method, phase_params=params)
    tables = setup.lightfield_tables()
    e_sky = sky.on_bands(bands)
    e0 = e0_below(tables, e_sky)
    scene = open_water(camera)
    gb = raycast_gbuffer(scene, camera)
    med = setup.medium(gb.materials)
    med["e0"] = e0
    out = shade_gbuffer(gb, **med, return_radiance=True, lightfield=tables)
    return out["radiance"], e0


def compare_window(water: str = "IB", *, depth_m: float = DEPTH_M, phase: str = "isotropic",
                   size: int = 64, spp: int = 256, sensors=("human",), seed: int = 0,
                   meter_spp: int = 0, bands: Bands = REFERENCE_BANDS) -> dict:
    """aquaspec's flat surface seen from below against the path tracer.

    Returns per region (:func:`regions`) and sensor the ratios aquaspec /
    reference of the mean camera RGB and their hue difference (degrees), the
    mean band-radiance ratios per region, the window's edge (column along the
    centre row) in both images and where Snell puts it, both band images, and
    with ``meter_spp`` > 0 the reference's measured ``E0`` beside aquaspec's.
    ``sensors``: names or :class:`aquaspec.colour.sensors.Sensor` objects.
    """
    if phase not in PHASES:
        raise AquaspecError(f"phase {phase!r}; accepted: {', '.join(PHASES)}")
    w = load_water(water)
    sky = surface_light("overcast")
    cam = up_camera(depth_m, size)
    t0 = time.perf_counter()
    ref = render_reference(open_water(cam), cam, w, sky, spp=spp, seed=seed, bands=bands,
                           phase=phase, surface="flat")
    t_ref = time.perf_counter() - t0
    aq, e0 = aquaspec_radiance(cam, w, sky, phase, bands)
    ref_l = ref["band_radiance"]
    masks = regions(cam)
    out = {"water": water, "depth_m": float(depth_m), "phase": phase, "size": size, "spp": spp,
           "reference_seconds": t_ref, "e0": e0, "bands": bands.describe(),
           "aquaspec": aq, "reference": ref_l, "regions": {}}
    row = cam.height // 2
    out["edge_px"] = {"snell": float(snell_edge_column(cam)),
                      "aquaspec": edge_column(aq[row].sum(axis=-1)),
                      "reference": edge_column(ref_l[row].sum(axis=-1))}
    for name, m in masks.items():
        reg = {"pixels": int(m.sum()),
               "band_ratio": (aq[m].mean(axis=0) / np.maximum(ref_l[m].mean(axis=0), 1e-300))}
        for s in sensors:
            sensor = get_sensor(s) if isinstance(s, str) else s
            rr, ra = bands_to_rgb(ref_l, sensor, bands)[m], bands_to_rgb(aq, sensor, bands)[m]
            rm, am = rr.mean(axis=0), ra.mean(axis=0)
            reg[sensor.name] = {"ratio_rgb": am / np.maximum(np.abs(rm), 1e-300) * np.sign(rm),
                                "brightness_ratio": float(am.sum() / rm.sum()),
                                "hue_deg": metrics.hue_difference_deg(rm[None], am[None])}
        out["regions"][name] = reg
    if meter_spp > 0:
        meter = measure_downwelling(w, sky, depths_m=[0.005], spp=meter_spp, bands=bands,
                                    phase=phase, seed=seed + 1, surface="flat")[0]
        out["e0_reference"] = meter
        out["e0_ratio"] = e0 / meter
    return out


def level_camera(depth_m: float = DEPTH_M, size: int = 32, fov_deg: float = 60.0) -> Camera:
    """A square camera at ``depth_m`` looking level (towards -z)."""
    p = np.array([0.0, -float(depth_m), 0.0])
    return Camera.look_at(p, p + [0.0, 0.0, -1.0], width=size, height=size, fov_y_deg=fov_deg)


def compare_level(water: str = "IB", *, depth_m: float = DEPTH_M, phase: str = "petzold",
                  size: int = 32, spp: int = 512, sensors=("nikon-5100-npl",), seed: int = 0,
                  bands: Bands = REFERENCE_BANDS) -> dict:
    """Open water seen level under the flat surface against the path tracer:
    per band of rows (``top``, ``middle``, ``bottom`` quarters) and sensor
    the ratio aquaspec / reference of the mean camera RGB. This is the view
    where the surface changes most (the sky no longer shines in at grazing
    angles)."""
    if phase not in PHASES:
        raise AquaspecError(f"phase {phase!r}; accepted: {', '.join(PHASES)}")
    w, sky = load_water(water), surface_light("overcast")
    cam = level_camera(depth_m, size)
    ref = render_reference(open_water(cam), cam, w, sky, spp=spp, seed=seed, bands=bands,
                           phase=phase, surface="flat")["band_radiance"]
    aq, _ = aquaspec_radiance(cam, w, sky, phase, bands)
    q = size // 4
    rows = {"top": slice(0, q), "middle": slice(size // 2 - q // 2, size // 2 + q // 2),
            "bottom": slice(size - q, size)}
    out = {"water": water, "phase": phase, "size": size, "spp": spp, "rows": {}}
    for name, r in rows.items():
        out["rows"][name] = {}
        for s in sensors:
            sensor = get_sensor(s) if isinstance(s, str) else s
            rm = bands_to_rgb(ref[r], sensor, bands).reshape(-1, 3).mean(axis=0)
            am = bands_to_rgb(aq[r], sensor, bands).reshape(-1, 3).mean(axis=0)
            out["rows"][name][sensor.name] = am / rm
    return out


#: The mirror check's box (corners, m) and its reflectance; the camera's depth,
#: pitch above level and field of view (degrees): the box is seen directly and,
#: above it, by total internal reflection outside Snell's window.
MIRROR_BOX = ((-1.2, -1.0, -11.0), (1.2, -0.3, -8.0))
MIRROR_BOX_RHO = 0.9
MIRROR_DEPTH_M, MIRROR_PITCH_DEG, MIRROR_FOV_DEG = 3.0, 18.0, 40.0


def mirror_scene(camera: Camera) -> Scene:
    """The bright box of :data:`MIRROR_BOX` (material 0) in open water."""
    return Scene(meshes=[cuboid(*MIRROR_BOX, 0, "box")],
                 materials=[Reflectance.constant(MIRROR_BOX_RHO)], camera=camera)


def compare_mirror(water: str = "IB", *, phase: str = "isotropic", size=(48, 32),
                   spp: int = 256, seed: int = 0, bands: Bands = REFERENCE_BANDS,
                   pitch_deg: float = MIRROR_PITCH_DEG, fov_deg: float = MIRROR_FOV_DEG) -> dict:
    """The box mirrored in the flat surface from below against the path
    tracer: per region the mean band radiance over all bands, aquaspec /
    reference, with the scene's mirror (``mirrored``) and with the open
    water's mirror it replaces (``open_water_mirror``). Regions: ``box_mirror``
    (pixels whose mirrored ray meets the box, eroded by a pixel), ``box``
    (the box seen directly, eroded), ``water_mirror`` (the rest looking up,
    open water mirrored); a region with no pixels is left out. ``pitch_deg``,
    ``fov_deg``: the camera's pitch above level and vertical field of view."""
    if phase not in PHASES:
        raise AquaspecError(f"phase {phase!r}; accepted: {', '.join(PHASES)}")
    w, sky = load_water(water), surface_light("overcast")
    width, height = size
    p = np.array([0.0, -MIRROR_DEPTH_M, 0.0])
    t = np.radians(pitch_deg)
    cam = Camera.look_at(p, p + [0.0, np.sin(t), -np.cos(t)], width=width, height=height,
                         fov_y_deg=fov_deg)
    scene = mirror_scene(cam)
    t0 = time.perf_counter()
    ref = render_reference(scene, cam, w, sky, spp=spp, seed=seed, bands=bands, phase=phase,
                           surface="flat")["band_radiance"]
    t_ref = time.perf_counter() - t0
    method, params = lightfield_phase(phase)
    setup = SpectralSetup(w, get_sensor("human"), sky, bands, surface="flat", phase=method,
                          phase_params=params)
    tables = setup.lightfield_tables()
    gb = raycast_gbuffer(scene, cam)
    med = setup.medium(gb.materials)
    med["e0"] = e0_below(tables, sky.on_bands(bands))
    plain = shade_gbuffer(gb, **med, return_radiance=True, lightfield=tables)["radiance"]
    v = cam.ray_directions()
    open_up = (v[..., 1] > 0) & ~np.isfinite(gb.distance)
    mirror_gb = raycast_gbuffer(scene, mirrored_camera(cam))
    aq = plain + scene_in_mirror(cam, open_up, mirror_gb, tables,
                                 **{k: med[k] for k in ("a", "b", "e0", "material_bands",
                                                        "sigmoid_centers_t")})
    hits = mirror_hits(cam, open_up, mirror_gb).mask
    masks = {"box_mirror": _eroded(hits), "box": _eroded(np.isfinite(gb.distance)),
             "water_mirror": _eroded(open_up & ~hits)}
    out = {"water": water, "phase": phase, "size": [width, height], "spp": spp,
           "reference_seconds": t_ref, "bands": bands.describe(), "regions": {},
           "aquaspec": aq, "reference": ref}
    for name, m in masks.items():
        if not m.any():
            continue
        r = float(ref[m].mean())
        out["regions"][name] = {"pixels": int(m.sum()), "mirrored": float(aq[m].mean()) / r,
                                "open_water_mirror": float(plain[m].mean()) / r}
    return out


def _eroded(mask) -> np.ndarray:
    """``mask`` less its pixels with a 4-neighbour outside it (edges mix in a pixel)."""
    m = np.asarray(mask, dtype=bool)
    out = m.copy()
    out[1:] &= m[:-1]
    out[:-1] &= m[1:]
    out[:, 1:] &= m[:, :-1]
    out[:, :-1] &= m[:, 1:]
    out[0], out[-1], out[:, 0], out[:, -1] = False, False, False, False
    return out
