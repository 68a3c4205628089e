"""What the lamps' GPU passes' time is made of, and the frame a fused pass could reach.

``aquaspec bench --lamps 2``'s setup (1280x720, 8 bands, the built-in scene at
5 m in Jerlov IB, the ``rov-pair`` lamps shadowed, overcast daylight), with
variants of ``lamps.wgsl`` that leave one part out (text substitutions of the
shipped shader; a substitution that no longer matches is an error). Every
variant's veil and per-pixel pass (the display transform fused, as the bench's
frame has it), the geometry pass and the shading pass are submitted one after
another, frame after frame, and their wall-clock medians printed: on a shared
host compare the parts within one run.

The parts (2 lamps): the pass's own cost (G-buffer read, display transform,
writes: ``base``), the veil's one trilinear read per pixel, the pixel's
reflectance times ``exp(-c S)`` per band (``rho``: the shading pass has it
already), the lamps' light (direct: beam, shadow, an exponential per band; the
glow), and the veil's columns at 16 and at 32 pixels. ``fused`` is the frame a
lamp term inside the shading pass's band loop would cost at best: the frame
without lamps plus the veil's columns, the veil read and the lamps' light,
with neither ``base`` nor ``rho`` paid again.

Usage::

    python tools/lamp_pass_parts.py [FRAMES]
"""
import sys
import time

import numpy as np

import aquaspec.gpu.passes.lamps as lamps_module
from aquaspec.apps.lamp_bench import bench_lamps
from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.gpu.passes.display import DisplayPass
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import get_water
from aquaspec.rendering.renderer import Renderer
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.builtin import builtin_scene

LOOP = "k < lp.n_lamps; k = k + 1u) {\n            let to_lamp"
NO_LOOP = "k < 0u; k = k + 1u) {\n            let to_lamp"
VEIL_READ = ("var acc = veil_sample(col, row, x);", "var acc = vec3<f32>(x * 1e-30);")
RHO_KEPT = ("        for (var k = 0u; k < 0u;",
            "        acc = acc + vec3<f32>(dot(rho[0], vec4<f32>(1.0))"
            " + dot(rho[BAND_GROUPS - 1u], vec4<f32>(1.0)));\n        for (var k = 0u; k < 0u;")
#: Variant: substitutions in lamps.wgsl (and the veil's column width, pixels).
VARIANTS = {
    "full": ([], None),
    "columns_32px": ([], 32),
    "no_glow": ([("let iso = lamps[k].iso / PI;", "let iso = 0.0;")], None),
    "no_shadow": ([("g = f * cos_n * lamp_visibility(k, pos, n, true) / (PI * r * r);",
                    "g = f * cos_n / (PI * r * r);")], None),
    "rho_only": ([(LOOP, NO_LOOP), RHO_KEPT], None),
    "veil_read_only": ([(LOOP, NO_LOOP)], None),
    "base": ([(LOOP, NO_LOOP), VEIL_READ], None),
}

frames = int(sys.argv[1]) if len(sys.argv) > 1 else 10
W, H, N = 1280, 720, 8
_load, _tile = lamps_module.load_wgsl, lamps_module.lamp_tile
state = {"subs": [], "tile": None}


def load(name, **values):
    src = _load(name, **values)
    for old, new in state["subs"]:
        if old not in src:
            raise SystemExit(f"lamps.wgsl no longer contains {old!r}: update VARIANTS")
        src = src.replace(old, new)
    return src


lamps_module.load_wgsl = load
lamps_module.lamp_tile = lambda camera: state["tile"] or _tile(camera)

scene, camera = builtin_scene(5.0, width=W, height=H)
setup = SpectralSetup(get_water("IB"), get_sensor("human"), surface_light("overcast"), Bands(N),
                      lamps=bench_lamps(2), phase="petzold")
r = Renderer(W, H, N)
dev = r.deferred.device
r.set_spectral(setup, scene.materials)
rgb = r.render_scene(scene, camera, setup)
shading = r.lightfield if setup.ms_model == "lightfield" else r.deferred
disp = DisplayPass(W, H, device=dev)
disp.use_input(shading.rgb_buffer)
s = disp.set_from_image(rgb)
display = dict(exposure_ev=s["exposure_ev"], white_balance_gains=s["white_balance_gains"],
               matrix=s["matrix"], tonemap=s["tonemap"])
