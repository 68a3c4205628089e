"""The validation study: waters x depths x cameras against the path tracer.

For each water type and camera depth the validation scene
(:func:`.scenes.board_scene`) is path-traced once into narrow bands
(:func:`.reference.render_reference`, cached on disk by a hash of all its
parameters), Kd is measured in the path-traced water (also cached), and the
same G-buffer is shaded by aquaspec (spectral n = 8 and 16, with the
database Kd and with the measured one, for each multiple-scattering model)
and by the baselines (RGB n = 3, Unreal's single-layer water, the
image-formation model). Every camera's RGB is compared with the reference's
over the whole image, the 24 ColorChecker patches, the grey patch and the
open-water background (all of it, and only the rays going down), and by the
24 patches' mean colours.

Regions: ``image``; ``patches`` (pixels of the 24 patches); ``grey``;
``background`` (open water); ``background_down`` (open water seen along rays
going down or level: the reference's water surface has no refraction, so up
rays see the sky at every angle, while the seeds' model sees it only through
Snell's window; below the horizon both see only the water); ``patch_means``
(the mean colour of each of the 24 patches, far less path-tracing noise than
per-pixel errors). With the occluded scenes (``scene_names``,
:data:`.scenes.SCENES`) also ``seabed``, ``shaded_seabed`` (the seabed the
occluder shades) and ``occluder`` (:func:`.scenes.masks`). Every masked
region's row also holds the error of the region's *mean* colour: its hue
(``mean_hue_deg``) and per channel (``ratio_r``, ``ratio_g``, ``ratio_b``,
model over reference); the patch means' row holds ``mean_abs_error``, the
mean over patches of ``|mean_ratio - 1|`` of each patch's mean colour.
"""

from __future__ import annotations

import functools
import inspect
import time
import warnings
from pathlib import Path

import numpy as np

from aquaspec.cache import cache_dir as aquaspec_cache_dir
from aquaspec.cache import load_arrays, save_arrays
from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError, GPUUnavailableError
from aquaspec.gpu.device import get_device
from aquaspec.scene.raycast import raycast_gbuffer
from aquaspec.gpu.passes.shadow_rays import ShadowRays
from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG, surface_light
from aquaspec.medium.water import load_water
from aquaspec.rendering.renderer import Renderer
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.shadowmap import numpy_shadow_map
from aquaspec.shading.shade import shade_gbuffer
from aquaspec.transport.lightfield.cone import forward_cone
from aquaspec.transport.lightfield.solve import solve_lightfield
from aquaspec.transport.models import MONZON2022, ms_model_name
from aquaspec.validation import metrics
from aquaspec.validation.baselines import render_baseline
from aquaspec.validation.reference import (FF_DEFAULT_BACKSCATTER, MAX_DEPTH, MEDIUM_SPECTRA, REFERENCE_BANDS,
                        bands_to_rgb, cache_key, check_phase, light_key, lightfield_phase,
                        phase_function, phase_key, preflight, render_reference,
                        spectra_digest)
from aquaspec.validation.meters import measure_kd, water_with_kd
from aquaspec.validation.scenes import OCCLUDERS, SCENES, board_scene, masks

