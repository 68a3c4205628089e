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
per-pixel errors).
"""

from __future__ import annotations

import csv
import functools
import io
import json
import time
import warnings
from pathlib import Path

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG, surface_light
from aquaspec.medium.water import load_water
from aquaspec.validation import metrics
from aquaspec.validation.baselines import render_baseline
from aquaspec.validation.reference import (FF_DEFAULT_BACKSCATTER, MAX_DEPTH, MEDIUM_SPECTRA, REFERENCE_BANDS,
                        bands_to_rgb, cache_key, check_phase, light_key, lightfield_phase,
                        measure_kd, phase_function, phase_key, preflight, render_reference,
                        spectra_digest, water_with_kd)
from aquaspec.validation.scenes import board_scene, masks

DEFAULT_WATERS = ("I", "IA", "IB", "II", "3C")
DEFAULT_DEPTHS = (3.0, 5.0, 9.0)
#: Surface lights of the study (:func:`aquaspec.light.sky.surface_light`).
STUDY_LIGHTS = ("overcast", "sun-sky")
DEFAULT_SUN_ELEVATION_DEG = 60.0
SCENE_VERSION = "board-v1"
#: Depths of the irradiance meters that measure Kd in the reference, m.
KD_DEPTHS_M = (1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
REGIONS = ("image", "patches", "grey", "background", "background_down", "patch_means")
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
    from aquaspec.transport.lightfield.solve import solve_lightfield
    wb = water.on_bands(REFERENCE_BANDS)
    lf = solve_lightfield(wb.a, wb.b, phase=phase_lf, wavelength_nm=REFERENCE_BANDS.centers_nm,
                          **dict(phase_params))
    d = np.asarray(depths_m, dtype=float)
    slope = np.polyfit(d, np.log(lf.e_d(d)).T, 1)[0]
    return {"kd_fit": -slope, "k_inf": np.asarray(lf.k_inf, dtype=float)}


def format_attenuation(waters: dict, wavelengths_nm=(450.0, 550.0, 650.0)) -> str:
    """Table of database, path-traced and light-field Kd per water (1/m) at a few wavelengths.

    ``waters`` maps a water name to its ``attenuation`` record (study result
    ``"waters"``): ``kd_database``, ``kd_measured``, ``kd_lightfield``,
    ``k_inf_lightfield`` on the reference bands.
    """
    c = REFERENCE_BANDS.centers_nm
    cols = ("kd_database", "kd_measured", "kd_lightfield", "k_inf_lightfield")
    lines = ["diffuse attenuation (1/m): database Kd, Kd measured in the path tracer, the "
             f"light-field model's Kd over the meters' depths {KD_DEPTHS_M[0]:g}-"
             f"{KD_DEPTHS_M[-1]:g} m and its kappa_1",
             f"{'water':>5s} {'nm':>5s} " + " ".join(f"{k:>16s}" for k in cols)]
    for name, rec in waters.items():
        for wl in wavelengths_nm:
            lines.append(f"{name:>5s} {wl:5.0f} " + " ".join(
                f"{np.interp(wl, c, rec[k]):16.4f}" for k in cols))
    return "\n".join(lines)


def default_cache_dir() -> Path | None:
    """Where path-traced references are kept: ``reference`` in aquaspec's cache
    (:func:`aquaspec.cache.cache_dir`; None when ``AQUASPEC_CACHE=off``)."""
    from aquaspec.cache import cache_dir
    base = cache_dir()
    return None if base is None else base / "reference"


def _cached(cache_dir, key, compute):
    """``(arrays, found)``: ``compute()``'s arrays (its dicts and Bands left
    out) kept in ``cache_dir/key.npz`` (:mod:`aquaspec.cache`'s reading and
    atomic writing), and whether they were read from there."""
    if cache_dir is None:
        return compute(), False
    from aquaspec.cache import load_arrays, save_arrays
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
              sun_shadow=None):
    from aquaspec.rendering.renderer import SpectralSetup
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.shading.shade import shade_gbuffer
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
                        sun=setup.sun_inputs(), sun_shadow=sun_shadow)
    return out["radiance"]


@functools.lru_cache(maxsize=4)
def _shadow_rays(n: int):
    """The shadow's ray integrals on the GPU when there is one (its WGSL twins
    agree with NumPy within 1e-5 of the term; several times faster), else
    None (NumPy). One per band count (the pipelines are compiled once)."""
    from aquaspec.errors import GPUUnavailableError
    try:
        from aquaspec.gpu.device import get_device
        from aquaspec.gpu.passes.shadow_rays import ShadowRays
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
    from aquaspec.rendering.renderer import Renderer, SpectralSetup
    from aquaspec.colour.sensors import get_sensor
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
              cache_dir=None, progress=None, gpu_timing: bool = False) -> dict:
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
    field, as :func:`aquaspec.transport.monzon2022.cone_spread_for`), its light taken as
    scattered once or a Poisson number of times (``spread_scattering``,
    :mod:`aquaspec.transport.lightfield.conespread`); ``ambient_shadow`` subtracts the scene's
    first-order shadow in the light field (:mod:`aquaspec.transport.lightfield.shadow`); ``forward_cone_deg``
    None is the model's default cone (15 degrees, 40 with the spread).
    ``view`` is the board's view (:data:`.scenes.VIEWS`: facing the camera,
    or lying flat seen from above).

    ``light`` (:data:`STUDY_LIGHTS`) is the surface light of both sides:
    ``overcast`` (the thesis's setting), or ``sun-sky`` with the sun at
    ``sun_elevation_deg`` and ``sun_azimuth_deg``
    (:func:`aquaspec.light.sky.surface_light`). The same light object, with its
    sun, goes to aquaspec's shading (:func:`_spectral`, the baselines), to
    the reference (a ``directional`` emitter plus the rest of E0 as the
    sky: :mod:`.reference`) and to the Kd meters (which add the sun's
    unscattered beam: :func:`.reference.measure_kd`); the sun is in the
    reference caches' keys (:func:`.reference.light_key`). The light-field
    Kd of the attenuation table (:func:`lightfield_kd`) is for a diffuse
    sky: it is the light-field solution's own, whatever the light.
    """
    from aquaspec.gpu.passes.raster import raycast_gbuffer
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
    from aquaspec.transport.lightfield.solve import forward_cone
    forward_cone_deg = forward_cone(forward_cone_deg, cone_spread)
    if spread_scattering not in ("single", "multiple") or (
            spread_scattering == "multiple" and not cone_spread):
        raise AquaspecError(f"spread_scattering={spread_scattering!r} with cone_spread="
                            f"{cone_spread!r}; accepted: 'single', or 'multiple' with the "
                            "cone spread on")
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
    rows, scenes, images, attenuation = [], [], {}, {}
    total = len(waters) * len(depths)
    if waters and depths:
        # A broken scene should fail in a second, not after the Kd meters.
        say("checking the reference scene on an 8x6 test image")
        scene0, cam0 = board_scene(depths[0], width=size[0], height=size[1],
                                   seabed_below_m=seabed_below_m, seabed_albedo=seabed_albedo,
                                   view=view)
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
        for depth in depths:
            k += 1
            scene, cam = board_scene(depth, width=size[0], height=size[1],
                                     seabed_below_m=seabed_below_m,
                                     seabed_albedo=seabed_albedo, view=view)
            gb = raycast_gbuffer(scene, cam)
            sun_shadow = None
            if light.sun is not None:
                from aquaspec.light.sun import numpy_shadow_map
                sun_shadow = numpy_shadow_map(scene, cam, light.sun.to_sun)
            m = masks(gb)
            going_down = cam.ray_directions()[..., 1] <= 0
            region_masks = {"image": None, "patches": m["patches"].any(axis=0),
                            "grey": m["grey"], "background": m["background"],
                            "background_down": m["background"] & going_down}
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
                            # (The level view's keys predate the views.)
                            **({} if view == "level" else
                               {"camera": [cam.position.tolist(), cam.forward.tolist()]}))
            t0 = time.perf_counter()
            ref, hit = _cached(cache_dir, key, lambda: render_reference(
                scene, cam, water, light, spp=spp, phase=phase, g=g,
                backscatter=backscatter))
            say(f"[{k}/{total}] {wname} {depth:g} m: reference "
                f"{'from cache' if hit else f'{time.perf_counter() - t0:.1f} s'}")
            methods = {}
            numpy_seconds = {}
            for mode in kd_modes:
                for ms in ms_models:
                    if ms != "seeds" and mode == "measured":
                        continue   # the light field does not use Kd
                    for n in band_counts + (3,):
                        name = f"{ms}-n{n}" if n != 3 else f"rgb-{ms}-n3"
                        t0 = time.perf_counter()
                        methods[(name, mode)] = ("bands", n, _spectral(
                            gb, waters_by_mode[mode], light, n, ms, phase_lf,
                            phase_params, forward_cone_deg, cone_spread, scene.seabed,
                            spread_scattering, ambient_shadow, sun_shadow))
                        numpy_seconds[name] = time.perf_counter() - t0
                        if ms == "lightfield" and scene.seabed is not None and n != 3:
                            # What leaving the seabed out of the light field costs.
                            methods[(f"lightfield-deep-n{n}", mode)] = ("bands", n, _spectral(
                                gb, waters_by_mode[mode], light, n, ms, phase_lf,
                                phase_params, forward_cone_deg, cone_spread,
                                spread_scattering=spread_scattering,
                                ambient_shadow=ambient_shadow, sun_shadow=sun_shadow))
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
                        rows.append({"water": wname, "depth_m": depth, "camera": cname,
                                     "method": mname, "kd": mode, "region": region, **met})
                    # Mean colour of each patch: far less path-tracing noise
                    # than per-pixel errors.
                    if "patches" in region_masks:
                        rows.append({"water": wname, "depth_m": depth, "camera": cname,
                                     "method": mname, "kd": mode, "region": "patch_means",
                                     **metrics.all_metrics(_region_means(ref_rgb, m),
                                                           _region_means(rgb, m), matrix=mat)})
                    if cname == next(iter(sensors)):
                        images[(wname, depth, mname, mode)] = rgb
                if cname == next(iter(sensors)):
                    images[(wname, depth, "reference", "-")] = ref_rgb
            info = {"water": wname, "depth_m": depth, "reference_seconds":
                    float(np.asarray(ref.get("seconds", np.nan))),
                    "pixels": size[0] * size[1], "spp": spp,
                    "numpy_shading_seconds": numpy_seconds,
                    "kd_measured": np.asarray(kd_res["kd"]).tolist(),
                    "kd_measured_stderr": np.asarray(kd_res["kd_stderr"]).tolist(),
                    "kd_database": water.on_bands(REFERENCE_BANDS).kd.tolist()}
            stderr = {r: reference_stderr(ref["band_radiance"], region_masks[r])
                      for r in ("grey", "background") if r in region_masks}
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
                       "light": light.describe(),
                       "seabed": None if seabed_below_m is None else
                       {"below_camera_m": float(seabed_below_m),
                        "albedo": float(seabed_albedo)}}}


