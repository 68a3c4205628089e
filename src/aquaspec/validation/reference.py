"""The reference: the same scene path-traced spectrally by Mitsuba 3.

The scene is built with ``mi.load_dict`` from aquaspec's own objects: the
meshes (written as PLY), their reflectance spectra (``diffuse`` BSDFs with
irregular spectra), the water's a and b (a ``homogeneous`` medium filling a
2 km x 1 km box whose top face is the water surface y = 0; the box has a
``null`` BSDF, so light enters without refraction, and no exterior medium),
the camera (inside the medium), and the sky (a ``constant`` environment of
radiance E_sky / pi, so that the sky's downwelling irradiance just below the
surface is E_sky). Without a sun (``overcast``, ``d65``) E_sky is the
light's whole E0; with one (``sun-sky``, :attr:`SurfaceLight.sun`) it is
E0 minus the sun's share ``mu0 * beam_normal`` (:func:`sky_irradiance`),
and the sun is a Mitsuba ``directional`` emitter (:func:`sun_emitter`)
whose ``direction`` is the refracted beam's way of travel under water and
whose ``irradiance`` is ``beam_normal``, the irradiance on a plane normal
to the beam (Mitsuba's ``directional``: "spectral power per unit area
received by a hypothetical surface normal to the specified direction";
``direction``: "direction towards which the emitter is radiating"). The
surface does not refract, so the emitter is given the underwater direction:
the beam in the water is the refracted one, the sky is seen at every angle
(not through Snell's window). The water's phase function (:data:`PHASES`,
:func:`reference_phase`) is Mitsuba's ``isotropic``, ``hg``, or for
Fournier-Forand (``ff``, from its backscatter fraction) and Petzold's
average particle phase function (``petzold``) a ``tabphase`` holding
exactly the table that aquaspec's light-field model is given
(:func:`lightfield_phase`, :func:`aquaspec.medium.phase.tabulated_phase`).
With ``surface="flat"`` (:func:`surface_bsdf`) the box is a smooth
``dielectric`` instead (the real flat sea surface: Snell's window, Fresnel,
total internal reflection); the sky's radiance is then the radiance in air,
so the downwelling irradiance below the surface is not E_sky but what the
interface lets through plus the water's light it mirrors back down
(measured with :func:`aquaspec.validation.meters.measure_downwelling`).
Integrator ``volpathmis`` (``volpath`` gives
fireflies in water whose extinction varies strongly with wavelength), no
path-length limit (see :data:`MAX_DEPTH`), box reconstruction filter.

One render serves every camera: the film is a ``specfilm`` of narrow box
bands (default 30 bands of 10 nm over 400-700 nm, each normalised to unit
area), so each channel is the band-averaged radiance; camera RGB follows as
``sum_i w_i L_i R_c,i`` exactly as in aquaspec (:func:`bands_to_rgb`).

The irradiance meters measuring Kd and plates in the same water are in
:mod:`aquaspec.validation.meters`.

Lamps (:class:`aquaspec.light.lamp.Lamp`, placed in the world) are Mitsuba
``spot`` emitters (:func:`lamp_emitter`: ``intensity`` the on-axis
``I0 s(lambda)`` in W sr^-1 nm^-1 as an ``irregular`` spectrum,
``cutoff_angle`` the cone, ``beam_width`` the beam; Mitsuba's fall-off is
linear in the angle between them, as aquaspec's) or ``point`` emitters for
180-degree lamps, inside the water medium. With no daylight (light
``none``) the sky emitter is left out.

Mitsuba is an optional dependency: ``pip install aquaspec[validation]``.
"""

from __future__ import annotations

import hashlib
import json
import tempfile
import time
from functools import lru_cache
from pathlib import Path

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import SurfaceLight
from aquaspec.medium.interface import N_WATER
from aquaspec.medium.phase import DEFAULT_TABLE_NODES, FournierForand, HenyeyGreenstein, get_phase
from aquaspec.medium.water import Water
from aquaspec.scene.camera import Camera

