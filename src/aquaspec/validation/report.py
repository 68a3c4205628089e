"""The validation study's results for people: tables, CSV and JSON, plots.

What :func:`aquaspec.validation.study.run_study` returns, summarised per
scene and region (:func:`summarise`, :func:`converged_means`), printed
(:func:`format_summary`, :func:`format_converged`, :func:`format_attenuation`,
:func:`format_timing`, and per scene the errors the occlusion issue sets,
:func:`format_scenes`) and written with its figures (:func:`write_results`).
Scenes are told apart by their ``scene`` (:data:`.scenes.SCENES`), water and
depth.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import NamedTuple

import numpy as np

from aquaspec.io.atomic import write_file_atomically
from aquaspec.io.png import write_figure
from aquaspec.transport.models import DEFAULT_MS_MODEL, ms_model_name
from aquaspec.validation.reference import REFERENCE_BANDS
from aquaspec.validation.study import CONVERGED_STDERR, KD_DEPTHS_M, REGIONS


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


#: Errors of a region's mean colour (:mod:`.study`), averaged where the rows have them.
MEAN_COLOUR_KEYS = ("mean_hue_deg", "ratio_r", "ratio_g", "ratio_b", "mean_abs_error")


def _scene_of(r) -> tuple:
    """(scene, water, depth) of a row or scene record."""
    return (r.get("scene", "board"), r["water"], r["depth_m"])


def summarise(rows, *, region="image") -> list[dict]:
    """Mean over cameras per (scene, water, depth, method, kd) for one region."""
    groups = {}
    for r in rows:
        if r["region"] != region:
            continue
        groups.setdefault((*_scene_of(r), r["method"], r["kd"]), []).append(r)
    out = []
    for (sc, w, d, mth, kd), rs in groups.items():
        keys = ("rmse_rel", "hsv", "hue_deg", "ciede2000", "mean_ratio") + (
            ("ssim",) if region == "image" else ()) + tuple(
            k for k in MEAN_COLOUR_KEYS if all(k in r for r in rs))
        out.append({"scene": sc, "water": w, "depth_m": d, "method": mth, "kd": kd,
                    "cameras": len(rs), **{k: float(np.mean([r[k] for r in rs])) for k in keys}})
    return out


def converged_means(rows, scenes, *, region) -> list[dict]:
    """Mean over the converged scenes (and cameras) per (method, kd) for one region.

    ``scenes`` are the study's scene records (``converged`` from
    :func:`reference_stderr`); an error in a scene whose reference is
    mostly Monte Carlo noise says nothing about the model.
    """
    ok = {_scene_of(sc) for sc in scenes if sc.get("converged")}
    per_scene = [r for r in summarise(rows, region=region) if _scene_of(r) in ok]
    groups = {}
    for r in per_scene:
        groups.setdefault((r["scene"], r["method"], r["kd"]), []).append(r)
    return [{"scene": sc, "method": m, "kd": kd, "scenes": len(rs),
             **{k: float(np.mean([r[k] for r in rs]))
                for k in ("rmse_rel", "hsv", "hue_deg", "ciede2000", "mean_ratio")}}
            for (sc, m, kd), rs in sorted(groups.items())]


def format_converged(rows, scenes, regions=("grey", "patch_means", "background")) -> str:
    """Table of :func:`converged_means` for ``regions``, with the scenes left out."""
    left_out = [_scene_label(sc) for sc in scenes if not sc.get("converged")]
    lines = [f"mean over scenes whose reference converged (standard error of the grey and "
             f"background means <= {CONVERGED_STDERR:.0%}); left out: "
             + (", ".join(left_out) or "none")]
    cols = ["rmse_rel", "hue_deg", "mean_ratio", "hsv", "ciede2000"]
    for region in regions:
        lines.append(f"region: {region}")
        lines.append(f"{'scene':>6s} {'method':>20s} {'Kd':>9s} {'scenes':>6s} "
                     + " ".join(f"{c:>10s}" for c in cols))
        for r in converged_means(rows, scenes, region=region):
            lines.append(f"{r['scene']:>6s} {r['method']:>20s} {r['kd']:>9s} {r['scenes']:6d} "
                         + " ".join(f"{r[c]:10.4f}" for c in cols))
    return "\n".join(lines)


def format_summary(rows, region="image") -> str:
    s = summarise(rows, region=region)
    cols = ["rmse_rel", "hsv", "hue_deg", "ciede2000", "mean_ratio"]
    lines = [f"region: {region} (mean over cameras)",
             f"{'scene':>6s} {'water':>5s} {'depth':>5s} {'method':>20s} {'Kd':>9s} "
             + " ".join(f"{c:>10s}" for c in cols)]
    for r in sorted(s, key=lambda r: (r["scene"], r["water"], r["depth_m"], r["method"],
                                      r["kd"])):
        lines.append(f"{r['scene']:>6s} {r['water']:>5s} {r['depth_m']:5.1f} "
                     f"{r['method']:>20s} {r['kd']:>9s} "
                     + " ".join(f"{r[c]:10.4f}" for c in cols))
    return "\n".join(lines)


def _scene_label(sc) -> str:
    """``"IB 5 m"``, or ``"ledge IB 5 m"`` for a scene other than the thesis's board."""
    name, w, d = _scene_of(sc)
    return ("" if name == "board" else f"{name} ") + f"{w} {d:g} m"