def summarise(rows, *, region="image") -> list[dict]:
    """Mean over cameras per (water, depth, method, kd) for one region."""
    groups = {}
    for r in rows:
        if r["region"] != region:
            continue
        groups.setdefault((r["water"], r["depth_m"], r["method"], r["kd"]), []).append(r)
    out = []
    for (w, d, mth, kd), rs in groups.items():
        out.append({"water": w, "depth_m": d, "method": mth, "kd": kd, "cameras": len(rs),
                    **{k: float(np.mean([r[k] for r in rs]))
                       for k in ("rmse_rel", "hsv", "hue_deg", "ciede2000", "mean_ratio")
                       + (("ssim",) if region == "image" else ())}})
    return out


def converged_means(rows, scenes, *, region) -> list[dict]:
    """Mean over the converged scenes (and cameras) per (method, kd) for one region.

    ``scenes`` are the study's scene records (``converged`` from
    :func:`reference_stderr`); an error in a scene whose reference is
    mostly Monte Carlo noise says nothing about the model.
    """
    ok = {(sc["water"], sc["depth_m"]) for sc in scenes if sc.get("converged")}
    per_scene = [r for r in summarise(rows, region=region) if (r["water"], r["depth_m"]) in ok]
    groups = {}
    for r in per_scene:
        groups.setdefault((r["method"], r["kd"]), []).append(r)
    return [{"method": m, "kd": kd, "scenes": len(rs),
             **{k: float(np.mean([r[k] for r in rs]))
                for k in ("rmse_rel", "hsv", "hue_deg", "ciede2000", "mean_ratio")}}
            for (m, kd), rs in sorted(groups.items())]


