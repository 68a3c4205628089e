"""What shadowed lamps cost a frame: ``aquaspec bench --lamps N``.

The built-in scene with ``N`` lamps fixed to the camera (:func:`bench_lamps`:
the ``rov-pair`` preset for 2, else ``N`` white LED spots of 20 W, cone 50
degrees, spread evenly over a 1 m bar through the camera), each with its
shadow map (:class:`aquaspec.gpu.passes.lamps.LampPass`). Two frames on the
same G-buffer, the same setup but for the lamps, in the same run:

- without lamps: geometry + the shading pass with the display transform
  fused in (the bench's frame);
- with them: geometry + the lamps' veil (their single scattering and glow
  per column, :mod:`aquaspec.transport.lamp_froxels`) + with the light
  field's single-scattering cone spread their lit surfaces' cone share into
  the spread's input (:meth:`aquaspec.gpu.passes.lamps.LampPass.encode_cone`)
  + the shading pass writing linear RGB + the lamps' per-pixel pass (their
  lit surfaces and the veil read at each pixel's distance, added to the
  linear image, with the display transform fused in); and beside it the
  same frame with the share kept on the lit pixels (no cone step: the frame
  before 2026-11-28), ``cone_ratio`` the one over the other. The
  lamps' shadow maps are kept from the frame before, as the sun's are while
  nothing moves; drawing them again (a moving camera moves camera-fixed
  lamps) is timed beside.

Each pass is timed as :func:`aquaspec.apps.bench.run_bench` times it (the wall
clock around submit + wait on a software adapter, whose timestamps do not
bracket a pass's work), and both whole frames are submitted at once,
alternately, their medians compared: ``ratio`` is the frame with lamps over the
frame without them. The machine may be shared: compare ratios from one run.
"""

from __future__ import annotations

import time

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.gpu.device import adapter_info
from aquaspec.gpu.passes.display import DisplayPass
from aquaspec.gpu.passes.lamps import LampPass
from aquaspec.gpu.timing import time_passes
from aquaspec.light.lamp import Lamp, parse_lamps
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import get_water
from aquaspec.rendering.renderer import Renderer
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.builtin import builtin_scene
from aquaspec.transport.lamp_froxels import LAMP_SLICES, lamp_tile