DEFAULT_WATERS = ("I", "IA", "IB", "II", "3C")
DEFAULT_DEPTHS = (3.0, 5.0, 9.0)
#: Surface lights of the study (:func:`aquaspec.light.sky.surface_light`).
STUDY_LIGHTS = ("overcast", "sun-sky")
DEFAULT_SUN_ELEVATION_DEG = 60.0
SCENE_VERSION = "board-v1"
#: Depths of the irradiance meters that measure Kd in the reference, m.
KD_DEPTHS_M = (1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
REGIONS = ("image", "patches", "grey", "background", "background_down", "seabed",
           "shaded_seabed", "occluder", "patch_means")
#: A scene's reference counts as converged when the standard error of the
#: mean of its grey patch and of its open-water background, in each third
#: of the spectrum, is at most this fraction of the mean (half of the 10 %
#: tolerance the light-field issue sets; see :func:`reference_stderr`).
CONVERGED_STDERR = 0.05


def reference_stderr(band_radiance, mask, groups: int = 3) -> float:
    """Relative standard error of a region's mean in a path-traced image.

    The region's pixels are summed over ``groups`` consecutive runs of
    bands (thirds of the spectrum by default: blue, green, red light,
    camera-independent); for each, the spread of the pixels over the root of
    their number, relative to their mean. Returns the largest; ``inf`` when
    a mean is not positive (no light reached the region). Real variation
    inside the region counts as noise here, so this bounds the Monte Carlo
    error of the mean from above.
    """
    x = np.asarray(band_radiance, dtype=np.float64)[np.asarray(mask, bool)]
    if x.shape[0] < 2:
        return float("inf")
    worst = 0.0
    for part in np.array_split(np.arange(x.shape[-1]), groups):
        v = x[:, part].sum(axis=-1)
        mean = v.mean()
        if not mean > 0:
            return float("inf")
        worst = max(worst, float(v.std(ddof=1) / np.sqrt(v.size) / mean))
    return worst


def lightfield_kd(water, phase_lf, phase_params=(), depths_m=KD_DEPTHS_M) -> dict:
    """The light-field model's diffuse attenuation on the reference's bands (1/m).

    ``kd_fit``: the least-squares slope of ``ln E_d`` over ``depths_m``, the
    depths of the reference's irradiance meters (:func:`measure_kd` fits the
    path tracer's the same way); ``k_inf``: the asymptotic kappa_1 of the
    discrete-ordinates solution, the attenuation far below the surface.
    """
    wb = water.on_bands(REFERENCE_BANDS)
    lf = solve_lightfield(wb.a, wb.b, phase=phase_lf, wavelength_nm=REFERENCE_BANDS.centers_nm,
                          **dict(phase_params))
    d = np.asarray(depths_m, dtype=float)
    slope = np.polyfit(d, np.log(lf.e_d(d)).T, 1)[0]
    return {"kd_fit": -slope, "k_inf": np.asarray(lf.k_inf, dtype=float)}


def default_cache_dir() -> Path | None:
    """Where path-traced references are kept: ``reference`` in aquaspec's cache
    (:func:`aquaspec.cache.cache_dir`; None when ``AQUASPEC_CACHE=off``)."""
    base = aquaspec_cache_dir()
    return None if base is None else base / "reference"


def _cached(cache_dir, key, compute):
    """``(arrays, found)``: ``compute()``'s arrays (its dicts and Bands left
    out) kept in ``cache_dir/key.npz`` (:mod:`aquaspec.cache`'s reading and
    atomic writing), and whether they were read from there."""
    if cache_dir is None:
        return compute(), False
    path = Path(cache_dir) / f"{key}.npz"
    found = load_arrays(path)
    if found is not None:
        return found, True
    arrays = {k: np.asarray(v) for k, v in compute().items()
              if not isinstance(v, (dict, Bands))}
    if not save_arrays(path, arrays, compressed=True):
        warnings.warn(f"could not write the reference cache file {path}", stacklevel=2)
    return arrays, False


def _spectral(gb, water, light, n, ms_model, phase_lf, phase_params=(), forward_cone_deg=None,
              cone_spread=False, seabed=None, spread_scattering="single", ambient_shadow=False,
              sun_shadow=None, occlusion=None):
    setup = SpectralSetup(water, get_sensor("human"), light, Bands(n), ms_model=ms_model,
                          phase=phase_lf, phase_params=phase_params,
                          forward_cone_deg=forward_cone_deg,
                          cone_spread=cone_spread and ms_model == "lightfield",
                          spread_scattering=(spread_scattering if cone_spread
                                             and ms_model == "lightfield" else "single"),
                          seabed=seabed if ms_model == "lightfield" else None,
                          ambient_shadow=ambient_shadow and ms_model == "lightfield")
    out = shade_gbuffer(gb, **setup.medium(gb.materials), return_radiance=True,
                        lightfield=setup.lightfield_tables(),
                        shadow_rays=_shadow_rays(n) if setup.ambient_shadow else None,
                        sun=setup.sun_inputs(), sun_shadow=sun_shadow,
                        **({"occlusion": occlusion}
                           if occlusion is not None and ms_model == "lightfield" else {}))
    return out["radiance"]


def _occlusion_model():
    """The function giving a scene's occlusion of the light field
    (``--occlusion``, issue 36), ``occlusion_maps(scene, camera)`` of
    ``aquaspec.scene.occlusion``, for
    :func:`aquaspec.shading.shade.shade_gbuffer`'s ``occlusion``; a clear
    error while that model does not exist yet."""
    try:
        # deferred: the occlusion model is optional here until it exists (issue 36)
        from aquaspec.scene.occlusion import occlusion_maps
    except ImportError as exc:
        raise AquaspecError("--occlusion: the light field's occlusion model "
                            "(aquaspec.scene.occlusion) is not available yet") from exc
    if "occlusion" not in inspect.signature(shade_gbuffer).parameters:
        raise AquaspecError("--occlusion: shade_gbuffer takes no occlusion maps yet "
                            "(aquaspec.shading.shade); not available yet")
    return occlusion_maps


def _mean_colour_metrics(ref_rgb, rgb, mask) -> dict:
    """Errors of a region's mean colour: hue angle between the means and the
    ratio of each channel's mean (model over reference)."""
    r = ref_rgb.reshape(-1, 3) if mask is None else ref_rgb[mask]
    t = rgb.reshape(-1, 3) if mask is None else rgb[mask]
    rm, tm = r.mean(axis=0), t.mean(axis=0)
    ratio = tm / np.maximum(rm, 1e-300)
    return {"mean_hue_deg": metrics.hue_difference_deg(rm[None], tm[None]),
            "ratio_r": float(ratio[0]), "ratio_g": float(ratio[1]),
            "ratio_b": float(ratio[2])}


def _patch_abs_error(ref_means, test_means) -> float:
    """Mean over patches of ``|brightness error|`` of each patch's mean colour."""
    ratio = test_means.sum(axis=1) / np.maximum(ref_means.sum(axis=1), 1e-300)
    return float(np.mean(np.abs(ratio - 1.0)))


@functools.lru_cache(maxsize=4)
def _shadow_rays(n: int):
    """The shadow's ray integrals on the GPU when there is one (its WGSL twins
    agree with NumPy within 1e-5 of the term; several times faster), else
    None (NumPy). One per band count (the pipelines are compiled once)."""
    try:
        return ShadowRays(get_device()[1], n)
    except GPUUnavailableError:
        return None


def gpu_frame_seconds(scene, camera, water, light, n: int, *, ms_model="seeds",
                      phase="isotropic", phase_params=(), frames: int = 5):
    """Median wall time of one GPU frame (raster + shading + read-back) at this size.

    The thesis's speed-up is of the real-time renderer over the path tracer at
    equal pixel count; on a machine without a GPU this is lavapipe on the CPU,
    so it is an upper bound of the frame time. Returns None (and the reason)
    when no wgpu adapter is available.
    """
    try:
        r = Renderer(camera.width, camera.height, n)
    except Exception as exc:  # noqa: BLE001 - wgpu raises several types without an adapter
        return None, f"no GPU timing: {exc}"
    setup = SpectralSetup(water, get_sensor("human"), light, Bands(n), ms_model=ms_model,
                          phase=phase, phase_params=phase_params, outside="zero")
    r.render_scene(scene, camera, setup)            # compile and upload once
    times = []
    for _ in range(frames):
        t0 = time.perf_counter()
        r.render_scene(scene, camera, setup)
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), None


