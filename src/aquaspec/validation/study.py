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
open-water background.
"""

from __future__ import annotations

import csv
import io
import json
import time
from pathlib import Path

import numpy as np

from ..bands import Bands
from ..errors import AquaspecError
from ..light import surface_light
from ..water import load_water
from . import metrics
from .baselines import render_baseline
from .reference import (MAX_DEPTH, REFERENCE_BANDS, bands_to_rgb, cache_key, measure_kd,
                        render_reference, water_with_kd)
from .scenes import board_scene, masks

DEFAULT_WATERS = ("I", "IA", "IB", "II", "3C")
DEFAULT_DEPTHS = (3.0, 5.0, 9.0)
SCENE_VERSION = "board-v1"
REGIONS = ("image", "patches", "grey", "background", "patch_means")


def default_cache_dir() -> Path:
    import os
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "aquaspec" / "reference"


def _cached(cache_dir, key, compute):
    if cache_dir is None:
        return compute(), False
    path = Path(cache_dir) / f"{key}.npz"
    if path.is_file():
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}, True
    out = compute()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part.npz")
    np.savez_compressed(tmp, **{k: np.asarray(v) for k, v in out.items()
                                if not isinstance(v, (dict, Bands))})
    tmp.replace(path)
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}, False


def _spectral(gb, water, light, n, ms_model, phase_lf, phase_params=(), forward_cone_deg=15.0):
    from ..renderer import SpectralSetup
    from ..sensors import get_sensor
    from ..shading import shade_gbuffer
    setup = SpectralSetup(water, get_sensor("human"), light, Bands(n), ms_model=ms_model,
                          phase=phase_lf, phase_params=phase_params,
                          forward_cone_deg=forward_cone_deg)
    out = shade_gbuffer(gb, **setup.medium(gb.materials), return_radiance=True,
                        lightfield=setup.lightfield_tables())
    return out["radiance"]


def _region_means(rgb, m):
    """(25, 3): mean RGB of each visible patch, then of the open-water background."""
    parts = [rgb[mask].mean(axis=0) for mask in m["patches"] if mask.any()]
    if m["background"].any():
        parts.append(rgb[m["background"]].mean(axis=0))
    return np.array(parts)


def run_study(*, waters=DEFAULT_WATERS, depths=DEFAULT_DEPTHS, sensors: dict, source="solonenko2015",
              size=(96, 72), spp: int = 256, kd_spp: int = 50_000, phase: str = "isotropic",
              g: float = 0.0, band_counts=(8, 16), ms_models=("seeds",),
              kd_modes=("database", "measured"), forward_cone_deg: float = 15.0,
              cache_dir=None, progress=None) -> dict:
    """Run the study; returns ``{"rows": [...], "scenes": [...], "images": {...}}``."""
    from ..gpu.raster import raycast_gbuffer
    say = progress or (lambda m: None)
    if not sensors:
        raise AquaspecError("the study needs at least one sensor")
    light = surface_light("overcast")
    phase_lf = "isotropic" if phase == "isotropic" else "hg"
    rows, scenes, images = [], [], {}
    total = len(waters) * len(depths)
    k = 0
    for wname in waters:
        water = load_water(wname, source)
        kd_key = cache_key(kind="kd", water=wname, source=source, phase=phase, g=g, spp=kd_spp,
                           bands=REFERENCE_BANDS.describe(), max_depth=MAX_DEPTH)
        kd_res, hit = _cached(cache_dir, kd_key, lambda: measure_kd(
            water, light, spp=kd_spp, phase=phase, g=g))
        say(f"[{wname}] Kd measured in the reference{' (cache)' if hit else ''}")
        waters_by_mode = {"database": water,
                          "measured": water_with_kd(water, np.asarray(kd_res["kd"]))}
        for depth in depths:
            k += 1
            scene, cam = board_scene(depth, width=size[0], height=size[1])
            gb = raycast_gbuffer(scene, cam)
            m = masks(gb)
            region_masks = {"image": None, "patches": m["patches"].any(axis=0),
                            "grey": m["grey"], "background": m["background"]}
            empty = [r for r, mk in region_masks.items() if mk is not None and not mk.any()]
            if empty:
                say(f"  note: no pixel in region(s) {', '.join(empty)} at {size[0]}x{size[1]}; "
                    "use a larger --size to measure them")
                region_masks = {r: mk for r, mk in region_masks.items() if r not in empty}
            key = cache_key(kind="render", scene=SCENE_VERSION, water=wname, source=source,
                            depth=depth, size=list(size), spp=spp, phase=phase, g=g,
                            bands=REFERENCE_BANDS.describe(), max_depth=MAX_DEPTH)
            t0 = time.perf_counter()
            ref, hit = _cached(cache_dir, key, lambda: render_reference(
                scene, cam, water, light, spp=spp, phase=phase, g=g))
            say(f"[{k}/{total}] {wname} {depth:g} m: reference "
                f"{'from cache' if hit else f'{time.perf_counter() - t0:.1f} s'}")
            methods = {}
            for mode in kd_modes:
                for ms in ms_models:
                    if ms != "seeds" and mode == "measured":
                        continue   # the light field does not use Kd
                    for n in band_counts + (3,):
                        name = f"{ms}-n{n}" if n != 3 else f"rgb-{ms}-n3"
                        methods[(name, mode)] = ("bands", n, _spectral(
                            gb, waters_by_mode[mode], light, n, ms, phase_lf,
                            (("g", g),) if phase_lf == "hg" else (), forward_cone_deg))
            methods[("unreal", "database")] = ("baseline", "unreal", None)
            methods[("ifm", "database")] = ("baseline", "ifm", None)
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
                    # Mean colour of each patch and of the background: far less
                    # path-tracing noise than per-pixel errors.
                    rows.append({"water": wname, "depth_m": depth, "camera": cname,
                                 "method": mname, "kd": mode, "region": "patch_means",
                                 **metrics.all_metrics(_region_means(ref_rgb, m),
                                                       _region_means(rgb, m), matrix=mat)})
                    if cname == next(iter(sensors)):
                        images[(wname, depth, mname, mode)] = rgb
                if cname == next(iter(sensors)):
                    images[(wname, depth, "reference", "-")] = ref_rgb
            scenes.append({"water": wname, "depth_m": depth, "reference_seconds":
                           float(np.asarray(ref.get("seconds", np.nan))),
                           "pixels": size[0] * size[1], "spp": spp,
                           "kd_measured": np.asarray(kd_res["kd"]).tolist()})
    return {"rows": rows, "scenes": scenes, "images": images,
            "params": {"waters": list(waters), "depths": list(depths), "cameras": list(sensors),
                       "size": list(size), "spp": spp, "kd_spp": kd_spp, "phase": phase, "g": g,
                       "source": source, "band_counts": list(band_counts),
                       "ms_models": list(ms_models), "forward_cone_deg": forward_cone_deg}}


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


def write_results(result, out_dir) -> dict:
    """CSV and JSON of every row, the per-scene summary, and the plots; returns paths."""
    from ..output import write_file_atomically
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = result["rows"]
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0].keys()) + ["ssim"], extrasaction="ignore")
    w.writeheader()
    for r in rows:
        w.writerow(r)
    text = buf.getvalue()
    paths = {"csv": out / "validation.csv", "json": out / "validation.json",
             "figure": out / "error_per_scene.png", "panels": out / "panels.png"}
    write_file_atomically(paths["csv"], lambda t: Path(t).write_text(text))
    doc = json.dumps({"params": result["params"], "scenes": result["scenes"],
                      "summary": {reg: summarise(rows, region=reg) for reg in REGIONS},
                      "rows": rows}, indent=1)
    write_file_atomically(paths["json"], lambda t: Path(t).write_text(doc))
    plot_errors(rows, paths["figure"])
    plot_panels(result["images"], paths["panels"])
    return {k: str(v) for k, v in paths.items()}


def plot_errors(rows, path):
    """The thesis's Figure 6.5: HSV error per scene, spectral vs RGB."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from ..output import write_file_atomically
    s = [r for r in summarise(rows) if r["kd"] == "database"]
    scenes = sorted({(r["water"], r["depth_m"]) for r in s}, key=lambda x: (x[0], x[1]))
    methods = sorted({r["method"] for r in s})
    fig, axes = plt.subplots(2, 1, figsize=(max(6, len(scenes) * 0.7), 6), sharex=True)
    x = np.arange(len(scenes))
    width = 0.8 / max(1, len(methods))
    for i, mth in enumerate(methods):
        for ax, key in zip(axes, ("hsv", "rmse_rel")):
            vals = [next((r[key] for r in s if (r["water"], r["depth_m"]) == sc
                          and r["method"] == mth), np.nan) for sc in scenes]
            ax.bar(x + i * width, vals, width, label=mth)
    axes[0].set_ylabel("HSV distance")
    axes[1].set_ylabel("relative RMSE")
    axes[1].set_xticks(x + 0.4 - width / 2, [f"{w} {d:g} m" for w, d in scenes], rotation=45)
    axes[0].legend(fontsize=7, ncol=3)
    axes[0].set_title("error per scene (mean over cameras, database Kd)")
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
    from ..output import write_file_atomically
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