def format_converged(rows, scenes, regions=("grey", "patch_means", "background")) -> str:
    """Table of :func:`converged_means` for ``regions``, with the scenes left out."""
    left_out = [f"{sc['water']} {sc['depth_m']:g} m" for sc in scenes if not sc.get("converged")]
    lines = [f"mean over scenes whose reference converged (standard error of the grey and "
             f"background means <= {CONVERGED_STDERR:.0%}); left out: "
             + (", ".join(left_out) or "none")]
    cols = ["rmse_rel", "hue_deg", "mean_ratio", "hsv", "ciede2000"]
    for region in regions:
        lines.append(f"region: {region}")
        lines.append(f"{'method':>20s} {'Kd':>9s} {'scenes':>6s} "
                     + " ".join(f"{c:>10s}" for c in cols))
        for r in converged_means(rows, scenes, region=region):
            lines.append(f"{r['method']:>20s} {r['kd']:>9s} {r['scenes']:6d} "
                         + " ".join(f"{r[c]:10.4f}" for c in cols))
    return "\n".join(lines)


def format_summary(rows, region="image") -> str:
    s = summarise(rows, region=region)
    cols = ["rmse_rel", "hsv", "hue_deg", "ciede2000", "mean_ratio"]
    lines = [f"region: {region} (mean over cameras)",
             f"{'water':>5s} {'depth':>5s} {'method':>20s} {'Kd':>9s} "
             + " ".join(f"{c:>10s}" for c in cols)]
    for r in sorted(s, key=lambda r: (r["water"], r["depth_m"], r["method"], r["kd"])):
        lines.append(f"{r['water']:>5s} {r['depth_m']:5.1f} {r['method']:>20s} {r['kd']:>9s} "
                     + " ".join(f"{r[c]:10.4f}" for c in cols))
    return "\n".join(lines)