def _region_means(rgb, m):
    """(k, 3): mean RGB of each visible patch (k <= 24)."""
    return np.array([rgb[mask].mean(axis=0) for mask in m["patches"] if mask.any()])


def run_study(*, waters=DEFAULT_WATERS, depths=DEFAULT_DEPTHS, sensors: dict, source="solonenko2015",
              size=(96, 72), spp: int = 256, kd_spp: int = 50_000, phase: str = "isotropic",
              g: float = 0.0, backscatter: float = FF_DEFAULT_BACKSCATTER,
              band_counts=(8, 16), ms_models=("seeds",),
              kd_modes=("database", "measured"), forward_cone_deg: float | None = None,
              cone_spread: bool | None = None, spread_scattering: str = "single",
              ambient_shadow: bool = False, seabed_below_m: float | None = None,
              seabed_albedo: float = 0.2, view: str = "level", light: str = "overcast",
              sun_elevation_deg: float = DEFAULT_SUN_ELEVATION_DEG,
              sun_azimuth_deg: float = DEFAULT_SUN_AZIMUTH_DEG,
              cache_dir=None, progress=None, gpu_timing: bool = False,
              scene_names=("board",), occlusion: bool = False) -> dict:
    """Run the study; returns ``{"rows": [...], "scenes": [...], "images": {...}}``.

    Each entry of ``scenes`` holds the reference's render time and the time
    aquaspec took to shade the same G-buffer in NumPy (float64, one core) per
    method, and with ``gpu_timing`` the median GPU frame time at the largest
    band count, so the speed-up at equal pixel count can be reported.

    ``phase`` (with ``g`` for ``"hg"``, ``backscatter`` for ``"ff"``) is the
    path-traced water's phase function (:data:`.reference.PHASES`); the
    light-field model is given exactly the same function
    (:func:`.reference.lightfield_phase`: for ``"ff"`` and ``"petzold"`` the
    very table Mitsuba's ``tabphase`` holds; ``"petzold"`` is the particle
    phase function alone, unmixed with pure water, on both sides).
    ``seabed_below_m`` puts a flat grey seabed (``seabed_albedo``) that far
    below the camera, in the reference and as the light field's lower
    boundary; the light field is then also run without it
    (``lightfield-deep-n*``) to show what leaving it out costs.
    ``cone_spread`` spreads the light-field model's forward cone over the
    image (:mod:`aquaspec.transport.lightfield.conespread`; None: when ``ms_models`` has the light
    field, as :func:`aquaspec.transport.models.cone_spread_for`), its light taken as
    scattered once or a Poisson number of times (``spread_scattering``,
    :mod:`aquaspec.transport.lightfield.conespread`); ``ambient_shadow`` subtracts the scene's
    first-order shadow in the light field (:mod:`aquaspec.transport.lightfield.shadow`); ``forward_cone_deg``
    None is the model's default cone (15 degrees, 40 with the spread).
    ``view`` is the board's view (:data:`.scenes.VIEWS`: facing the camera,
    or lying flat seen from above). ``scene_names`` are the scenes
    (:data:`.scenes.SCENES`: the thesis's board, or the board over a seabed,
    open or occluded; each row and scene record holds its ``scene``, and the
    scene is in its reference's cache key); ``occlusion`` gives the light
    field the scene's occlusion maps (:func:`_occlusion_model`).

    ``light`` (:data:`STUDY_LIGHTS`) is the surface light of both sides:
    ``overcast`` (the thesis's setting), or ``sun-sky`` with the sun at
    ``sun_elevation_deg`` and ``sun_azimuth_deg``
    (:func:`aquaspec.light.sky.surface_light`). The same light object, with its
    sun, goes to aquaspec's shading (:func:`_spectral`, the baselines), to
    the reference (a ``directional`` emitter plus the rest of E0 as the
    sky: :mod:`.reference`) and to the Kd meters (which add the sun's
    unscattered beam: :func:`.meters.measure_kd`); the sun is in the
    reference caches' keys (:func:`.reference.light_key`). The light-field
    Kd of the attenuation table (:func:`lightfield_kd`) is for a diffuse
    sky: it is the light-field solution's own, whatever the light.
    """
    say = progress or (lambda m: None)
    if not sensors:
        raise AquaspecError("the study needs at least one sensor")
    if cone_spread is None:
        cone_spread = "lightfield" in ms_models
    if cone_spread and "lightfield" not in ms_models:
        raise AquaspecError(f"cone_spread is part of the light-field model; ms_models="
                            f"{list(ms_models)}; accepted: a list with 'lightfield'")
    if ambient_shadow and "lightfield" not in ms_models:
        raise AquaspecError(f"ambient_shadow is part of the light-field model; ms_models="
                            f"{list(ms_models)}; accepted: a list with 'lightfield'")
    forward_cone_deg = forward_cone(forward_cone_deg, cone_spread)
    if spread_scattering not in ("single", "multiple") or (
            spread_scattering == "multiple" and not cone_spread):
        raise AquaspecError(f"spread_scattering={spread_scattering!r} with cone_spread="
                            f"{cone_spread!r}; accepted: 'single', or 'multiple' with the "
                            "cone spread on")
    scene_names = tuple(scene_names)
    bad = [s for s in scene_names if s not in SCENES]
    if bad or not scene_names:
        raise AquaspecError(f"scene {', '.join(map(repr, bad)) or '(none)'}; accepted: "
                            f"{', '.join(SCENES)}")
    if occlusion and "lightfield" not in ms_models:
        raise AquaspecError(f"occlusion is part of the light-field model; ms_models="
                            f"{list(ms_models)}; accepted: a list with 'lightfield'")
    if light not in STUDY_LIGHTS:
        raise AquaspecError(f"study light {light!r}; accepted: {', '.join(STUDY_LIGHTS)}")
    light = (surface_light(light, sun_elevation_deg=sun_elevation_deg,
                           sun_azimuth_deg=sun_azimuth_deg) if light == "sun-sky"
             else surface_light(light))
    lkey = light_key(light)      # {} without a sun: older keys stay valid
    g = float(g) if phase == "hg" else 0.0
    backscatter = float(backscatter)
    check_phase(phase, g, backscatter)
    phase_lf, phase_params = lightfield_phase(phase, g, backscatter)
    ph = phase_function(phase, g, backscatter)
    phase_info = {**ph.describe(), "backscatter_fraction": ph.backscatter_fraction(),
                  "mean_cosine": float(ph.legendre_moments(1)[1])}
    pkey = phase_key(phase, g, backscatter)
    occlusion_of = _occlusion_model() if occlusion else None
    rows, scenes, images, attenuation = [], [], {}, {}
    total = len(waters) * len(depths) * len(scene_names)
    if waters and depths:
        # A broken scene should fail in a second, not after the Kd meters.
        for name in scene_names:
            scene0, cam0 = board_scene(depths[0], width=size[0], height=size[1],
                                       seabed_below_m=seabed_below_m,
                                       seabed_albedo=seabed_albedo, view=view, scene=name)
        say("checking the reference scene on an 8x6 test image")
        preflight(scene0, cam0, load_water(waters[0], source), light, phase=phase, g=g,
                  backscatter=backscatter)
    k = 0
    for wname in waters:
        water = load_water(wname, source)
        # Keys hold every parameter of the render, including the values of
        # the spectra (not only their names).
        data = spectra_digest(water.wavelength_nm, water.a, water.b, light.wavelength_nm,
                              light.values)
        kd_key = cache_key(kind="kd", water=wname, source=source, **pkey, spp=kd_spp,
                           medium=MEDIUM_SPECTRA,
                           bands=REFERENCE_BANDS.describe(), max_depth=MAX_DEPTH,
                           depths=list(KD_DEPTHS_M), data=data, **lkey)
        kd_res, hit = _cached(cache_dir, kd_key, lambda: measure_kd(
            water, light, depths_m=KD_DEPTHS_M, spp=kd_spp, phase=phase, g=g,
            backscatter=backscatter))
        say(f"[{wname}] Kd measured in the reference{' (cache)' if hit else ''}")
        lf_att = lightfield_kd(water, phase_lf, phase_params)
        attenuation[wname] = {
            "kd_database": water.on_bands(REFERENCE_BANDS).kd.tolist(),
            "kd_measured": np.asarray(kd_res["kd"]).tolist(),
            "kd_measured_stderr": np.asarray(kd_res["kd_stderr"]).tolist(),
            "kd_lightfield": lf_att["kd_fit"].tolist(),
            "k_inf_lightfield": lf_att["k_inf"].tolist()}
        waters_by_mode = {"database": water,
                          "measured": water_with_kd(water, np.asarray(kd_res["kd"]))}
        for depth, scene_name in ((d, n) for d in depths for n in scene_names):
            k += 1
            scene, cam = board_scene(depth, width=size[0], height=size[1],
                                     seabed_below_m=seabed_below_m,
                                     seabed_albedo=seabed_albedo, view=view,
                                     scene=scene_name)
            gb = raycast_gbuffer(scene, cam)
            occlusion_maps = occlusion_of(scene, cam) if occlusion_of else None
            sun_shadow = None
            if light.sun is not None:
                sun_shadow = numpy_shadow_map(scene, cam, light.sun.to_sun)
            m = masks(gb, scene=scene_name)
            going_down = cam.ray_directions()[..., 1] <= 0
            region_masks = {"image": None, "patches": m["patches"].any(axis=0),
                            "grey": m["grey"], "background": m["background"],
                            "background_down": m["background"] & going_down}
            if scene_name != "board":
                region_masks.update({r: m[r] for r in ("seabed", "shaded_seabed")})
            if scene_name in OCCLUDERS:
                region_masks["occluder"] = m["occluder"]
            empty = [r for r, mk in region_masks.items() if mk is not None and not mk.any()]
            if empty:
                say(f"  note: no pixel in region(s) {', '.join(empty)} at {size[0]}x{size[1]}; "
                    "use a larger --size to measure them")
                region_masks = {r: mk for r, mk in region_masks.items() if r not in empty}
            geometry = spectra_digest(*[x for mesh in scene.meshes
                                        for x in (mesh.vertices, mesh.faces)],
                                      *[x for mat in scene.materials
                                        for x in (mat.wavelength_nm, mat.values)])
            key = cache_key(kind="render", scene=SCENE_VERSION, medium=MEDIUM_SPECTRA,
                            water=wname, source=source,
                            depth=depth, size=list(size), spp=spp, **pkey,
                            bands=REFERENCE_BANDS.describe(), max_depth=MAX_DEPTH,
                            data=data, geometry=geometry, **lkey,
                            # (The level view's keys predate the views and scenes.)
                            **({} if view == "level" else
                               {"camera": [cam.position.tolist(), cam.forward.tolist()]}),
                            **({} if scene_name == "board" else {"layout": scene_name}))
            t0 = time.perf_counter()
            ref, hit = _cached(cache_dir, key, lambda: render_reference(
                scene, cam, water, light, spp=spp, phase=phase, g=g,
                backscatter=backscatter))
            say(f"[{k}/{total}] {wname} {depth:g} m {scene_name}: reference "
                f"{'from cache' if hit else f'{time.perf_counter() - t0:.1f} s'}")
            methods = {}
            numpy_seconds = {}
            for mode in kd_modes:
                for ms in ms_models:
                    if ms_model_name(ms) != MONZON2022 and mode == "measured":
                        continue   # the light field does not use Kd
                    for n in band_counts + (3,):
                        name = f"{ms}-n{n}" if n != 3 else f"rgb-{ms}-n3"
                        t0 = time.perf_counter()
                        methods[(name, mode)] = ("bands", n, _spectral(
                            gb, waters_by_mode[mode], light, n, ms, phase_lf,
                            phase_params, forward_cone_deg, cone_spread, scene.seabed,
                            spread_scattering, ambient_shadow, sun_shadow, occlusion_maps))
                        numpy_seconds[name] = time.perf_counter() - t0
                        if ms == "lightfield" and scene.seabed is not None and n != 3:
                            # What leaving the seabed out of the light field costs.
                            methods[(f"lightfield-deep-n{n}", mode)] = ("bands", n, _spectral(
                                gb, waters_by_mode[mode], light, n, ms, phase_lf,
                                phase_params, forward_cone_deg, cone_spread,
                                spread_scattering=spread_scattering,
                                ambient_shadow=ambient_shadow, sun_shadow=sun_shadow,
                                occlusion=occlusion_maps))
            methods[("unreal", "database")] = ("baseline", "unreal", None)
            for mode in kd_modes:       # the image-formation model's B_inf and J use Kd
                methods[("ifm", mode)] = ("baseline", "ifm", None)
            for cname, sensor in sensors.items():
                ref_rgb = bands_to_rgb(ref["band_radiance"], sensor)
                mat = sensor.srgb_matrix()
                for (mname, mode), (kind, arg, rad) in methods.items():
                    if kind == "bands":
                        rgb = rad @ sensor.band_weights(Bands(arg), outside="zero")
                    else:
                        rgb = render_baseline(arg, gb, waters_by_mode[mode], light, sensor)
                    for region, mask in region_masks.items():
                        met = metrics.all_metrics(ref_rgb, rgb, mask, matrix=mat)
                        if region == "image":
                            met["ssim"] = metrics.ssim(ref_rgb, rgb)
                        met.update(_mean_colour_metrics(ref_rgb, rgb, mask))
                        rows.append({"scene": scene_name, "water": wname, "depth_m": depth,
                                     "camera": cname, "method": mname, "kd": mode,
                                     "region": region, **met})
                    # Mean colour of each patch: far less path-tracing noise
                    # than per-pixel errors.
                    if "patches" in region_masks:
                        ref_means, test_means = _region_means(ref_rgb, m), _region_means(rgb, m)
                        rows.append({"scene": scene_name, "water": wname, "depth_m": depth,
                                     "camera": cname, "method": mname, "kd": mode,
                                     "region": "patch_means",
                                     **metrics.all_metrics(ref_means, test_means, matrix=mat),
                                     "mean_abs_error": _patch_abs_error(ref_means, test_means)})
                    if cname == next(iter(sensors)):
                        images[(scene_name, wname, depth, mname, mode)] = rgb
                if cname == next(iter(sensors)):
                    images[(scene_name, wname, depth, "reference", "-")] = ref_rgb
            info = {"scene": scene_name, "water": wname, "depth_m": depth, "reference_seconds":
                    float(np.asarray(ref.get("seconds", np.nan))),
                    "pixels": size[0] * size[1], "spp": spp,
                    "numpy_shading_seconds": numpy_seconds,
                    "kd_measured": np.asarray(kd_res["kd"]).tolist(),
                    "kd_measured_stderr": np.asarray(kd_res["kd_stderr"]).tolist(),
                    "kd_database": water.on_bands(REFERENCE_BANDS).kd.tolist()}
            stderr = {r: reference_stderr(ref["band_radiance"], region_masks[r])
                      for r in ("grey", "background", "shaded_seabed") if r in region_masks}
            info["reference_stderr"] = stderr
            info["converged"] = bool(stderr) and max(stderr.values()) <= CONVERGED_STDERR
            say("  reference standard error of the mean: " + ", ".join(
                f"{r} {v:.1%}" for r, v in stderr.items())
                + ("" if info["converged"] else
                   f" (above {CONVERGED_STDERR:.0%}: not converged at {spp} spp)"))
            if gpu_timing:
                n_max = max(band_counts)
                secs, why = gpu_frame_seconds(scene, cam, water, light, n_max)
                info["gpu_frame_seconds"] = secs
                info["gpu_bands"] = n_max
                if why:
                    say("  " + why)
                else:
                    say(f"  GPU frame n={n_max}: {secs * 1e3:.1f} ms; reference "
                        f"{info['reference_seconds']:.1f} s")
            scenes.append(info)
    return {"rows": rows, "scenes": scenes, "images": images, "waters": attenuation,
            "params": {"waters": list(waters), "depths": list(depths), "cameras": list(sensors),
                       "size": list(size), "spp": spp, "kd_spp": kd_spp, "phase": phase, "g": g,
                       "backscatter": backscatter if phase == "ff" else None,
                       "phase_function": phase_info,
                       "source": source, "band_counts": list(band_counts),
                       "ms_models": list(ms_models), "forward_cone_deg": forward_cone_deg,
                       "cone_spread": bool(cone_spread),
                       "spread_scattering": spread_scattering,
                       "ambient_shadow": bool(ambient_shadow), "view": view,
                       "scenes": list(scene_names), "occlusion": bool(occlusion),
                       "light": light.describe(),
                       "seabed": None if seabed_below_m is None else
                       {"below_camera_m": float(seabed_below_m),
                        "albedo": float(seabed_albedo)}}}