#: Variants tried in order (llvm needs Debian's libllvm19; scalar needs nothing).
VARIANTS = ("llvm_ad_spectral", "scalar_spectral")
#: Reference bands: 30 boxes of 10 nm.
REFERENCE_BANDS = Bands(30, 400.0, 700.0)
#: Path length limit: none (-1); Russian roulette ends paths without bias.
#: A limit of 33 (the thesis setting) is not converged in turbid water: for
#: Jerlov 3C at 9 m it made the image 2.5x too dark in blue with isotropic
#: scattering and 20 % with HG 0.92, against limits of 100 and 300 (which
#: agree within 2 %).
MAX_DEPTH = -1
#: Half-size of the water box, metres (its sides are far enough that light
#: entering through them is attenuated to nothing).
WATER_BOX_M = 1000.0
#: The water surfaces a reference can have (:func:`surface_bsdf`), named as
#: :class:`aquaspec.rendering.setup.SpectralSetup`'s.
REFERENCE_SURFACES = ("index-matched", "flat")
#: Phase functions of the path-traced water.
#:
#: ``"ff"`` and ``"petzold"`` are Mitsuba's ``tabphase``: values on a regular
#: grid of ``mu = cos Theta`` over [-1, 1] (``mu = 1`` forward, as verified by
#: sampling it), linear in between and normalised by the plugin, i.e. exactly
#: :class:`aquaspec.medium.phase.TabulatedPhase` with the same values. The table has
#: :data:`aquaspec.medium.phase.DEFAULT_TABLE_NODES` nodes (forward peak resolved to
#: ~0.4 degree; B and g of the table within 2e-6 of the functions').
#:
#: ``"petzold"`` is Petzold's *particle* phase function alone, for all of b:
#: a Mitsuba medium has one phase function for all wavelengths (``blendphase``
#: takes a scalar weight, so it cannot mix in pure water by b_w/b per
#: wavelength), so aquaspec's light-field model is given the same unmixed
#: function for this comparison (unlike its ``"petzold"`` method, which mixes
#: in pure water by band).
PHASES = ("isotropic", "hg", "ff", "petzold")
#: Default backscatter fraction of ``"ff"``: Petzold's average particle phase
#: function (Mobley et al. 2002: B = 0.0183, n = 1.10, mu = 3.5835).
FF_DEFAULT_BACKSCATTER = 0.0183


def check_phase(phase: str, g: float = 0.0, backscatter: float = FF_DEFAULT_BACKSCATTER):
    """Raise :class:`AquaspecError` unless ``phase`` and its parameter are accepted."""
    if phase not in PHASES:
        raise AquaspecError(f"reference phase function {phase!r}; accepted: {', '.join(PHASES)}")
    if phase == "hg":
        HenyeyGreenstein(float(g))
    elif phase == "ff":
        FournierForand(float(backscatter))


def lightfield_phase(phase: str, g: float = 0.0,
                     backscatter: float = FF_DEFAULT_BACKSCATTER) -> tuple[str, tuple]:
    """``(method, params)`` of aquaspec's phase function equal to the reference's.

    ``params`` is a tuple of ``(name, value)`` pairs for
    :func:`aquaspec.medium.phase.get_phase` (``SpectralSetup.phase_params``). ``ff``
    and ``petzold`` are the tabulated functions whose values
    :func:`reference_phase` gives Mitsuba (``petzold`` unmixed: see
    :data:`PHASES`).
    """
    check_phase(phase, g, backscatter)
    if phase == "isotropic":
        return "isotropic", ()
    if phase == "hg":
        return "hg", (("g", float(g)),)
    params = (("of", phase), ("n_nodes", DEFAULT_TABLE_NODES))
    if phase == "ff":
        params += (("backscatter", float(backscatter)),)
    return "tabulated", params


def phase_function(phase: str, g: float = 0.0, backscatter: float = FF_DEFAULT_BACKSCATTER):
    """The :class:`aquaspec.medium.phase.PhaseFunction` of the reference's water."""
    method, params = lightfield_phase(phase, g, backscatter)
    return get_phase(method, **dict(params))


@lru_cache(maxsize=4)
def _table_text(phase: str, g: float, backscatter: float) -> str:
    # 9 significant digits: float32 (Mitsuba's storage) keeps them all.
    return ", ".join(f"{v:.9g}" for v in phase_function(phase, g, backscatter).values)


def reference_phase(phase: str, g: float = 0.0,
                    backscatter: float = FF_DEFAULT_BACKSCATTER) -> dict:
    """Mitsuba's phase-function dictionary for the reference's water."""
    check_phase(phase, g, backscatter)
    if phase == "isotropic":
        return {"type": "isotropic"}
    if phase == "hg":
        return {"type": "hg", "g": float(g)}
    return {"type": "tabphase", "values": _table_text(phase, float(g), float(backscatter))}