def format_timing(scenes) -> str:
    """Reference vs aquaspec time per scene at equal pixel count (and speed-ups)."""
    lines = ["time per image at equal pixel count (reference: Mitsuba; NumPy: shade_gbuffer "
             "in float64 at the largest n; GPU: one frame at the largest n)",
             f"{'water':>5s} {'depth':>5s} {'pixels':>7s} {'spp':>5s} {'reference s':>11s} "
             f"{'NumPy s':>11s} {'speed-up':>9s} {'GPU ms':>8s} {'speed-up':>9s}"]
    for sc in scenes:
        ref = sc["reference_seconds"]
        np_s = sc["numpy_shading_seconds"]
        key = max((k for k in np_s if not k.startswith("rgb")), default=None,
                  key=lambda k: int(k.rsplit("n", 1)[-1]))
        t_np = np_s.get(key, np.nan) if key else np.nan
        gpu = sc.get("gpu_frame_seconds")
        gpu_txt = (f"{gpu * 1e3:8.1f} {ref / gpu:9.0f}" if gpu else f"{'-':>8s} {'-':>9s}")
        lines.append(f"{sc['water']:>5s} {sc['depth_m']:5.1f} {sc['pixels']:7d} {sc['spp']:5d} "
                     f"{ref:11.2f} {t_np:11.3f} {ref / t_np:9.0f} {gpu_txt}")
    return "\n".join(lines)


def write_results(result, out_dir) -> dict:
    """CSV and JSON of every row, the per-scene summary, and the plots; returns paths."""
    from aquaspec.io.output import write_file_atomically
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = result["rows"]
    buf = io.StringIO()
    # Every row's keys in first-seen order (only the whole-image rows have SSIM).
    fields = list(dict.fromkeys(k for r in rows for k in r))
    w = csv.DictWriter(buf, fieldnames=fields, restval="")
    w.writeheader()
    for r in rows:
        w.writerow(r)
    text = buf.getvalue()
    paths = {"csv": out / "validation.csv", "json": out / "validation.json",
             "figure": out / "error_per_scene.png",
             "figure_measured_kd": out / "error_per_scene_measured_kd.png",
             "panels": out / "panels.png"}
    write_file_atomically(paths["csv"], lambda t: Path(t).write_text(text))
    doc = json.dumps({"params": result["params"], "scenes": result["scenes"],
                      "waters": result.get("waters", {}),
                      "summary": {reg: summarise(rows, region=reg) for reg in REGIONS},
                      "rows": rows}, indent=1)
    write_file_atomically(paths["json"], lambda t: Path(t).write_text(doc))
    order = result["params"]["waters"]
    plot_errors(rows, paths["figure"], kd="database", order=order)
    if any(r["kd"] == "measured" for r in rows):
        plot_errors(rows, paths["figure_measured_kd"], kd="measured", order=order)
    else:
        del paths["figure_measured_kd"]
    plot_panels(result["images"], paths["panels"])
    return {k: str(v) for k, v in paths.items()}