def bench_lamps(n: int) -> list:
    """``n`` camera-fixed lamps: the ``rov-pair`` preset for 2, else white LED
    spots (20 W, cone 50 degrees) at ``x`` evenly over -0.5 ... 0.5 m (0.3 m
    for one), looking ahead."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= 16:
        raise AquaspecError(f"--lamps {n!r}; accepted: an integer 1 ... 16")
    if n == 2:
        return parse_lamps(["rov-pair"])
    xs = [0.3] if n == 1 else np.linspace(-0.5, 0.5, n)
    return [Lamp((float(x), 0.0, 0.0), (0.0, 0.0, -1.0), 50.0, power_w=20.0, spectrum="led",
                 name=f"bench-{k}") for k, x in enumerate(xs)]


class _Step:
    """One timed pass: ``encode(encoder, timestamp_writes=None)`` calling ``fn``."""

    def __init__(self, fn):
        self.fn = fn

    def encode(self, encoder, timestamp_writes=None):
        self.fn(encoder, timestamp_writes)


def _frames_ms(device, frames: dict, count: int, warmup: int, fence) -> dict:
    """Median wall-clock time of each whole frame (a list of encode functions)
    submitted at once, the frames alternated."""
    out = {k: [] for k in frames}
    for f in range(warmup + count):
        for name, parts in frames.items():
            enc = device.create_command_encoder()
            for part in parts:
                part(enc, None)
            t0 = time.perf_counter()
            device.queue.submit([enc.finish()])
            device.queue.read_buffer(fence)
            if f >= warmup:
                out[name].append(1e3 * (time.perf_counter() - t0))
    return {k: float(np.median(v)) for k, v in out.items()}


def run_lamp_bench(*, width: int = 1280, height: int = 720, n_bands: int = 8, n_lamps: int = 2,
                   frames: int = 20, warmup: int = 3, water="IB", depth_m: float = 5.0,
                   sensor="human", light: str = "overcast", ms_model: str | None = None,
                   phase: str = "petzold", progress=None) -> dict:
    """Time the frame with ``n_lamps`` shadowed lamps against the frame without
    them (module docstring); returns a JSON-ready dict with ``ratio``."""
    say = progress or (lambda m: None)
    lamps = bench_lamps(n_lamps)
    scene, camera = builtin_scene(depth_m, width=width, height=height)
    kw = dict(phase=phase) if ms_model is None else dict(ms_model=ms_model, phase=phase)
    setup = SpectralSetup(get_water(water), get_sensor(sensor), surface_light(light),
                          Bands(n_bands), lamps=lamps, **kw)
    r = Renderer(width, height, n_bands)
    dev = r.deferred.device
    r.set_spectral(setup, scene.materials)
    rgb = r.render_scene(scene, camera, setup)
    shading = r.lightfield if setup.ms_model == "lightfield" else r.deferred
    disp = DisplayPass(width, height, device=dev)
    disp.use_input(shading.rgb_buffer)
    settings = disp.set_from_image(rgb)
    display_kw = dict(exposure_ev=settings["exposure_ev"],
                      white_balance_gains=settings["white_balance_gains"],
                      matrix=settings["matrix"], tonemap=settings["tonemap"])
    shading.set_display(**display_kw)
    lp = LampPass(dev, width, height, n_bands)
    lp.set_display(**display_kw)
    medium = setup.medium(scene.materials)
    lp.set_inputs(setup.lamp_inputs(camera), response_weights=medium["response_weights"],
                  material_bands=medium["material_bands"],
                  sigmoid_centers_t=medium["sigmoid_centers_t"])
    enc = dev.create_command_encoder()
    r.raster.render_to(r.deferred.gbuffer, scene, camera, encoder=enc)
    if not lp.encode_shadow_maps(enc, r.raster, scene):
        raise AquaspecError("the bench's scene casts no shadows")
    dev.queue.submit([enc.finish()])
    gbt = r.deferred.gbuffer.textures
    plan = None
    if shading is r.lightfield and shading.spread and not shading.nodes:
        # The spread the lamps' cone share goes to (as rendering.lamps.lamps_before_shading).
        start, alpha, _ = shading._update_spread(camera)
        plan = (shading._spread_pass, start, alpha)

    def no_share():
        if plan is not None:
            plan[0].set_extra(False)

    def geometry(e, tw):
        r.raster.render_to(r.deferred.gbuffer, scene, camera, encoder=e, timestamp_writes=tw)

    def fused(e, tw):
        no_share()
        if hasattr(shading, "set_sun"):
            shading.set_sun(None)
        shading.encode(e, tw, display=True)

    def linear(e, tw):
        if hasattr(shading, "set_sun"):
            shading.set_sun(None)
        shading.encode(e, tw)

    def veil(e, tw):
        lp.set_cone_spread(*(plan or (None,)))
        lp.encode_veil(e, camera, gbt, shading.rgb_buffer, tw)

    def cone(e, tw):
        if plan is not None:
            lp.encode_cone(e, tw)

    def kept_veil(e, tw):
        no_share()
        lp.set_cone_spread(None)
        lp.encode_veil(e, camera, gbt, shading.rgb_buffer, tw)

    def pixels(e, tw):
        lp.encode_pixels(e, tw, display=True)

    def maps(e, tw):
        lp.forget_shadow_maps()
        lp.encode_shadow_maps(e, r.raster, scene)

    def display(e, tw):
        disp.encode(e, tw)

    timing = "wall-clock" if adapter_info().get("adapter_type") == "CPU" else "auto"
    parts = {"geometry": geometry, "shade_display": fused, "shading": linear,
             "lamp_veil": veil, "lamp_cone": cone, "lamp_pixels": pixels, "display": display,
             "lamp_shadow_maps": maps}
    # (display: the separate display pass, for comparison; the lamps' frame fuses it.)
    times = time_passes({k: _Step(f) for k, f in parts.items()}, method=timing, frames=frames,
                        warmup=warmup, device=dev)
    ms = times.ms
    plain = ms["geometry"] + ms["shade_display"]
    lit = (ms["geometry"] + ms["shading"] + ms["lamp_veil"] + ms["lamp_cone"]
           + ms["lamp_pixels"])
    fence = dev.create_buffer(size=256, usage="COPY_SRC")
    whole = _frames_ms(dev, {"plain": [geometry, fused],
                             "lamps": [geometry, veil, cone, linear, pixels],
                             "kept": [geometry, linear, kept_veil, pixels]},
                       frames, warmup, fence)
    tile = lamp_tile(camera)
    row = {"width": width, "height": height, "bands": n_bands, "lamps": len(lamps),
           "lamp_names": [lamp.name for lamp in lamps],
           "veil": f"columns of {tile}x{tile} pixels, {LAMP_SLICES} slices",
           **{f"{k}_ms": v for k, v in ms.items()},
           "frame_ms": plain, "lamp_frame_ms": lit, "passes_ratio": lit / plain,
           "frame_wall_ms": whole["plain"], "lamp_frame_wall_ms": whole["lamps"],
           "ratio": whole["lamps"] / whole["plain"],
           "kept_frame_wall_ms": whole["kept"], "cone_ratio": whole["lamps"] / whole["kept"],
           "moving_ratio": (whole["lamps"] + ms["lamp_shadow_maps"]) / whole["plain"],
           "timing": times.method}
    say(format_lamp_row(row))
    return row


def format_lamp_row(row: dict) -> str:
    """A bench result in words."""
    return (f"{row['width']}x{row['height']} n={row['bands']}: {row['lamps']} shadowed lamps "
            f"({row['veil']}): frame {row['lamp_frame_wall_ms']:.1f} ms against "
            f"{row['frame_wall_ms']:.1f} ms without them, ratio {row['ratio']:.2f} "
            f"(whole frames, wall clock, alternated); per pass ({row['timing']}): geometry "
            f"{row['geometry_ms']:.1f}, shading {row['shading_ms']:.1f} (fused with the display "
            f"{row['shade_display_ms']:.1f}), lamp veil {row['lamp_veil_ms']:.1f}, lamp cone "
            f"share {row['lamp_cone_ms']:.1f}, lamp pixels "
            f"with the display {row['lamp_pixels_ms']:.1f} ms (a display pass alone "
            f"{row['display_ms']:.1f}): "
            f"{row['passes_ratio']:.2f}x; shadow maps drawn again {row['lamp_shadow_maps_ms']:.1f}"
            f" ms (a moving camera: {row['moving_ratio']:.2f}x); the frame with the cone share "
            f"kept on the lit pixels {row['kept_frame_wall_ms']:.1f} ms (with it spread "
            f"{row['cone_ratio']:.2f}x)")
