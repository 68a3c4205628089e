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
  light-field frame, and their ratio (the cost of the better model; with a
  sun, both frames without it: the sun's passes are the same work for both);
- with a sun (``light="sun-sky"``, :mod:`aquaspec.gpu.passes.sun`), its passes
  each (:class:`aquaspec.apps.sun_passes.SunFrame`). With the light field the
  frame is geometry + the shadow map (kept from the frame before while
  nothing moves; its cost when drawn again is reported beside) + the froxels
  + the shading pass adding the sun in its band loop with the display fused;
  with the seeds' model the sun is added after the shading, so the display
  cannot be fused: geometry + shading + shadow map + froxels + per-pixel sun
  + display. Its ratio to the frame without the sun (geometry + fused
  shading and display) is measured on the same G-buffer in the same run, and
  with ``waves`` (caustics) the ratio of the sun with caustics to the sun
  over a flat surface (a second sun pass without caustics, timed beside it).
  The NumPy reference then shades the sun too (its NumPy shadow map
  included): 1.6 times its time without the sun at 1280x720, 2.7 times with
  caustics (measured here), seconds per size, so it is kept and stays
  comparable with the GPU frame.

The machine may be shared and noisy: compare ratios from one run, not
absolute times across runs.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.display import display_settings, to_display
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.gpu.timing import time_passes
from aquaspec.gpu.device import adapter_info
from aquaspec.gpu.passes.copy import CopyPass
from aquaspec.gpu.passes.display import DisplayPass
from aquaspec.gpu.passes.sun import SunPass
from aquaspec.apps.sun_passes import SunFrame, Unlit
from aquaspec.io.png import write_figure
from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG, surface_light
from aquaspec.medium.water import get_water
from aquaspec.rendering.api import as_waves
from aquaspec.rendering.renderer import Renderer
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.builtin import builtin_scene
from aquaspec.scene.shadowmap import (DEFAULT_MAP_RADIUS_M, DEFAULT_MAP_SIZE, numpy_shadow_map,
                                      shadow_map_spec)
from aquaspec.shading.shade import shade_gbuffer
from aquaspec.transport.froxels import froxel_description
from aquaspec.transport.models import DEFAULT_MS_MODEL, MONZON2022, cone_spread_for, ms_model_name

DEFAULT_SIZES = ((1280, 720), (1920, 1080))
DEFAULT_BANDS = (3, 8, 16, 32, 64)


class _Geometry:
    """The geometry pass (rasterising into the shading pass's G-buffer textures), as one timed pass."""

    def __init__(self, renderer, scene, camera):
        self.r, self.scene, self.camera = renderer, scene, camera

    def encode(self, encoder, timestamp_writes=None):
        self.r.raster.render_to(self.r.deferred.gbuffer, self.scene, self.camera, encoder=encoder,
                                timestamp_writes=timestamp_writes)


class _Fused:
    """A shading pass with the display transform fused in (``encode(display=True)``),
    with the occlusion factors of ``occlusion`` applied (an
    :class:`~aquaspec.gpu.passes.occlusion.OcclusionPass`; None: without)."""

    def __init__(self, shading, occlusion=None):
        self.shading, self.occlusion = shading, occlusion

    def encode(self, encoder, timestamp_writes=None):
        if hasattr(self.shading, "set_sun"):
            self.shading.set_sun(None)          # the frame without the sun
        if hasattr(self.shading, "set_occlusion"):
            self.shading.set_occlusion(self.occlusion)
        self.shading.encode(encoder, timestamp_writes, display=True)


class _OcclusionFactors:
    """The occlusion factors computed again (what a moving camera costs; the
    maps of the static scene are kept), as one timed pass."""

    def __init__(self, renderer, scene, camera):
        self.r, self.scene, self.camera = renderer, scene, camera

    def encode(self, encoder, timestamp_writes=None):
        self.r.occlusion.recompute()
        self.r.encode_occlusion(encoder, self.camera, self.scene, timestamp_writes)


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
        dev.queue.read_buffer(renderer.deferred.output.status_buffer)  # waits for the frame
        if f >= warmup:
            out.append((time.perf_counter() - t0) * 1e3)
    return float(np.median(out))


def run_bench(*, sizes=DEFAULT_SIZES, bands=DEFAULT_BANDS, frames: int = 20, warmup: int = 3,
              water="IB", depth_m: float = 5.0, sensor="human", numpy_reference: bool = True,
              ms_model: str | None = None, phase: str = "petzold", compare_seeds: bool = False,
              cone_spread: bool | None = None, spread_scattering: str = "single",
              light: str = "overcast", sun_elevation_deg: float = 60.0,
              sun_azimuth_deg: float | None = None, sun_shadow_map: int | None = None,
              waves=None, occlusion: bool = False, progress=None) -> dict:
    """Run the cost study; returns a JSON-ready dict (see the module docstring).

    Parameters
    ----------
    occlusion : bool
        Also time the light-field frame with the scene's occlusion of the
        ambient light (:meth:`aquaspec.rendering.renderer.Renderer.set_occlusion`,
        default options): the frame of a static scene and still camera (the
        factors kept) and the factors' pass itself (computed again each frame
        when the camera moves), against the frame without it in the same run.
    light : {"overcast", "d65", "sun-sky"}
        The light at the surface (:func:`aquaspec.light.sky.surface_light`).
        ``sun-sky`` has a sun at ``sun_elevation_deg`` (1-90) and
        ``sun_azimuth_deg`` (default
        :data:`aquaspec.light.sky.DEFAULT_SUN_AZIMUTH_DEG`), whose passes are
        timed too, and the frame with the sun is compared with the frame
        without it.
    sun_shadow_map : int, optional
        Side of the sun's shadow map in texels (16 to 8192; default
        :data:`aquaspec.scene.shadowmap.DEFAULT_MAP_SIZE`).
    waves : aquaspec.light.waves.Waves or float, optional
        A wind sea (or its wind speed in m/s) focusing the sun into caustics;
        needs ``light="sun-sky"``. The sun over a flat surface is timed
        beside it.

    The other parameters: the number of ``frames`` timed after ``warmup``,
    the scene's ``water``, ``depth_m`` and ``sensor``, and the model
    (``ms_model``, ``phase``, ``cone_spread``, ``spread_scattering``) as
    :func:`aquaspec.rendering.api.render` takes them; ``numpy_reference`` and
    ``compare_seeds`` as in the module docstring; ``progress`` is called
    with a line per measurement.
    """
    say = progress or (lambda m: None)
    if frames < 20:
        say(f"note: {frames} frames (the study asks for at least 20)")
    if not sizes or not bands:
        raise AquaspecError("bench needs at least one size and one band count")
    ms_model = ms_model_name(DEFAULT_MS_MODEL if ms_model is None else ms_model)
    cone_spread = cone_spread_for(ms_model, cone_spread)
    if compare_seeds and ms_model == MONZON2022:
        raise AquaspecError("compare_seeds times the seeds' frame beside another model's: it "
                            "needs ms_model='lightfield'")
    light_obj = surface_light(light, sun_elevation_deg=sun_elevation_deg,
                              sun_azimuth_deg=DEFAULT_SUN_AZIMUTH_DEG if sun_azimuth_deg is None
                              else sun_azimuth_deg)
    sun = light_obj.sun
    waves = as_waves(waves)
    if waves is not None and sun is None:
        raise AquaspecError(f"waves focus the sun's beam into caustics: they need "
                            f"light='sun-sky', not {light!r}")
    map_size = DEFAULT_MAP_SIZE if sun_shadow_map is None else sun_shadow_map
    if sun is not None:
        # Checks the size before any GPU work (the spec itself is made per frame).
        shadow_map_spec(np.array([[-1.0] * 3, [1.0] * 3]), np.zeros(3), sun.to_sun,
                        size=map_size)
    if waves is not None:
        say(f"caustics of a {waves.wind_speed:g} m/s sea ({waves.tile_m:g} m tile, "
            f"{waves.grid}x{waves.grid} samples) under the sun")
    w_obj, s_obj = get_water(water), get_sensor(sensor)
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
            setup = SpectralSetup(w_obj, s_obj, light_obj, Bands(n), ms_model=ms_model,
                                  phase=phase, cone_spread=cone_spread,
                                  spread_scattering=spread_scattering, waves=waves)
            r = Renderer(width, height, n)
            r.sun_map_size = map_size
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
                if occlusion and ms_model == "lightfield":
                    r.set_occlusion(True)
                    if not r.encode_occlusion_now(scene, camera):
                        raise AquaspecError("bench --occlusion: the scene has no occluders")
                    passes["occlusion"] = _OcclusionFactors(r, scene, camera)
                    passes["shade_display_occluded"] = _Fused(shading, r.occlusion)
            if compare_seeds:
                # The seeds' shading of the same G-buffer, with the same display
                # settings, in the same timing run.
                seeds = SpectralSetup(w_obj, s_obj, light_obj, Bands(n))
                r.deferred.set_medium(**seeds.medium(scene.materials))
                r.deferred.set_display(exposure_ev=settings["exposure_ev"],
                                       white_balance_gains=settings["white_balance_gains"],
                                       matrix=settings["matrix"], tonemap=settings["tonemap"])
                passes["shade_display_seeds"] = _Fused(r.deferred)
            if sun is not None:
                # render_scene made r.sun with setup's inputs (its shadow map
                # and froxels are there for this camera).
                sun_frame = SunFrame(r, r.sun, scene, camera, shading)
                passes.update({f"sun_{k}": p for k, p in sun_frame.parts().items()})
                if sun_frame.fused:
                    passes["deferred"] = Unlit(shading)    # its linear image without the sun
                if waves is not None:
                    # The same sun over a flat surface, on the same G-buffer.
                    flat = SunPass(r.deferred.device, width, height, n, map_size=map_size)
                    flat_setup = dataclasses.replace(setup, waves=None)
                    medium = flat_setup.medium(scene.materials)
                    flat.set_inputs(flat_setup.sun_inputs(),
                                    response_weights=medium["response_weights"],
                                    material_bands=medium["material_bands"],
                                    sigmoid_centers_t=medium["sigmoid_centers_t"])
                    flat_frame = SunFrame(r, flat, scene, camera, shading)
                    enc = r.deferred.device.create_command_encoder()
                    flat_frame.encode(enc)
                    r.deferred.device.queue.submit([enc.finish()])
                    passes.update({f"flat_sun_{k}": p for k, p in flat_frame.parts().items()})
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
            extra = {}
            if "occlusion" in passes:
                still = times.ms["geometry"] + times.ms["shade_display_occluded"]
                extra = {"occluded_frame_ms": still, "occluded_over_plain": still / frame,
                         "moving_occluded_frame_ms": still + times.ms["occlusion"],
                         "moving_occluded_over_plain": (still + times.ms["occlusion"]) / frame}
                say(f"{width}x{height} n={n:3d}: occlusion: frame {still:.2f} ms "
                    f"({still / frame:.3f}x the frame without it, factors kept), factors "
                    f"{times.ms['occlusion']:.2f} ms when the camera moves "
                    f"({(still + times.ms['occlusion']) / frame:.3f}x)")
            if sun is not None:
                # The sun's frame: with the light field geometry + shadow map +
                # froxels + shading with the sun and the display fused; with the
                # seeds' model its passes between the shading and the display.
                no_sun = frame

                def sun_frame_ms(prefix):
                    ms = sum(times.ms[f"{prefix}{k}"] for k in sun_frame.frame_parts())
                    return times.ms["geometry"] + ms if sun_frame.fused else unfused + ms
                frame = sun_frame_ms("sun_")
                if sun_frame.fused:
                    times.ms["sun_pixels"] = (times.ms["sun_shade_display"]
                                              - times.ms["shade_display"])
                extra = {"sun_ms": frame - no_sun, "no_sun_frame_ms": no_sun,
                         "sun_over_no_sun": frame / no_sun, "no_sun_frame_wall_ms": wall,
                         "sun_fused": sun_frame.fused}
                wall = _frame_wall_ms(r, [geometry, sun_frame, passes["sun_shade_display"]]
                                      if sun_frame.fused else [geometry, shading, sun_frame, disp],
                                      frames, warmup)
                if waves is not None:
                    flat_frame_ms = sun_frame_ms("flat_sun_")
                    extra.update({"flat_sun_ms": flat_frame_ms - no_sun,
                                  "flat_sun_frame_ms": flat_frame_ms,
                                  "caustics_over_flat_sun": frame / flat_frame_ms})
            row = {"width": width, "height": height, "bands": n, **{f"{k}_ms": v for k, v in
                   times.ms.items()}, "frame_ms": frame, "fps": 1e3 / frame,
                   "frame_wall_ms": wall, "frame_unfused_ms": unfused, **extra,
                   "timing": times.method}
            if compare_seeds:
                # With a sun, the models' frames without it (the sun's passes
                # are the same work for both).
                row["seeds_frame_ms"] = times.ms["geometry"] + times.ms["shade_display_seeds"]
                row["over_seeds"] = row.get("no_sun_frame_ms", frame) / row["seeds_frame_ms"]
                say(f"{width}x{height} n={n:3d}: seeds' frame {row['seeds_frame_ms']:7.2f} ms in "
                    f"the same run: {ms_model} / seeds = {row['over_seeds']:.3f}"
                    + ("" if sun is None else " (both without the sun)"))
            rows.append(row)
            if sun is None:
                say(f"{width}x{height} n={n:3d}: frame {frame:7.2f} ms ({1e3 / frame:6.1f} fps) "
                    f"= geometry {times.ms['geometry']:.2f} + shade+display "
                    f"{times.ms['shade_display']:.2f} | separate passes: deferred "
                    f"{times.ms['deferred']:.2f} display {times.ms['display']:.2f} copy "
                    f"{times.ms['copy']:.2f} | frame submitted at once {wall:.2f} ms")
            else:
                say(f"{width}x{height} n={n:3d}: frame {frame:7.2f} ms ({1e3 / frame:6.1f} fps) "
                    + (f"= geometry {times.ms['geometry']:.2f} + shadow map "
                       f"{times.ms['sun_shadow_map']:.2f} (drawn again: "
                       f"{times.ms['sun_shadow_map_redraw']:.2f}) + froxels "
                       f"{times.ms['sun_froxels']:.2f} + shading with the sun and display "
                       f"{times.ms['sun_shade_display']:.2f} (without the sun "
                       f"{times.ms['shade_display']:.2f}: the sun per pixel "
                       f"{times.ms['sun_pixels']:.2f})" if sun_frame.fused else
                       f"= geometry {times.ms['geometry']:.2f} + deferred "
                       f"{times.ms['deferred']:.2f} + sun {row['sun_ms']:.2f} (shadow map "
                       f"{times.ms['sun_shadow_map']:.2f}, drawn again "
                       f"{times.ms['sun_shadow_map_redraw']:.2f}, froxels "
                       f"{times.ms['sun_froxels']:.2f}, per pixel {times.ms['sun_pixels']:.2f}) "
                       f"+ display {times.ms['display']:.2f}")
                    + f" | without the sun {row['no_sun_frame_ms']:.2f} "
                    f"ms: sun / no sun = {row['sun_over_no_sun']:.3f}"
                    + ("" if waves is None else
                       f" | flat sun {row['flat_sun_ms']:.2f} ms: caustics / flat sun = "
                       f"{row['caustics_over_flat_sun']:.3f}")
                    + f" | frame submitted at once {wall:.2f} ms")
            if numpy_reference and n == 8:
                gb = r.raster.render(scene, camera)
                t0 = time.perf_counter()
                # With a sun, as the GPU frame: its shadow map and its light
                # (the caustic map is made once per setup, before).
                sun_shadow = (None if sun is None else
                              numpy_shadow_map(scene, camera, sun.to_sun, size=map_size))
                lin = shade_gbuffer(gb, **setup.medium(gb.materials),
                                    lightfield=setup.lightfield_tables(),
                                    sun=setup.sun_inputs(), sun_shadow=sun_shadow)["camera_rgb"]
                to_display(lin, **{"exposure": display_settings(lin)["exposure_ev"]})
                numpy_ms = (time.perf_counter() - t0) * 1e3
                numpy_rows.append({"width": width, "height": height, "bands": n,
                                   "numpy_ms": numpy_ms, "gpu_frame_ms": frame,
                                   "numpy_over_gpu": numpy_ms / frame,
                                   **({} if sun is None else {"with_sun": True})})
                say(f"{width}x{height} n=8: NumPy reference {numpy_ms:.0f} ms = "
                    f"{numpy_ms / frame:.1f} x our frame"
                    + ("" if sun is None else " (both with the sun)"))
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
            for k in ("sun_over_no_sun", "caustics_over_flat_sun"):
                if k in by_n[8]:
                    entry[f"{k}_n8"] = by_n[8][k]
        for x in numpy_rows:
            if (x["width"], x["height"]) == (width, height):
                entry["numpy_over_gpu_n8"] = x["numpy_over_gpu"]
        ratios.append(entry)
    return {"adapter": adapter_info(), "frames": frames, "warmup": warmup,
            "ms_model": ms_model, **({"phase": phase, "cone_spread": cone_spread,
                                        "spread_scattering": spread_scattering}
                                     if ms_model != MONZON2022 else {}),
            "water": w_obj.describe(), "sensor": s_obj.describe(), "depth_m": depth_m,
            "light": light_obj.describe(),
            **({} if sun is None else {"sun_rendering": {
                "shadow_map_texels": map_size, "shadow_radius_m": DEFAULT_MAP_RADIUS_M,
                "single_scattering": froxel_description(),
                "caustics": None if waves is None else setup.sun_inputs().caustics.describe()}}),
            "rows": rows, "numpy_reference": numpy_rows, "fits": fits, "ratios": ratios}


def _light_line(result: dict) -> str | None:
    """The header's line on the light; None for the default (overcast), whose
    header is the one bench always printed."""
    light = result.get("light") or {"name": "overcast"}
    if light["name"] == "overcast" and "sun" not in light:
        return None
    line = f"light: {light['name']}"
    sun, rendering = light.get("sun"), result.get("sun_rendering") or {}
    if sun is not None:
        line += (f", sun at {sun['elevation_deg']:g} deg elevation, azimuth "
                 f"{sun['azimuth_deg']:g} deg; shadow map {rendering.get('shadow_map_texels')} "
                 "texels")
        caustics = rendering.get("caustics")
        line += ("; flat surface" if caustics is None else
                 f"; caustics of a {caustics['wind_speed_m_s']:g} m/s sea")
        if result.get("numpy_reference"):
            line += "; the NumPy reference shades the sun too"
    return line


def format_table(result: dict) -> str:
    """The results as printed by ``aquaspec bench``: a header, a row per size
    and band count (ms), the fits and the ratios."""
    sun = any("sun_ms" in x for x in result["rows"])
    lines = [f"adapter: {result['adapter'].get('device')} ({result['adapter'].get('adapter_type')}),"
             f" median of {result['frames']} frames after {result['warmup']} warm-up"]
    light = _light_line(result)
    if light is not None:
        lines.append(light)
    if sun and any(x.get("sun_fused") for x in result["rows"]):
        lines += ["frame = geometry + shadow map + froxels + shading with the sun and the "
                  "display fused (the light field adds the sun in its band loop; the shadow "
                  "map is kept while nothing moves); no sun: geometry + shade+display "
                  "(fused), the same G-buffer in the same run; wall: the frame submitted at "
                  "once"]
    elif sun:
        lines += ["frame = geometry + deferred + sun + display: the sun's passes (shadow map, "
                  "froxels, per pixel) add its light to the linear image, so the display "
                  "cannot be fused; no sun: geometry + shade+display (fused), the same "
                  "G-buffer in the same run; wall: the frame submitted at once"]
    else:
        lines += ["frame = geometry + shade+display (the display transform fused into the "
                  "shading pass); deferred and display: the same work as two passes; wall: "
                  "the frame submitted at once"]
    lines.append(f"{'size':>10s} {'n':>4s} {'geometry':>9s} {'shade+disp':>10s} {'frame':>8s} "
                 f"{'fps':>6s} {'wall':>7s} | {'deferred':>8s} {'display':>8s} {'copy':>6s}  "
                 "(ms)")
    compare = any("over_seeds" in x for x in result["rows"])
    flat = any("flat_sun_ms" in x for x in result["rows"])
    if compare:
        lines[-1] += f" | {'seeds':>7s} {'ratio':>6s}"
    if sun:
        lines[-1] += (f" | {'shadow':>7s} {'froxels':>7s} {'sun/px':>7s} {'no sun':>7s} "
                      f"{'ratio':>6s}")
    if flat:
        lines[-1] += f" | {'flat sun':>8s} {'caustics':>8s}"
    for x in result["rows"]:
        line = (f"{x['width']:>5d}x{x['height']:<4d} {x['bands']:>4d} {x['geometry_ms']:9.2f} "
                f"{x['shade_display_ms']:10.2f} {x['frame_ms']:8.2f} {x['fps']:6.1f} "
                f"{x['frame_wall_ms']:7.2f} | {x['deferred_ms']:8.2f} "
                f"{x['display_ms']:8.2f} {x['copy_ms']:6.2f}")
        if compare:
            line += f" | {x['seeds_frame_ms']:7.2f} {x['over_seeds']:6.3f}"
        if sun:
            line += (f" | {x['sun_shadow_map_ms']:7.2f} {x['sun_froxels_ms']:7.2f} "
                     f"{x['sun_pixels_ms']:7.2f} {x['no_sun_frame_ms']:7.2f} "
                     f"{x['sun_over_no_sun']:6.3f}")
        if flat:
            line += f" | {x['flat_sun_ms']:8.2f} {x['caustics_over_flat_sun']:8.3f}"
        lines.append(line)
    if sun:
        lines.append("shade+disp: without the sun; shadow, froxels, sun/px: the sun's passes "
                     "(fused: sun/px is the shading pass's time with the sun less without; "
                     "shadow: as a still frame runs it, kept from the frame before); "
                     "ratio: frame / frame without the sun"
                     + ("; seeds: the seeds' frame without the sun, its ratio the models' "
                        "frames without the sun" if compare else "")
                     + ("; flat sun: the sun's cost without caustics, caustics: frame "
                        "/ frame with the flat sun" if flat else ""))
    for f in result["fits"]:
        lines.append(f"fit {f['width']}x{f['height']}: t(n) = {f['t0_ms']:.2f} ms + n * "
                     f"{f['t1_ms_per_band']:.3f} ms (deferred alone: {f['deferred_t0_ms']:.2f} + "
                     f"n * {f['deferred_t1_ms_per_band']:.3f})")
    for r in result["ratios"]:
        parts = [f"{k} = {v:.2f}" for k, v in r.items() if k not in ("width", "height")]
        lines.append(f"ratios {r['width']}x{r['height']}: " + ", ".join(parts))
    return "\n".join(lines)


def plot(result: dict, path) -> None:
    import matplotlib  # deferred: matplotlib takes 0.3 s to import; only --plot needs it
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # deferred: as matplotlib
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
    write_figure(path, fig, dpi=110)
