"""Irradiance measured in the path-traced water: Kd from meters, plates.

Kd is also measured in the path-traced water (:func:`measure_kd`):
irradiance meters facing up at several depths, fitted per band by a
log-linear least-squares fit, so the analytic model can be run with the Kd
of exactly the water the path tracer sees. A path tracer's irradiance meter
never receives a delta (directional) emitter's light unscattered: its rays
reach the sun only by next-event estimation at scattering events. With a
sun the meters therefore measure the sky's light and the sun's scattered
light, and the unscattered beam, ``mu0 * beam_normal * exp(-c d / mu0)``
exactly in a homogeneous medium, is added in closed form on the medium's
own spectra (:func:`direct_sun_irradiance`); tests check the sum against
horizontal white Lambertian plates, whose next-event estimation does see the
sun.
"""

from __future__ import annotations

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import SurfaceLight
from aquaspec.medium.water import Water
from aquaspec.validation.reference import (FF_DEFAULT_BACKSCATTER, MAX_DEPTH, REFERENCE_BANDS,
                                           base_scene, check_range, film, water_medium,
                                           medium_spectra, require_mitsuba)


def direct_sun_irradiance(water: Water, light: SurfaceLight, depths_m,
                          bands: Bands = REFERENCE_BANDS) -> np.ndarray:
    """The sun's unscattered horizontal irradiance at depth, per band, (n_depths, n).

    ``mu0 * beam_normal(lambda) * exp(-c(lambda) d / mu0)`` averaged over each
    band on a 0.05 nm grid, with ``c`` exactly as handed to Mitsuba
    (:func:`medium_spectra`) and the beam linear between its wavelengths (as
    Mitsuba's ``irregular`` spectrum). Zero without a sun.
    """
    depths = np.atleast_1d(np.asarray(depths_m, dtype=float))
    if light.sun is None:
        return np.zeros((depths.size, bands.n))
    sun = light.sun
    fine = np.arange(bands.lo_nm, bands.hi_nm + 1e-9, 0.05)
    mwl, c, _ = medium_spectra(water)
    c_f = np.interp(fine, mwl, c)
    beam = np.interp(fine, sun.wavelength_nm, sun.beam_normal)
    vals = sun.mu0 * beam[None, :] * np.exp(-c_f[None, :] * depths[:, None] / sun.mu0)
    return bands.average(fine, vals, name="direct sun")


def measure_downwelling(water: Water, light: SurfaceLight, *, depths_m, spp: int = 100_000,
                        bands: Bands = REFERENCE_BANDS, phase: str = "isotropic", g: float = 0.0,
                        seed: int = 0, backscatter: float = FF_DEFAULT_BACKSCATTER,
                        surface: str = "index-matched") -> np.ndarray:
    """What irradiance meters facing up read in the path-traced water,
    (n_depths, n) per band: a 2 cm square cosine collector (Mitsuba's
    ``irradiancemeter`` on a ``null`` rectangle) at each depth, ``spp``
    samples. A meter never receives a directional sun's unscattered beam
    (:func:`measure_kd` adds it). ``surface``: the water surface
    (:func:`aquaspec.validation.reference.surface_bsdf`); under the flat one
    a meter just below it reads the light the interface lets through plus
    the water's own light it mirrors back down.
    """
    mi = require_mitsuba()
    check_range(water, light, bands)
    depths = np.atleast_1d(np.asarray(depths_m, dtype=float))
    if np.any(depths <= 0):
        raise AquaspecError(f"depths {depths.tolist()}: meters go below the surface (> 0 m)")
    T = mi.ScalarTransform4f
    e_d = []
    for i, depth in enumerate(depths):
        d = base_scene(water, light, phase, g, backscatter, surface=surface)
        d["meter"] = {
            "type": "rectangle",
            "to_world": T().translate([0.0, -float(depth), 0.0]).rotate([1, 0, 0], -90).scale(0.01),
            "bsdf": {"type": "null"},
            "interior": {"type": "ref", "id": "water_medium"},
            "exterior": {"type": "ref", "id": "water_medium"},
            # The meter's own medium: a copy of the water (a reference here is
            # refused by Mitsuba for sensors attached to shapes).
            "sensor": {"type": "irradiancemeter", "film": film(bands, 1, 1),
                       "sampler": {"type": "independent", "sample_count": int(spp)},
                       "medium": water_medium(water, phase, g, backscatter)},
        }
        img = np.array(mi.render(mi.load_dict(d), seed=seed + i), dtype=np.float64)
        e_d.append(img.reshape(bands.n))
    return np.array(e_d)