def phase_key(phase: str, g: float = 0.0, backscatter: float = FF_DEFAULT_BACKSCATTER) -> dict:
    """The phase function's entries of a cache key.

    ``phase`` and ``g`` as before (existing isotropic/HG caches stay valid);
    for tabulated phases also the backscatter fraction (``ff``), the table
    size and a digest of the table's values.
    """
    key = {"phase": phase, "g": float(g) if phase == "hg" else 0.0}
    if phase in ("ff", "petzold"):
        tab = phase_function(phase, g, backscatter)
        key.update(table_nodes=int(tab.values.size), table=spectra_digest(tab.values))
        if phase == "ff":
            key["backscatter"] = float(backscatter)
    return key


def require_mitsuba():
    """Import Mitsuba 3 and choose a spectral variant; clear error if missing."""
    return mitsuba_variant(VARIANTS, "the validation")[0]


def mitsuba_variant(variants, what: str):
    """Import Mitsuba 3 and choose the first of ``variants`` that loads (the
    current one if it is among them): ``(mi, previous)``, ``previous`` the
    variant set before (None if none). Errors say what needed it (``what``)."""
    try:
        import mitsuba as mi  # deferred: an optional dependency (the 'validation' extra)
    except ImportError as exc:
        raise AquaspecError(f"{what} needs Mitsuba 3, which is not installed: "
                            "pip install 'aquaspec[validation]'") from exc
    previous = mi.variant()
    if previous in variants:
        return mi, previous
    errors = []
    for v in variants:
        try:
            mi.set_variant(v)
            return mi, previous
        except Exception as exc:  # noqa: BLE001 - Mitsuba raises several types
            errors.append(f"{v}: {exc}")
    raise AquaspecError(f"no Mitsuba variant for {what} could be loaded ("
                        + "; ".join(errors) + "); for the llvm_ad variants install Debian's "
                        "libllvm19")


def _spectrum(wl, values):
    if not np.any(np.asarray(values) > 0):
        # Mitsuba cannot build a sampling distribution of an all-zero spectrum.
        return {"type": "spectrum", "value": 0.0}
    return {"type": "irregular", "wavelengths": ", ".join(f"{w:.6g}" for w in wl),
            "values": ", ".join(f"{max(v, 0.0):.9g}" for v in values)}


def _box(lo, hi, full=(300.0, 900.0)):
    eps = 1e-3
    wl = [full[0], lo - eps, lo, hi, hi + eps, full[1]]
    h = 1.0 / (hi - lo)
    return _spectrum(wl, [0, 0, h, h, 0, 0])


def film(bands, width, height):
    film = {"type": "specfilm", "width": int(width), "height": int(height),
            "rfilter": {"type": "box"}}
    for k, (lo, hi) in enumerate(zip(bands.edges_nm[:-1], bands.edges_nm[1:])):
        film[f"band{k:03d}"] = _box(lo, hi)
    return film


#: Spacing (nm) of the grid on which the medium's extinction and albedo are
#: handed to Mitsuba, and the name of that choice in the reference caches'
#: keys. aquaspec reads a and b as piecewise linear between the data's
#: wavelengths (aquaspec.colour.bands.band_average); Mitsuba interpolates each
#: given spectrum linearly, so c = a + b and b / c given at the data's own
#: wavelengths (25 nm apart for Jerlov types) made b / c linear instead,
#: with b 13 % higher and a 5 % lower in the 580-590 nm band for Jerlov IB
#: (the reference's open water 8 % brighter there, 5.7 % at 590-600 nm,
#: than with this grid).
MEDIUM_GRID_NM = 1.0
MEDIUM_SPECTRA = "a-b-linear-1nm"


def medium_spectra(water: Water):
    """``(wavelength_nm, c, albedo)`` handed to Mitsuba: a and b interpolated
    linearly onto a :data:`MEDIUM_GRID_NM` grid (plus the data's own
    wavelengths), so that Mitsuba's linear interpolation of c and b / c
    between grid points follows the piecewise-linear a and b aquaspec uses."""
    wl = np.asarray(water.wavelength_nm, dtype=float)
    grid = np.union1d(wl, np.arange(np.ceil(wl[0]), wl[-1], MEDIUM_GRID_NM))
    a = np.interp(grid, wl, water.a)
    b = np.interp(grid, wl, water.b)
    c = a + b
    return grid, c, np.clip(b / c, 0.0, 1.0)