shading.set_display(**display)
medium = setup.medium(scene.materials)
passes = {}
for name, (subs, _) in VARIANTS.items():
    state["subs"] = subs
    lp = lamps_module.LampPass(dev, W, H, N)
    lp.set_display(**display)
    lp.set_inputs(setup.lamp_inputs(camera), response_weights=medium["response_weights"],
                  material_bands=medium["material_bands"],
                  sigmoid_centers_t=medium["sigmoid_centers_t"])
    lp._pipelines_for(lp._mat_key, display["tonemap"])  # compiled with this variant's source
    enc = dev.create_command_encoder()
    r.raster.render_to(r.deferred.gbuffer, scene, camera, encoder=enc)
    lp.encode_shadow_maps(enc, r.raster, scene)
    dev.queue.submit([enc.finish()])
    passes[name] = lp
state["subs"] = []
gbt = r.deferred.gbuffer.textures
fence = dev.create_buffer(size=256, usage="COPY_SRC")


def timed(fn):
    enc = dev.create_command_encoder()
    fn(enc)
    t0 = time.perf_counter()
    dev.queue.submit([enc.finish()])
    dev.queue.read_buffer(fence)
    return 1e3 * (time.perf_counter() - t0)


ms = {k: [] for k in ["geometry", "shade_display", "shading"]
      + [f"{v}_{p}" for v in VARIANTS for p in ("veil", "pixels")]}
for f in range(frames + 2):
    ms["geometry"].append(timed(lambda e: r.raster.render_to(r.deferred.gbuffer, scene, camera,
                                                             encoder=e)))
    ms["shade_display"].append(timed(lambda e: shading.encode(e, None, display=True)))
    ms["shading"].append(timed(lambda e: shading.encode(e, None)))
    for name, lp in passes.items():
        state["tile"] = VARIANTS[name][1]
        ms[f"{name}_veil"].append(timed(lambda e: lp.encode_veil(e, camera, gbt,
                                                                 shading.rgb_buffer)))
        ms[f"{name}_pixels"].append(timed(lambda e: lp.encode_pixels(e, display=True)))
    state["tile"] = None
m = {k: float(np.median(v[2:])) for k, v in ms.items()}
frame = m["geometry"] + m["shade_display"]
light = m["full_pixels"] - m["rho_only_pixels"]
parts = {
    "pass's own (G-buffer, display, writes)": m["base_pixels"],
    "veil read": m["veil_read_only_pixels"] - m["base_pixels"],
    "rho exp(-c S)": m["rho_only_pixels"] - m["veil_read_only_pixels"],
    "lamps' light (2)": light,
    "  of which the glow": m["full_pixels"] - m["no_glow_pixels"],
    "  of which the shadow lookups": m["full_pixels"] - m["no_shadow_pixels"],
    "veil columns, 16 px": m["full_veil"],
    "veil columns, 32 px": m["columns_32px_veil"],
}
print(f"frame without lamps {frame:.1f} ms (geometry {m['geometry']:.1f}, shading with the "
      f"display {m['shade_display']:.1f}, linear {m['shading']:.1f}); lamp pixels "
      f"{m['full_pixels']:.1f} ms")
for k, v in parts.items():
    print(f"  {k:40s} {v:7.1f} ms  {v / frame:5.2f} x frame")
now = (m["geometry"] + m["shading"] + m["full_veil"] + m["full_pixels"]) / frame
veil_read = parts["veil read"]
fused = (frame + m["full_veil"] + veil_read + light) / frame
fused32 = (frame + m["columns_32px_veil"] + veil_read + light) / frame
no_glow = (frame + m["columns_32px_veil"] + veil_read + light
           - parts["  of which the glow"]) / frame
print(f"ratio now {now:.2f}; fused at best {fused:.2f}; fused, 32-px columns {fused32:.2f}; "
      f"fused, 32-px columns, no glow on surfaces {no_glow:.2f}")