def plot_errors(rows, path, *, region="patch_means", kd="database", order=None):
    """The thesis's Figure 6.5: error per scene (mean over cameras), spectral vs RGB.

    One row per metric (HSV distance, relative RMSE on a log axis,
    CIEDE2000), one group of bars per scene in the study's order, one bar
    per method with Kd mode ``kd`` (Unreal's water does not use Kd: always shown).
    ``region`` defaults to the patch means, the low-noise comparison.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from aquaspec.io.output import write_file_atomically
    s = [r for r in summarise(rows, region=region)
         if r["kd"] == kd or r["method"] == "unreal"]
    order = list(order or [])
    scenes = sorted({(r["water"], r["depth_m"]) for r in s},
                    key=lambda x: (order.index(x[0]) if x[0] in order else len(order), x[0], x[1]))

    def method_key(m):
        # Spectral then RGB per model, baselines last.
        base = m.replace("rgb-", "").rsplit("-n", 1)[0]
        rank = 2 if m in ("unreal", "ifm") else (1 if m.startswith("rgb-") else 0)
        return (m in ("unreal", "ifm"), base, rank, m)
    methods = sorted({r["method"] for r in s}, key=method_key)
    # The same colour for a method in every figure of the study.
    colour_of = {m: i for i, m in enumerate(sorted({r["method"] for r in rows}, key=method_key))}
    metrics_ = (("hsv", "HSV distance", False), ("rmse_rel", "relative RMSE", True),
                ("ciede2000", "CIEDE2000", False))
    fig, axes = plt.subplots(len(metrics_), 1, figsize=(max(7, len(scenes) * 0.8), 8),
                             sharex=True)
    x = np.arange(len(scenes))
    width = 0.8 / max(1, len(methods))
    cmap = plt.get_cmap("tab10")
    for i, mth in enumerate(methods):
        for ax, (key, _, _) in zip(axes, metrics_):
            vals = [next((r[key] for r in s if (r["water"], r["depth_m"]) == sc
                          and r["method"] == mth), np.nan) for sc in scenes]
            ax.bar(x + i * width, vals, width, label=mth, color=cmap(colour_of[mth] % 10))
    for ax, (_, label, log) in zip(axes, metrics_):
        ax.set_ylabel(label)
        if log:
            ax.set_yscale("log")
    axes[-1].set_xticks(x + 0.4 - width / 2, [f"{w} {d:g} m" for w, d in scenes], rotation=45)
    axes[0].legend(fontsize=7, ncol=4)
    axes[0].set_title(f"error per scene, {region.replace('_', ' ')} (mean over cameras, "
                      f"{kd} Kd)")
    fig.tight_layout()
    try:
        write_file_atomically(path, lambda t: fig.savefig(t, format="png", dpi=100))
    finally:
        plt.close(fig)


def plot_panels(images, path):
    """Reference / ours (largest n, seeds) / RGB / difference, per scene (first camera)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from aquaspec.io.output import write_file_atomically
    scenes = sorted({(w, d) for (w, d, m, k) in images}, key=lambda x: (x[0], x[1]))
    ours = sorted({m for (_, _, m, k) in images if m.startswith("seeds-n")},
                  key=lambda m: int(m.split("n")[-1]))[-1:]
    fig, axes = plt.subplots(len(scenes), 4, figsize=(10, 2.2 * len(scenes)), squeeze=False)
    for i, (w, d) in enumerate(scenes):
        ref = images[(w, d, "reference", "-")]
        scale = 0.8 / max(float(np.percentile(ref, 99)), 1e-300)
        ours_img = images.get((w, d, ours[0], "database")) if ours else None
        rgb_img = images.get((w, d, "rgb-seeds-n3", "database"))
        panels = [("reference", ref), (ours[0] if ours else "ours", ours_img),
                  ("RGB n=3", rgb_img),
                  ("|ours - ref|", None if ours_img is None else np.abs(ours_img - ref) * 4)]
        for ax, (title, img) in zip(axes[i], panels):
            ax.set_axis_off()
            if img is not None:
                ax.imshow(np.clip(img * scale, 0, 1) ** (1 / 2.2))
            ax.set_title(f"{w} {d:g} m: {title}" if ax is axes[i][0] else title, fontsize=8)
    fig.tight_layout()
    try:
        write_file_atomically(path, lambda t: fig.savefig(t, format="png", dpi=100))
    finally:
        plt.close(fig)