def water_medium(water: Water, phase: str, g: float, backscatter: float = FF_DEFAULT_BACKSCATTER):
    phase_dict = reference_phase(phase, g, backscatter)
    wl, c, albedo = medium_spectra(water)
    return {"type": "homogeneous", "sigma_t": _spectrum(wl, c),
            "albedo": _spectrum(wl, albedo), "phase": phase_dict}


def check_range(water, light, bands):
    ranges = [("water", water.range_nm),
              ("light", (light.wavelength_nm[0], light.wavelength_nm[-1]))]
    if light.sun is not None:
        ranges.append(("sun", (light.sun.wavelength_nm[0], light.sun.wavelength_nm[-1])))
    for name, (lo, hi) in ranges:
        if lo > bands.lo_nm or hi < bands.hi_nm:
            raise AquaspecError(f"{name} spectra cover {lo:g}-{hi:g} nm but the reference film "
                                f"samples {bands.lo_nm:g}-{bands.hi_nm:g} nm")


def sky_irradiance(light: SurfaceLight) -> np.ndarray:
    """The diffuse sky's downwelling irradiance just below the surface, on the
    light's wavelength grid (:meth:`aquaspec.light.sky.SurfaceLight.sky_values`:
    ``E0`` minus the sun's share, clipped at 0). The reference's sky radiance
    is this over pi."""
    return light.sky_values()


def sun_emitter(light: SurfaceLight) -> dict | None:
    """Mitsuba's ``directional`` emitter of the light's sun (None without one).

    ``direction`` is the way the refracted beam travels under water
    (:attr:`aquaspec.light.sun.Sun.direction`, y < 0); ``irradiance`` the beam's
    irradiance normal to it just below the surface (``beam_normal``).
    """
    if light.sun is None:
        return None
    sun = light.sun
    return {"type": "directional", "direction": [float(x) for x in sun.direction],
            "irradiance": _spectrum(sun.wavelength_nm, sun.beam_normal)}


def light_key(light: SurfaceLight) -> dict:
    """The sun's entries of a cache key: ``{}`` without a sun (so the keys of
    sky-only references stay as they were), else its angles, underwater
    direction and a digest of its beam spectrum (the light's E0 is in the
    keys' ``data`` digest already)."""
    if light.sun is None:
        return {}
    sun = light.sun
    return {"sun": {"elevation_deg": float(sun.elevation_deg),
                    "azimuth_deg": float(sun.azimuth_deg), "n_water": float(sun.n_water),
                    "direction": [round(float(x), 12) for x in sun.direction],
                    "beam": spectra_digest(sun.wavelength_nm, sun.beam_normal)}}


def lamp_emitter(lamp) -> dict:
    """Mitsuba's emitter of a lamp placed in the world (:meth:`aquaspec.light.lamp.Lamp.placed`):
    a ``spot`` (a ``point`` for a 180-degree lamp) inside the water medium."""
    if lamp.frame != "world":
        raise AquaspecError(f"lamp {lamp.name!r} is fixed to the camera: place it first "
                            "(Lamp.placed(camera))")
    if lamp.profile is not None:
        raise AquaspecError(f"lamp {lamp.name!r} has a measured profile; the reference takes "
                            "Mitsuba's spot profile (cone and beam) only")
    mi = require_mitsuba()
    spec = lamp.spectrum
    intensity = _spectrum(spec.wavelength_nm, lamp.on_axis_w_sr * spec.values)
    medium = {"type": "ref", "id": "water_medium"}
    if lamp.cone_deg >= 180.0:
        return {"type": "point", "position": lamp.position.tolist(), "intensity": intensity,
                "medium": medium}
    d = lamp.direction
    up = [0.0, 1.0, 0.0] if abs(d[1]) < 0.9 else [1.0, 0.0, 0.0]
    return {"type": "spot", "intensity": intensity, "cutoff_angle": float(lamp.cone_deg),
            "beam_width": float(lamp.beam_deg), "medium": medium,
            "to_world": mi.ScalarTransform4f().look_at(
                origin=lamp.position.tolist(), target=(lamp.position + d).tolist(), up=up)}


