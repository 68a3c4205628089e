"""The cost study: frame time per pass against the number of bands.

For each image size and band count the built-in scene is rendered entirely
on the GPU and each pass is timed with GPU timestamp queries (the wall clock
around submit-and-wait where the driver has none). A frame is the geometry
pass (rasterising into the G-buffer) and the spectral shading pass with the
display transform fused in (``DeferredPass.encode(display=True)``: linear
camera RGB never goes through memory); the display settings (exposure,
white balance) are resolved once beforehand, as an interactive view carries
them from frame to frame. The separate shading and display passes, which
``aquaspec render`` uses because it also writes the linear image, are timed
too. Reported:

- the median time of each pass over ``frames`` frames after ``warmup``;
- the whole frame (geometry + fused shading and display) and frames per
  second, and the same frame submitted at once (wall clock);
- the linear fit ``t(n) = t0 + n t1`` of the frame time (thesis Fig. 6.7);
- three ratios measured in the same run: the NumPy reference shading and
  display of the same G-buffer against our frame; n = 8 against n = 3 (the
  cost of going spectral); the deferred pass against a trivial pass that
  only reads the G-buffer and writes the output (distance from the memory
  floor);
- with ``compare_seeds`` (``--ms-model lightfield --compare-seeds``), the
  seeds' frame on the same G-buffer, timed in the same run beside the
  light-field frame, and their ratio (the cost of the better model).

The machine may be shared and noisy: compare ratios from one run, not
absolute times across runs.
"""

from __future__ import annotations

import time

import numpy as np

from .bands import Bands
from .errors import AquaspecError

DEFAULT_SIZES = ((1280, 720), (1920, 1080))
DEFAULT_BANDS = (3, 8, 16, 32, 64)


class _Geometry:
    """The geometry pass (rasterising into the shading pass's G-buffer textures), as one timed pass."""

    def __init__(self, renderer, scene, camera):
        self.r, self.scene, self.camera = renderer, scene, camera

    def encode(self, encoder, timestamp_writes=None):
        self.r.raster.render_to(self.r.deferred, self.scene, self.camera, encoder=encoder,
                                timestamp_writes=timestamp_writes)


class _Fused:
    """A shading pass with the display transform fused in (``encode(display=True)``)."""

    def __init__(self, shading):
        self.shading = shading

    def encode(self, encoder, timestamp_writes=None):
        self.shading.encode(encoder, timestamp_writes, display=True)


def _frame_wall_ms(renderer, passes, frames, warmup):
    """Median wall-clock time of a whole frame submitted at once (submit + wait)."""
    dev = renderer.deferred.device
    out = []
    for f in range(warmup + frames):
        enc = dev.create_command_encoder()
        for p in passes:
            p.encode(enc)
        t0 = time.perf_counter()
        dev.queue.submit([enc.finish()])
        dev.queue.read_buffer(renderer.deferred._status)  # waits for the frame
        if f >= warmup:
            out.append((time.perf_counter() - t0) * 1e3)
    return float(np.median(out))


