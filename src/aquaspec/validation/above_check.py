"""The sea seen from above: aquaspec against the path tracer (issue 30).

The scene: a camera :data:`HEIGHT_M` above the flat sea looking down at
:data:`PITCH_DEG` below the horizon (field of view :data:`FOV_DEG`), over
deep water or a grey Lambertian seabed (reflectance :data:`SEABED_ALBEDO`)
at 3 or 10 m, under an overcast sky. Both renderers get the same water
(a, b and phase function) and the same sky *above* the surface:

- the reference (Mitsuba 3, :func:`aquaspec.validation.reference.scene_dict`
  with ``surface="flat"``): a smooth ``dielectric`` water surface, the
  camera in air (no medium), a uniform sky of radiance ``E_sky / pi``, the
  seabed a large ``diffuse`` square inside the water;
- aquaspec: :func:`aquaspec.shading.above_water.sea_from_above` on the flat
  surface's light-field tables, with the seabed as their lower boundary, and
  ``E0 = t_d E_sky / s`` below the surface
  (:mod:`aquaspec.validation.window_check` explains it).

Compared: the mean camera RGB over the image (ratio per channel, the
relative error of the mean colour ``|rgb - rgb_ref| / |rgb_ref|``, and the
hue difference) and per band.

With the sun (``sun_elevation_deg``; SPECTRL2's sun and sky, the sun at
:data:`SUN_AZIMUTH_DEG`) the reference is
:mod:`aquaspec.validation.slab_mc`'s Monte Carlo instead: a directional sun
cannot reach the water through Mitsuba's smooth dielectric in
``volpathmis`` (SPEC). That estimator agrees with Mitsuba wherever Mitsuba
can render the same thing (tests/validation/test_slab_mc.py). The sun's
glint is left out of both (a delta in the reference); aquaspec's
``E0`` is the setup's own (:meth:`aquaspec.rendering.setup.SpectralSetup.e0_on_bands`),
the reference's sky and sun are the light's in air.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.reflectance import Reflectance
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import surface_light
from aquaspec.medium.interface import refract
from aquaspec.medium.water import load_water
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import Camera, camera_above
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.scene.seabed import Seabed
from aquaspec.light.sky import SKY_TRANSMITTANCE
from aquaspec.shading.above_meshes import water_to_hits
from aquaspec.shading.above_water import e0_below, sea_from_above, sky_shape, sun_in_air
from aquaspec.validation import metrics
from aquaspec.validation.reference import (REFERENCE_BANDS, bands_to_rgb, lightfield_phase,
                                           phase_function, require_mitsuba, scene_dict)
from aquaspec.validation.slab_mc import sea_radiance_mc

#: The camera's height above the sea (m), pitch below the horizon and field of view (degrees).
HEIGHT_M = 5.0
PITCH_DEG = 60.0
FOV_DEG = 30.0
#: The grey seabed's reflectance.
SEABED_ALBEDO = 0.2
#: Half-size of the seabed square in the reference (m): beyond the camera's view.
SEABED_HALF_M = 200.0
PHASES = ("isotropic", "petzold")
#: The sun's azimuth in the checks with a sun (behind the camera's right shoulder).
SUN_AZIMUTH_DEG = 150.0
#: Paths of the Monte Carlo reference per band, and the forward angle it
#: counts as unscattered (:class:`aquaspec.validation.slab_mc.PhaseSampler`).
MC_PATHS, MC_TRUNCATE_DEG = 60_000, 3.0


def above_camera(size: int = 48, height_m: float = HEIGHT_M,
                 pitch_deg: float = PITCH_DEG) -> Camera:
    """A square camera ``height_m`` above the sea looking down at ``pitch_deg``
    (towards -z): :func:`aquaspec.scene.camera.camera_above` at this check's
    field of view."""
    return camera_above(height_m, pitch_deg, width=size, height=size, fov_y_deg=FOV_DEG)


def _seabed_scene(depth_m, camera) -> Scene:
    """The reference's seabed: a grey square at ``depth_m`` (none: no mesh)."""
    if depth_m is None:
        return Scene(meshes=[], materials=[], camera=camera)
    h, y = SEABED_HALF_M, -float(depth_m)
    quad = Mesh(np.array([[-h, y, -h], [h, y, -h], [h, y, h], [-h, y, h]]),
                np.array([[0, 2, 1], [0, 3, 2]]), np.tile([0.0, 1.0, 0.0], (4, 1)), 0)
    return Scene(meshes=[quad], materials=[Reflectance.constant(SEABED_ALBEDO)], camera=camera)