def scene_errors(rows, scenes, *, method: str, kd: str = "database") -> list[dict]:
    """Per scene, ``method``'s errors as the occlusion issue tabulates them.

    Mean over cameras (and the cameras' range) of the error of the region's
    mean brightness (``mean_ratio - 1``) of the grey patch and of the shaded
    seabed, the patches' mean absolute error (:func:`.study._patch_abs_error`),
    and the hue angle between the region means; None where a region has no
    pixel. Also whether the scene's reference converged.
    """
    by_scene = {}
    for r in rows:
        if r["method"] == method and r["kd"] == kd:
            by_scene.setdefault(_scene_of(r), {}).setdefault(r["region"], []).append(r)
    out = []
    for sc in scenes:
        regs = by_scene.get(_scene_of(sc))
        if regs is None:
            continue
        rec = {"scene": _scene_of(sc)[0], "water": sc["water"], "depth_m": sc["depth_m"],
               "converged": bool(sc.get("converged")), "method": method}
        for region, field in (("grey", "mean_ratio"), ("shaded_seabed", "mean_ratio"),
                              ("patch_means", "mean_abs_error")):
            rs = regs.get(region, [])
            err = [r[field] - (1.0 if field == "mean_ratio" else 0.0) for r in rs]
            hue = [r["hue_deg" if region == "patch_means" else "mean_hue_deg"] for r in rs]
            rec[region] = None if not rs else {
                "error": float(np.mean(err)), "min": float(np.min(err)),
                "max": float(np.max(err)), "hue_deg": float(np.mean(hue)),
                **({"rgb_ratio": [float(np.mean([r[f"ratio_{c}"] for r in rs]))
                                  for c in "rgb"]} if field == "mean_ratio" else {})}
        out.append(rec)
    return out


def format_scenes(rows, scenes, methods) -> str:
    """Table of :func:`scene_errors` for each of ``methods`` (database Kd)."""
    def cell(v, signed=True):
        if v is None:
            return f"{'-':>24s}"
        sign = "+" if signed else ""
        return (f"{v['error']:{sign}7.1%} [{v['min']:{sign}.0%},{v['max']:{sign}.0%}]"
                f" {v['hue_deg']:4.2f}deg").rjust(24)
    lines = ["per scene: error of the region's mean brightness, mean over cameras "
             "[their range], and hue between the region means; patches: mean absolute "
             "error of the 24 patch means (* = reference not converged)",
             f"{'scene':>18s} {'method':>20s} {'grey':>24s} {'patches (mean abs.)':>24s} "
             f"{'shaded seabed':>24s}"]
    for m in methods:
        for r in scene_errors(rows, scenes, method=m):
            label = _scene_label(r) + ("" if r["converged"] else " *")
            lines.append(f"{label:>18s} {m:>20s} {cell(r['grey'])} "
                         f"{cell(r['patch_means'], signed=False)} {cell(r['shaded_seabed'])}")
    return "\n".join(lines)


def format_timing(scenes) -> str:
    """Reference vs aquaspec time per scene at equal pixel count (and speed-ups)."""
    lines = ["time per image at equal pixel count (reference: Mitsuba; NumPy: shade_gbuffer "
             "in float64 at the largest n; GPU: one frame at the largest n)",
             f"{'scene':>6s} {'water':>5s} {'depth':>5s} {'pixels':>7s} {'spp':>5s} "
             f"{'reference s':>11s} "
             f"{'NumPy s':>11s} {'speed-up':>9s} {'GPU ms':>8s} {'speed-up':>9s}"]
    for sc in scenes:
        ref = sc["reference_seconds"]
        np_s = sc["numpy_shading_seconds"]
        key = max((k for k in np_s if not k.startswith("rgb")), default=None,
                  key=lambda k: int(k.rsplit("n", 1)[-1]))
        t_np = np_s.get(key, np.nan) if key else np.nan
        gpu = sc.get("gpu_frame_seconds")
        gpu_txt = (f"{gpu * 1e3:8.1f} {ref / gpu:9.0f}" if gpu else f"{'-':>8s} {'-':>9s}")
        lines.append(f"{_scene_of(sc)[0]:>6s} {sc['water']:>5s} {sc['depth_m']:5.1f} "
                     f"{sc['pixels']:7d} {sc['spp']:5d} "
                     f"{ref:11.2f} {t_np:11.3f} {ref / t_np:9.0f} {gpu_txt}")
    return "\n".join(lines)


def write_results(result, out_dir) -> dict:
    """CSV and JSON of every row, the per-scene summary, and the plots; returns paths."""
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
    plot_panels(result["images"], paths["panels"], result["params"])
    return {k: str(v) for k, v in paths.items()}