def run_bench(*, sizes=DEFAULT_SIZES, bands=DEFAULT_BANDS, frames: int = 20, warmup: int = 3,
              water="IB", depth_m: float = 5.0, sensor="human", numpy_reference: bool = True,
              ms_model: str | None = None, phase: str = "petzold", compare_seeds: bool = False,
              cone_spread: bool | None = None, spread_scattering: str = "single",
              progress=None) -> dict:
    """Run the cost study; returns a JSON-ready dict (see the module docstring)."""
    from .display import display_settings, to_display
    from .gpu.buffers import time_passes
    from .gpu.copy_pass import CopyPass
    from .gpu.device import adapter_info
    from .gpu.display_pass import DisplayPass
    from .light import surface_light
    from .renderer import Renderer, SpectralSetup
    from .scene.builtin import builtin_scene
    from .sensors import get_sensor
    from .shading import shade_gbuffer
    from .water import get_water

    say = progress or (lambda m: None)
    if frames < 20:
        say(f"note: {frames} frames (the study asks for at least 20)")
    if not sizes or not bands:
        raise AquaspecError("bench needs at least one size and one band count")
    from .model import DEFAULT_MS_MODEL, cone_spread_for
    ms_model = DEFAULT_MS_MODEL if ms_model is None else ms_model
    cone_spread = cone_spread_for(ms_model, cone_spread)
    if compare_seeds and ms_model == "seeds":
        raise AquaspecError("compare_seeds times the seeds' frame beside another model's: it "
                            "needs ms_model='lightfield'")
    w_obj, s_obj, light = get_water(water), get_sensor(sensor), surface_light("overcast")
    # lavapipe runs a command buffer when it is submitted and its timestamps
    # do not bracket the work of each pass (seen here: 0.1 ms for a deferred
    # pass whose submit-and-wait takes 30 ms), so software adapters are timed
    # by the wall clock around submit + wait, one pass at a time.
    timing = "wall-clock" if adapter_info().get("adapter_type") == "CPU" else "auto"
    rows = []
    numpy_rows = []
    for width, height in sizes:
        scene, camera = builtin_scene(depth_m, width=width, height=height)
        for n in bands:
            setup = SpectralSetup(w_obj, s_obj, light, Bands(n), ms_model=ms_model, phase=phase,
                                  cone_spread=cone_spread, spread_scattering=spread_scattering)
            r = Renderer(width, height, n)
            geometry = _Geometry(r, scene, camera)
            r.set_spectral(setup, scene.materials)
            rgb = r.render_scene(scene, camera, setup)
            shading = r.lightfield if ms_model == "lightfield" else r.deferred
            disp = DisplayPass(width, height, device=r.deferred.device)
            disp.use_input(shading.rgb_buffer)
            settings = disp.set_from_image(rgb)
            passes = {"geometry": geometry, "deferred": shading, "display": disp,
                      "copy": CopyPass(r.deferred)}
            # The light-field pass has no fused display yet: its frame is
            # geometry + shading + display.
            fusable = hasattr(shading, "set_display")
            if fusable:
                shading.set_display(exposure_ev=settings["exposure_ev"],
                                    white_balance_gains=settings["white_balance_gains"],
                                    matrix=settings["matrix"], tonemap=settings["tonemap"])
                passes["shade_display"] = _Fused(shading)
            if compare_seeds:
                # The seeds' shading of the same G-buffer, with the same display
                # settings, in the same timing run.
                seeds = SpectralSetup(w_obj, s_obj, light, Bands(n))
                r.deferred.set_medium(**seeds.medium(scene.materials))
                r.deferred.set_display(exposure_ev=settings["exposure_ev"],
                                       white_balance_gains=settings["white_balance_gains"],
                                       matrix=settings["matrix"], tonemap=settings["tonemap"])
                passes["shade_display_seeds"] = _Fused(r.deferred)
            times = time_passes(passes, method=timing, frames=frames, warmup=warmup,
                                device=r.deferred.device)
            unfused = times.ms["geometry"] + times.ms["deferred"] + times.ms["display"]
            if fusable:
                frame = times.ms["geometry"] + times.ms["shade_display"]
                wall = _frame_wall_ms(r, [geometry, passes["shade_display"]], frames, warmup)
            else:
                times.ms["shade_display"] = times.ms["deferred"] + times.ms["display"]
                frame = unfused
                wall = _frame_wall_ms(r, [geometry, shading, disp], frames, warmup)
            row = {"width": width, "height": height, "bands": n, **{f"{k}_ms": v for k, v in
                   times.ms.items()}, "frame_ms": frame, "fps": 1e3 / frame,
                   "frame_wall_ms": wall, "frame_unfused_ms": unfused, "timing": times.method}
            if compare_seeds:
                row["seeds_frame_ms"] = times.ms["geometry"] + times.ms["shade_display_seeds"]
                row["over_seeds"] = frame / row["seeds_frame_ms"]
                say(f"{width}x{height} n={n:3d}: seeds' frame {row['seeds_frame_ms']:7.2f} ms in "
                    f"the same run: {ms_model} / seeds = {row['over_seeds']:.3f}")
            rows.append(row)
            say(f"{width}x{height} n={n:3d}: frame {frame:7.2f} ms ({1e3 / frame:6.1f} fps) "
                f"= geometry {times.ms['geometry']:.2f} + shade+display "
                f"{times.ms['shade_display']:.2f} | separate passes: deferred "
                f"{times.ms['deferred']:.2f} display {times.ms['display']:.2f} copy "
                f"{times.ms['copy']:.2f} | frame submitted at once {wall:.2f} ms")
            if numpy_reference and n == 8:
                gb = r.raster.render(scene, camera)
                t0 = time.perf_counter()
                lin = shade_gbuffer(gb, **setup.medium(gb.materials),
                                    lightfield=setup.lightfield_tables())["camera_rgb"]
                to_display(lin, **{"exposure": display_settings(lin)["exposure_ev"]})
                numpy_ms = (time.perf_counter() - t0) * 1e3
                numpy_rows.append({"width": width, "height": height, "bands": n,
                                   "numpy_ms": numpy_ms, "gpu_frame_ms": frame,
                                   "numpy_over_gpu": numpy_ms / frame})
                say(f"{width}x{height} n=8: NumPy reference {numpy_ms:.0f} ms = "
                    f"{numpy_ms / frame:.1f} x our frame")
    fits, ratios = [], []
    for width, height in sizes:
        sel = [x for x in rows if (x["width"], x["height"]) == (width, height)]
        ns = np.array([x["bands"] for x in sel], float)
        ts = np.array([x["frame_ms"] for x in sel])
        td = np.array([x["deferred_ms"] for x in sel])
        if len(ns) >= 2:
            t1, t0 = np.polyfit(ns, ts, 1)
            d1, d0 = np.polyfit(ns, td, 1)
            fits.append({"width": width, "height": height, "t0_ms": float(t0),
                         "t1_ms_per_band": float(t1), "deferred_t0_ms": float(d0),
                         "deferred_t1_ms_per_band": float(d1)})
        by_n = {x["bands"]: x for x in sel}
        entry = {"width": width, "height": height}
        if 8 in by_n and 3 in by_n:
            entry["n8_over_n3"] = by_n[8]["frame_ms"] / by_n[3]["frame_ms"]
        if 8 in by_n:
            entry["deferred_over_copy_n8"] = by_n[8]["deferred_ms"] / by_n[8]["copy_ms"]
            if "over_seeds" in by_n[8]:
                entry[f"{ms_model}_over_seeds_n8"] = by_n[8]["over_seeds"]
        for x in numpy_rows:
            if (x["width"], x["height"]) == (width, height):
                entry["numpy_over_gpu_n8"] = x["numpy_over_gpu"]
        ratios.append(entry)
    return {"adapter": adapter_info(), "frames": frames, "warmup": warmup,
            "ms_model": ms_model, **({"phase": phase, "cone_spread": cone_spread,
                                        "spread_scattering": spread_scattering}
                                     if ms_model != "seeds" else {}),
            "water": w_obj.describe(), "sensor": s_obj.describe(), "depth_m": depth_m,
            "rows": rows, "numpy_reference": numpy_rows, "fits": fits, "ratios": ratios}