def reference_from_above(camera, water, sky, *, seabed_depth_m, phase, spp, seed=0,
                         bands: Bands = REFERENCE_BANDS) -> dict:
    """Mitsuba's band radiance (H, W, n) with the camera in air above the
    dielectric sea, and the seconds it took."""
    mi = require_mitsuba()
    with tempfile.TemporaryDirectory(prefix="aquaspec-above-") as tmp:
        d = scene_dict(_seabed_scene(seabed_depth_m, camera), camera, water, sky, spp=spp,
                       mesh_dir=tmp, bands=bands, phase=phase, surface="flat")
        d["sensor"].pop("medium")                     # the camera is in air
        t0 = time.perf_counter()
        img = np.array(mi.render(mi.load_dict(d), seed=seed), dtype=np.float64)
        seconds = time.perf_counter() - t0
    if not np.all(np.isfinite(img)):
        raise AquaspecError("the reference render contains NaN or infinity")
    return {"band_radiance": img.reshape(camera.height, camera.width, bands.n),
            "seconds": seconds}


def aquaspec_from_above(camera, water, sky, *, seabed_depth_m, phase,
                        bands: Bands = REFERENCE_BANDS):
    """aquaspec's band radiance (H, W, n) from above, with ``E0`` from the sky
    above the sea, and that ``E0``."""
    method, params = lightfield_phase(phase)
    bed = None if seabed_depth_m is None else Seabed(float(seabed_depth_m), SEABED_ALBEDO)
    setup = SpectralSetup(water, get_sensor("human"), sky, bands, surface="flat",
                          phase=method, phase_params=params, seabed=bed)
    tables = setup.lightfield_tables()
    e0 = e0_below(tables, sky.on_bands(bands))
    med = setup.medium([])
    return sea_from_above(camera, tables, a=med["a"], b=med["b"], e0=e0), e0


def sun_from_above(camera, water, light, *, seabed_depth_m, phase, bands: Bands = REFERENCE_BANDS,
                   paths: int = MC_PATHS, seed: int = 0,
                   truncate_deg: float = MC_TRUNCATE_DEG) -> dict:
    """With the sun: aquaspec's band radiance (H, W, n) without the glint,
    and the Monte Carlo reference's mean band radiance over the same rays
    (n,) with its standard error, and the seconds it took."""
    method, params = lightfield_phase(phase)
    bed = None if seabed_depth_m is None else Seabed(float(seabed_depth_m), SEABED_ALBEDO)
    setup = SpectralSetup(water, get_sensor("human"), light, bands, surface="flat",
                          phase=method, phase_params=params, seabed=bed)
    med, sun = setup.medium([]), setup.sun_inputs()
    aq = sea_from_above(camera, setup.lightfield_tables(), a=med["a"], b=med["b"],
                        e0=med["e0"], sun=sun, glint=False)
    to_air, beam_air = sun_in_air(sun)
    t0 = time.perf_counter()
    ref = sea_radiance_mc(camera.ray_directions().reshape(-1, 3), a=med["a"], b=med["b"],
                          phase=phase_function(phase),
                          sky_radiance=light.sky_on(bands) / (SKY_TRANSMITTANCE * np.pi),
                          sun_to_air=to_air, sun_beam_air=beam_air,
                          seabed_depth_m=seabed_depth_m, seabed_albedo=SEABED_ALBEDO,
                          paths=paths, seed=seed, truncate_deg=truncate_deg,
                          sky_shape=sky_shape(sun))
    return {"aquaspec": aq, "e0": med["e0"], "reference_mean": ref["mean"],
            "reference_standard_error": ref["standard_error"],
            "seconds": time.perf_counter() - t0}