def surface_bsdf(surface: str, light: SurfaceLight | None = None) -> dict:
    """The water box's BSDF for a surface of :data:`REFERENCE_SURFACES`:
    ``null`` (index-matched) or Mitsuba's smooth ``dielectric`` (``flat``:
    air above, index :data:`aquaspec.medium.interface.N_WATER` below). A
    directional sun cannot reach the water through a smooth dielectric in
    ``volpathmis`` (no path can connect a delta light through a delta
    surface), so ``flat`` refuses a light with a sun."""
    if surface not in REFERENCE_SURFACES:
        raise AquaspecError(f"reference surface {surface!r}; accepted: "
                            f"{', '.join(REFERENCE_SURFACES)}")
    if surface == "index-matched":
        return {"type": "null"}
    if light is not None and light.sun is not None:
        raise AquaspecError("a reference with the flat (dielectric) surface takes a sky without "
                            f"a directional sun (light {light.name!r} has one): use overcast")
    return {"type": "dielectric", "int_ior": N_WATER, "ext_ior": 1.0}


def base_scene(water, light, phase, g, backscatter=FF_DEFAULT_BACKSCATTER, max_depth=MAX_DEPTH,
               lamps=(), surface: str = "index-matched"):
    mi = require_mitsuba()
    T = mi.ScalarTransform4f
    sky = _spectrum(light.wavelength_nm, sky_irradiance(light) / np.pi)
    d = {
        "type": "scene",
        "integrator": {"type": "volpathmis", "max_depth": int(max_depth)},
        "water_medium": water_medium(water, phase, g, backscatter),
        "water": {"type": "cube",
                  "to_world": T().translate([0.0, -WATER_BOX_M / 2, 0.0]).scale(
                      [WATER_BOX_M, WATER_BOX_M / 2, WATER_BOX_M]),
                  "bsdf": surface_bsdf(surface, light),
                  "interior": {"type": "ref", "id": "water_medium"}},
        "sky": {"type": "constant", "radiance": sky},
    }
    sun = sun_emitter(light)
    if sun is not None:
        d["sun"] = sun
    if not np.any(sky_irradiance(light) > 0):
        del d["sky"]
    for k, lamp in enumerate(lamps):
        d[f"lamp{k:02d}"] = lamp_emitter(lamp)
    return d


def scene_dict(scene, camera, water: Water, light: SurfaceLight, *, spp: int,
               mesh_dir, bands: Bands = REFERENCE_BANDS, phase: str = "isotropic",
               g: float = 0.0, backscatter: float = FF_DEFAULT_BACKSCATTER,
               max_depth: int = MAX_DEPTH, lamps=(), surface: str = "index-matched") -> dict:
    """The Mitsuba scene dictionary (meshes are written as PLY into ``mesh_dir``;
    ``lamps`` placed in the world, :func:`lamp_emitter`; ``surface``:
    :func:`surface_bsdf`)."""
    import trimesh  # deferred: trimesh takes about 0.9 s to import; only the reference needs it
    mi = require_mitsuba()
    check_range(water, light, bands)
    if abs(camera.cx - camera.width / 2) > 1e-6 or abs(camera.cy - camera.height / 2) > 1e-6:
        raise AquaspecError("the reference camera needs the principal point at the image centre")
    d = base_scene(water, light, phase, g, backscatter, max_depth, lamps, surface)
    fov_y = float(np.degrees(2 * np.arctan(camera.height / 2 / camera.fy)))
    d["sensor"] = {
        "type": "perspective", "fov": fov_y, "fov_axis": "y",
        "to_world": mi.ScalarTransform4f().look_at(
            origin=camera.position.tolist(), target=(camera.position + camera.forward).tolist(),
            up=camera.true_up.tolist()),
        "film": film(bands, camera.width, camera.height),
        "sampler": {"type": "independent", "sample_count": int(spp)},
        "medium": {"type": "ref", "id": "water_medium"},
    }
    mesh_dir = Path(mesh_dir)
    for i, mesh in enumerate(scene.meshes):
        if mesh.per_pixel:
            raise AquaspecError("the reference supports meshes with one material each "
                                f"(mesh {mesh.name!r} is textured or vertex-coloured)")
        path = mesh_dir / f"mesh{i:04d}.ply"
        trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).export(path)
        mat = scene.materials[mesh.material]
        d[f"mesh{i:04d}"] = {"type": "ply", "filename": str(path), "face_normals": True,
                             "bsdf": {"type": "diffuse", "reflectance": _spectrum(
                                 mat.wavelength_nm, mat.values)}}
    return d