def format_table(result: dict) -> str:
    lines = [f"adapter: {result['adapter'].get('device')} ({result['adapter'].get('adapter_type')}),"
             f" median of {result['frames']} frames after {result['warmup']} warm-up",
             "frame = geometry + shade+display (the display transform fused into the shading "
             "pass); deferred and display: the same work as two passes; wall: the frame "
             "submitted at once",
             f"{'size':>10s} {'n':>4s} {'geometry':>9s} {'shade+disp':>10s} {'frame':>8s} "
             f"{'fps':>6s} {'wall':>7s} | {'deferred':>8s} {'display':>8s} {'copy':>6s}  (ms)"]
    compare = any("over_seeds" in x for x in result["rows"])
    if compare:
        lines[-1] += f" | {'seeds':>7s} {'ratio':>6s}"
    for x in result["rows"]:
        line = (f"{x['width']:>5d}x{x['height']:<4d} {x['bands']:>4d} {x['geometry_ms']:9.2f} "
                f"{x['shade_display_ms']:10.2f} {x['frame_ms']:8.2f} {x['fps']:6.1f} "
                f"{x['frame_wall_ms']:7.2f} | {x['deferred_ms']:8.2f} "
                f"{x['display_ms']:8.2f} {x['copy_ms']:6.2f}")
        if compare:
            line += f" | {x['seeds_frame_ms']:7.2f} {x['over_seeds']:6.3f}"
        lines.append(line)
    for f in result["fits"]:
        lines.append(f"fit {f['width']}x{f['height']}: t(n) = {f['t0_ms']:.2f} ms + n * "
                     f"{f['t1_ms_per_band']:.3f} ms (deferred alone: {f['deferred_t0_ms']:.2f} + "
                     f"n * {f['deferred_t1_ms_per_band']:.3f})")
    for r in result["ratios"]:
        parts = [f"{k} = {v:.2f}" for k, v in r.items() if k not in ("width", "height")]
        lines.append(f"ratios {r['width']}x{r['height']}: " + ", ".join(parts))
    return "\n".join(lines)


def plot(result: dict, path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from .output import write_file_atomically
    fig, ax = plt.subplots(figsize=(6, 4))
    for f in result["fits"]:
        sel = [x for x in result["rows"] if (x["width"], x["height"]) == (f["width"], f["height"])]
        ns = np.array([x["bands"] for x in sel])
        line, = ax.plot(ns, [x["frame_ms"] for x in sel], "o", label=f"{f['width']}x{f['height']}")
        xs = np.linspace(0, ns.max(), 50)
        ax.plot(xs, f["t0_ms"] + f["t1_ms_per_band"] * xs, "-", color=line.get_color(), alpha=0.6)
    ax.set_xlabel("bands n")
    ax.set_ylabel("frame time (ms)")
    ax.set_title(f"aquaspec frame time, {result['adapter'].get('device')}", fontsize=9)
    ax.legend()
    fig.tight_layout()
    try:
        write_file_atomically(path, lambda tmp: fig.savefig(tmp, format="png", dpi=110))
    finally:
        plt.close(fig)