def compare_above(water: str = "IB", *, seabed_depth_m=None, phase: str = "isotropic",
                  size: int = 48, spp: int = 256, sensors=("human",), seed: int = 0,
                  bands: Bands = REFERENCE_BANDS, sun_elevation_deg=None,
                  paths: int = MC_PATHS, truncate_deg: float = MC_TRUNCATE_DEG) -> dict:
    """aquaspec's sea from above against the path tracer (module docstring):
    per sensor the ratio of the image's mean camera RGB (aquaspec /
    reference), the relative error of that mean colour and its hue
    difference; the band ratios; the band images (with the sun: aquaspec's
    image and the reference's mean, from ``paths`` Monte Carlo paths per
    band)."""
    if phase not in PHASES:
        raise AquaspecError(f"phase {phase!r}; accepted: {', '.join(PHASES)}")
    w = load_water(water)
    cam = above_camera(size)
    out = {"water": water, "seabed_depth_m": seabed_depth_m, "phase": phase, "size": size}
    if sun_elevation_deg is None:
        sky = surface_light("overcast")
        ref = reference_from_above(cam, w, sky, seabed_depth_m=seabed_depth_m, phase=phase,
                                   spp=spp, seed=seed, bands=bands)
        aq, e0 = aquaspec_from_above(cam, w, sky, seabed_depth_m=seabed_depth_m, phase=phase,
                                     bands=bands)
        ref_l = ref["band_radiance"]
        out.update(spp=spp, reference_seconds=ref["seconds"], reference="mitsuba")
    else:
        light = surface_light("sun-sky", sun_elevation_deg=float(sun_elevation_deg),
                              sun_azimuth_deg=SUN_AZIMUTH_DEG)
        r = sun_from_above(cam, w, light, seabed_depth_m=seabed_depth_m, phase=phase,
                           bands=bands, paths=paths, seed=seed, truncate_deg=truncate_deg)
        aq, e0, ref_l = r["aquaspec"], r["e0"], r["reference_mean"][None, None, :]
        out.update(paths=paths, reference_seconds=r["seconds"], reference="slab Monte Carlo",
                   sun_elevation_deg=float(sun_elevation_deg),
                   reference_standard_error=r["reference_standard_error"])
    out.update(e0=e0, aquaspec=aq, reference_image=ref_l,
               band_ratio=aq.reshape(-1, bands.n).mean(0) / ref_l.reshape(-1, bands.n).mean(0))
    for s in sensors:
        sensor = get_sensor(s) if isinstance(s, str) else s
        rm = bands_to_rgb(ref_l, sensor, bands).reshape(-1, 3).mean(axis=0)
        am = bands_to_rgb(aq, sensor, bands).reshape(-1, 3).mean(axis=0)
        out[sensor.name] = {"ratio_rgb": am / rm,
                            "rgb_error": float(np.linalg.norm(am - rm) / np.linalg.norm(rm)),
                            "hue_deg": metrics.hue_difference_deg(rm[None], am[None])}
    return out


#: The box of :func:`compare_box_above`: half-sizes (x, y, z) in m and reflectance.
BOX_HALF_M, BOX_ALBEDO = (0.5, 0.4, 0.5), 0.6


def box_scene(depth_m: float, camera) -> tuple[Scene, np.ndarray]:
    """A grey box (:data:`BOX_HALF_M`, :data:`BOX_ALBEDO`) standing on the
    seabed at ``depth_m`` where ``camera``'s centre ray, refracted by the flat
    surface, meets it; ``(the box alone, its centre)``."""
    v = camera.forward / np.linalg.norm(camera.forward)
    entry = camera.position + v * (camera.position[1] / -v[1])
    t, _ = refract(v[None], np.array([[0.0, 1.0, 0.0]]))
    t = t[0]
    floor = entry + t * (depth_m / -t[1])
    hx, hy, hz = BOX_HALF_M
    centre = floor + np.array([0.0, hy, 0.0])
    corners = np.array([[x, y, z] for y in (-1, 1) for z in (-1, 1) for x in (-1, 1)], float)
    verts = centre + corners * np.array([hx, hy, hz])
    # Each face outward (counter-clockwise seen from outside).
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    meshes = []
    for q in quads:
        p = verts[list(q)]
        n = np.cross(p[1] - p[0], p[2] - p[0])
        n /= np.linalg.norm(n)
        meshes.append(Mesh(p, np.array([[0, 1, 2], [0, 2, 3]]), np.tile(n, (4, 1)), 0))
    return Scene(meshes=meshes, materials=[Reflectance.constant(BOX_ALBEDO)], camera=camera), \
        centre