def measure_kd(water: Water, light: SurfaceLight, *, depths_m=(1.0, 2.0, 3.0, 4.0, 5.0, 6.0),
               spp: int = 100_000, bands: Bands = REFERENCE_BANDS, phase: str = "isotropic",
               g: float = 0.0, seed: int = 0,
               backscatter: float = FF_DEFAULT_BACKSCATTER) -> dict:
    """Kd(lambda) of the path-traced water, from irradiance meters facing up.

    Returns ``depths_m``, ``e_d`` (n_depths, n) downwelling irradiance per
    band, ``kd`` (n,) from a least-squares fit of ``ln E_d`` against depth,
    and ``kd_stderr`` (n,), the fit's standard error. The water (and the
    meters' copy of it) has the phase function of :func:`render_reference`.

    With a sun (``light.sun``) ``e_d`` is the whole downwelling irradiance:
    the meters' reading (the sky's light, scattered or not, and the sun's
    scattered light; a meter never receives the delta emitter's unscattered
    beam) plus the unscattered beam in closed form
    (:func:`direct_sun_irradiance`), which is also returned as
    ``e_d_direct`` (zeros without a sun).
    """
    depths = np.asarray(depths_m, dtype=float)
    if depths.size < 2 or np.any(depths <= 0):
        raise AquaspecError(f"depths {depths.tolist()} must be at least two positive depths")
    e_d = measure_downwelling(water, light, depths_m=depths, spp=spp, bands=bands, phase=phase,
                              g=g, seed=seed, backscatter=backscatter)
    e_direct = direct_sun_irradiance(water, light, depths, bands)
    e_d = e_d + e_direct
    if np.any(e_d <= 0):
        raise AquaspecError("an irradiance meter received no light; use more samples or "
                            "shallower depths")
    y = np.log(e_d)
    A = np.stack([np.ones_like(depths), -depths], axis=1)
    coef, res, *_ = np.linalg.lstsq(A, y, rcond=None)
    kd = coef[1]
    dof = max(1, depths.size - 2)
    resid = y - A @ coef
    s2 = (resid ** 2).sum(axis=0) / dof
    se = np.sqrt(s2 / ((depths - depths.mean()) ** 2).sum())
    return {"depths_m": depths, "e_d": e_d, "e_d_direct": e_direct, "kd": kd, "kd_stderr": se,
            "bands": bands}


def measure_plate(water: Water, light: SurfaceLight, *, depths_m, albedo: float = 1.0,
                  spp: int = 20_000, bands: Bands = REFERENCE_BANDS, phase: str = "isotropic",
                  g: float = 0.0, seed: int = 0, backscatter: float = FF_DEFAULT_BACKSCATTER,
                  max_depth: int = MAX_DEPTH, size_m: float = 0.02,
                  above_m: float = 0.01) -> np.ndarray:
    """Radiance of horizontal Lambertian plates in the path-traced water, (n_depths, n).

    At each depth a ``size_m`` square plate facing up (``diffuse``, reflectance
    ``albedo``) and a ``radiancemeter`` ``above_m`` above its centre looking
    straight down; per band the plate's radiance, ``albedo / pi`` times the
    irradiance on its top, times ``exp(-c above_m)`` on the way up (not
    removed here: 1 cm of water). Unlike an irradiance meter, the plate
    receives a directional sun by next-event estimation, so
    ``pi L / albedo`` measures the whole downwelling irradiance, sun's beam
    included (a cosine collector).
    """
    mi = require_mitsuba()
    check_range(water, light, bands)
    T = mi.ScalarTransform4f
    out = []
    for i, depth in enumerate(np.atleast_1d(np.asarray(depths_m, dtype=float))):
        d = base_scene(water, light, phase, g, backscatter, max_depth)
        d["plate"] = {
            "type": "rectangle",
            "to_world": T().translate([0.0, -float(depth), 0.0]).rotate([1, 0, 0], -90).scale(
                size_m / 2),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum",
                                                         "value": float(albedo)}}}
        d["meter"] = {"type": "radiancemeter",
                      "origin": [0.0, -float(depth) + above_m, 0.0], "direction": [0.0, -1.0, 0.0],
                      "film": film(bands, 1, 1),
                      "sampler": {"type": "independent", "sample_count": int(spp)},
                      "medium": {"type": "ref", "id": "water_medium"}}
        img = np.array(mi.render(mi.load_dict(d), seed=seed + i), dtype=np.float64)
        out.append(img.reshape(bands.n))
    return np.array(out)


def water_with_kd(water: Water, kd_bands: np.ndarray, bands: Bands = REFERENCE_BANDS) -> Water:
    """``water`` with its Kd replaced by per-band values (e.g. measured), as a Water."""
    centres = bands.centers_nm
    wl = np.concatenate([[bands.lo_nm], centres, [bands.hi_nm]])
    kd = np.concatenate([[kd_bands[0]], kd_bands, [kd_bands[-1]]])
    a = np.interp(wl, water.wavelength_nm, water.a)
    b = np.interp(wl, water.wavelength_nm, water.b)
    return Water(name=water.name, source=water.source + " (Kd measured in the reference)",
                 wavelength_nm=wl, a=a, b=b, kd=np.maximum(kd, 0.0), kd_derived=True,
                 notes=water.notes, citation=water.citation)