def render_reference(scene, camera, water: Water, light: SurfaceLight, *, spp: int = 256,
                     seed: int = 0, bands: Bands = REFERENCE_BANDS, phase: str = "isotropic",
                     g: float = 0.0, backscatter: float = FF_DEFAULT_BACKSCATTER,
                     max_depth: int = MAX_DEPTH, lamps=(), surface: str = "index-matched") -> dict:
    """Path-trace the scene; returns ``band_radiance`` (H, W, n) and timing.

    ``band_radiance`` is the radiance averaged over each band of ``bands``
    (W m^-2 sr^-1 nm^-1), the same quantity aquaspec computes per band.
    ``phase``, ``g`` (``hg``) and ``backscatter`` (``ff``): see :data:`PHASES`.
    ``lamps``: lamps placed in the world, as Mitsuba emitters in the water
    (:func:`lamp_emitter`). ``surface``: the water surface
    (:data:`REFERENCE_SURFACES`, :func:`surface_bsdf`).
    ``max_depth`` is volpathmis's path length limit (-1: none, the
    reference's setting); it counts scattering events in the medium and at
    non-null surfaces (the water's null surface does not count): 1 gives the
    sky seen directly, 2 adds light scattered once (next-event estimation
    at the first event), e.g. the sun's single scattering alone when the
    light is the sun only.
    """
    mi = require_mitsuba()
    with tempfile.TemporaryDirectory(prefix="aquaspec-ref-") as tmp:
        d = scene_dict(scene, camera, water, light, spp=spp, mesh_dir=tmp, bands=bands,
                       phase=phase, g=g, backscatter=backscatter, max_depth=max_depth,
                       lamps=lamps, surface=surface)
        t0 = time.perf_counter()
        mscene = mi.load_dict(d)
        img = np.array(mi.render(mscene, seed=seed), dtype=np.float64)
        seconds = time.perf_counter() - t0
    if not np.all(np.isfinite(img)):
        raise AquaspecError("the reference render contains NaN or infinity")
    return {"band_radiance": img.reshape(camera.height, camera.width, bands.n),
            "seconds": seconds, "spp": spp, "variant": mi.variant(), "bands": bands.describe()}


def preflight(scene, camera, water: Water, light: SurfaceLight, *, phase: str = "isotropic",
              g: float = 0.0, backscatter: float = FF_DEFAULT_BACKSCATTER,
              bands: Bands = REFERENCE_BANDS, size=(8, 6), spp: int = 8) -> dict:
    """Render a tiny version of the scene first, to fail in a second, not after minutes.

    Same scene, camera pose and field of view at ``size`` pixels and ``spp``
    samples. Raises :class:`AquaspecError` if the image is not finite (checked
    by :func:`render_reference`), has negative values, or is black (the
    sky must reach the camera through the water).
    Returns the tiny render.
    """
    fov_y = float(np.degrees(2 * np.arctan(camera.height / 2 / camera.fy)))
    tiny = Camera.look_at(camera.position, camera.position + camera.forward, width=size[0],
                          height=size[1], fov_y_deg=fov_y, up=camera.true_up)
    res = render_reference(scene, tiny, water, light, spp=spp, seed=12345, bands=bands,
                           phase=phase, g=g, backscatter=backscatter)
    img = res["band_radiance"]
    if np.any(img < 0):
        raise AquaspecError(f"the reference's test render has negative radiance "
                            f"(min {img.min():.3g})")
    if not np.any(img > 0):
        # A single dark band can be noise in very turbid water at this sample
        # count; a black image means the sky does not reach the camera.
        raise AquaspecError("the reference's test render is black: no light reaches the "
                            f"camera at depth {camera.depth_m:g} m; check the camera is under "
                            "water and the water and light spectra")
    return res


def bands_to_rgb(band_radiance, sensor, bands: Bands = REFERENCE_BANDS, outside="zero"):
    """Camera RGB from reference band radiance: ``sum_i w_i L_i R_c,i``."""
    return np.asarray(band_radiance) @ sensor.band_weights(bands, outside=outside)


def spectra_digest(*arrays) -> str:
    """A short hash of the values of arrays (spectra, vertices), for cache keys.

    Names alone are not enough: the data behind a water type's name (gap
    filling, a new table) or a light can change between versions.
    """
    h = hashlib.sha256()
    for arr in arrays:
        x = np.ascontiguousarray(np.asarray(arr, dtype=np.float64))
        h.update(str(x.shape).encode())
        h.update(x.tobytes())
    return h.hexdigest()[:16]


def cache_key(**params) -> str:
    """A stable hash of every parameter of a reference render."""
    text = json.dumps(params, sort_keys=True, default=lambda o: getattr(o, "tolist", str)(o))
    return hashlib.sha256(text.encode()).hexdigest()[:20]