def compare_box_above(water: str = "IB", *, seabed_depth_m: float = 3.0,
                      phase: str = "isotropic", size: int = 48, spp: int = 256, seed: int = 0,
                      bands: Bands = REFERENCE_BANDS, sensor: str = "human",
                      spread_scattering: str = "single") -> dict:
    """A mesh under the water seen from above against the path tracer: a grey
    box on the grey seabed (:func:`box_scene`) under an overcast sky, the
    camera as in :func:`compare_above`; aquaspec's meshes seen through the
    surface (:func:`aquaspec.shading.above_meshes.water_to_hits`) against
    Mitsuba with the box and the seabed square as geometry. Per region
    (the pixels that see the box, the rest): the mean camera RGB's ratio,
    relative error and hue difference. ``spread_scattering``: the forward
    cone's light spread as scattered once or many times (the light field's
    setting, :class:`aquaspec.rendering.setup.SpectralSetup`)."""
    if phase not in PHASES:
        raise AquaspecError(f"phase {phase!r}; accepted: {', '.join(PHASES)}")
    w = load_water(water)
    cam = above_camera(size)
    box, centre = box_scene(seabed_depth_m, cam)
    sky = surface_light("overcast")
    both = _seabed_scene(seabed_depth_m, cam)
    both = Scene(meshes=list(both.meshes) + [dataclasses.replace(m, material=1)
                                             for m in box.meshes],
                 materials=list(both.materials) + list(box.materials), camera=cam)
    mi = require_mitsuba()
    with tempfile.TemporaryDirectory(prefix="aquaspec-box-") as tmp:
        d = scene_dict(both, cam, w, sky, spp=spp, mesh_dir=tmp, bands=bands, phase=phase,
                       surface="flat")
        d["sensor"].pop("medium")                     # the camera is in air
        t0 = time.perf_counter()
        ref = np.array(mi.render(mi.load_dict(d), seed=seed), dtype=np.float64)
        seconds = time.perf_counter() - t0
    ref = ref.reshape(cam.height, cam.width, bands.n)
    method, params = lightfield_phase(phase)
    setup = SpectralSetup(w, get_sensor("human"), sky, bands, surface="flat", phase=method,
                          phase_params=params, spread_scattering=spread_scattering,
                          seabed=Seabed(float(seabed_depth_m), SEABED_ALBEDO))
    tables = setup.lightfield_tables()
    e0 = e0_below(tables, sky.on_bands(bands))
    med = setup.medium(box.materials)
    under = water_to_hits(box, cam, tables, a=med["a"], b=med["b"], e0=e0,
                          material_bands=med["material_bands"],
                          sigmoid_centers_t=med["sigmoid_centers_t"])
    aq = sea_from_above(cam, tables, a=med["a"], b=med["b"], e0=e0, under=under)
    s = get_sensor(sensor)
    out = {"water": water, "phase": phase, "seabed_depth_m": seabed_depth_m, "size": size,
           "spread_scattering": spread_scattering,
           "spp": spp, "reference_seconds": seconds, "box_centre_m": centre.tolist(),
           "box_pixels": int(under[0].sum()), "aquaspec": aq, "reference_image": ref}
    rgb_ref, rgb_aq = bands_to_rgb(ref, s, bands), bands_to_rgb(aq, s, bands)
    for name, mask in (("box", under[0]), ("around", ~under[0])):
        rm, am = rgb_ref[mask].mean(axis=0), rgb_aq[mask].mean(axis=0)
        out[name] = {"ratio_rgb": am / rm,
                     "rgb_error": float(np.linalg.norm(am - rm) / np.linalg.norm(rm)),
                     "hue_deg": metrics.hue_difference_deg(rm[None], am[None])}
    return out