def plot_errors(rows, path, *, region="patch_means", kd="database", order=None):
    """The thesis's Figure 6.5: error per scene (mean over cameras), spectral vs RGB.

    One row per metric (HSV distance, relative RMSE on a log axis,
    CIEDE2000), one group of bars per scene in the study's order, one bar
    per method with Kd mode ``kd`` (Unreal's water does not use Kd: always shown).
    ``region`` defaults to the patch means, the low-noise comparison.
    """
    import matplotlib  # deferred: matplotlib takes 0.3 s to import; only the plots need it
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # deferred: as matplotlib
    s = [r for r in summarise(rows, region=region)
         if r["kd"] == kd or r["method"] == "unreal"]
    order = list(order or [])
    scenes = sorted({_scene_of(r) for r in s},
                    key=lambda x: (x[0], order.index(x[1]) if x[1] in order else len(order),
                                   x[1], x[2]))

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
            vals = [next((r[key] for r in s if _scene_of(r) == sc
                          and r["method"] == mth), np.nan) for sc in scenes]
            ax.bar(x + i * width, vals, width, label=mth, color=cmap(colour_of[mth] % 10))
    for ax, (_, label, log) in zip(axes, metrics_):
        ax.set_ylabel(label)
        if log:
            ax.set_yscale("log")
    axes[-1].set_xticks(x + 0.4 - width / 2,
                        [_scene_label({"scene": n, "water": w, "depth_m": d})
                         for n, w, d in scenes], rotation=45)
    axes[0].legend(fontsize=7, ncol=4)
    axes[0].set_title(f"error per scene, {region.replace('_', ' ')} (mean over cameras, "
                      f"{kd} Kd)")
    fig.tight_layout()
    write_figure(path, fig, dpi=100)


class Panel(NamedTuple):
    """A column of :func:`plot_panels`: the image of ``method`` with Kd mode
    ``kd`` (the study's image keys), or with ``difference`` its absolute
    difference from the reference, times :data:`DIFFERENCE_GAIN`."""

    title: str
    method: str
    kd: str = "database"
    difference: bool = False


#: The panels' difference images are this many times brighter than the error.
DIFFERENCE_GAIN = 4.0


def panel_columns(images, params) -> list[Panel]:
    """The columns of :func:`plot_panels` for a study's ``images`` and ``params``.

    The reference; each multiple-scattering model that was run
    (``params["ms_models"]``, in its order) at the largest band count, and
    the light field also without its seabed where it ran so; then the RGB
    n = 3 render and the difference from the reference of the main model:
    the renderer's default (:data:`aquaspec.transport.models.DEFAULT_MS_MODEL`)
    when it ran, else the first (without models, Unreal's water). A model
    given by an alias is titled with its canonical name too. Database Kd.
    """
    n = max(params["band_counts"])
    models = list(params["ms_models"])
    cols = [Panel("reference", "reference", "-")]
    for m in models:
        canonical = ms_model_name(m)
        cols.append(Panel(f"{m}-n{n}" + (f" ({canonical})" if canonical != m else ""),
                          f"{m}-n{n}"))
        deep = f"lightfield-deep-n{n}"
        if m == "lightfield" and any(k[3] == deep for k in images):
            cols.append(Panel(f"{deep} (no seabed)", deep))
    if models:
        main = next((m for m in models if ms_model_name(m) == DEFAULT_MS_MODEL), models[0])
        cols.append(Panel(f"rgb-{main}-n3", f"rgb-{main}-n3"))
        ours = f"{main}-n{n}"
    else:
        ours = "unreal"
        cols.append(Panel(ours, ours))
    cols.append(Panel(f"|{ours} - ref| x{DIFFERENCE_GAIN:g}", ours, difference=True))
    return cols


def plot_panels(images, path, params):
    """One row per scene (first camera), the columns of :func:`panel_columns`.

    ``images`` are keyed ``(scene, water, depth, method, kd)`` (:mod:`.study`)."""
    import matplotlib  # deferred: matplotlib takes 0.3 s to import; only the plots need it
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # deferred: as matplotlib
    scenes = sorted({(n, w, d) for (n, w, d, m, k) in images})
    cols = panel_columns(images, params)
    fig, axes = plt.subplots(len(scenes), len(cols),
                             figsize=(2.5 * len(cols), 2.2 * len(scenes)), squeeze=False)
    for i, (name, w, d) in enumerate(scenes):
        ref = images[(name, w, d, "reference", "-")]
        scale = 0.8 / max(float(np.percentile(ref, 99)), 1e-300)
        for j, col in enumerate(cols):
            img = images[(name, w, d, col.method, col.kd)]
            if col.difference:
                img = np.abs(img - ref) * DIFFERENCE_GAIN
            ax = axes[i][j]
            ax.set_axis_off()
            ax.imshow(np.clip(img * scale, 0, 1) ** (1 / 2.2))
            label = _scene_label({"scene": name, "water": w, "depth_m": d})
            ax.set_title(f"{label}: {col.title}" if j == 0 else col.title, fontsize=8)
    fig.tight_layout()
    write_figure(path, fig, dpi=100)
