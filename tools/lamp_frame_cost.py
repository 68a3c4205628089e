"""The lamp pass's cost against the frame without lamps, on the GPU.

The built-in scene at 60 m in Jerlov II, no daylight, the ``rov-pair`` lamps:
the frame without lamps (``Renderer.draw_frame``, wall clock, median of six),
the lamps' shadow maps drawn once, and the lamp pass (timestamp queries where
the device has them, :func:`aquaspec.gpu.timing.time_passes`).

Usage::

    python tools/lamp_frame_cost.py WIDTH HEIGHT BANDS [SLICES]
"""
import statistics
import sys
import time

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.gpu.passes.lamps import LampPass
from aquaspec.gpu.timing import time_passes
from aquaspec.light.lamp import parse_lamps
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import get_water
from aquaspec.rendering.renderer import Renderer
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.builtin import builtin_scene
from aquaspec.transport.lamp_froxels import LAMP_SLICES

w, h, n = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
slices = int(sys.argv[4]) if len(sys.argv) > 4 else LAMP_SLICES
scene, cam = builtin_scene(60.0, width=w, height=h)
setup = SpectralSetup(get_water("II"), get_sensor("human"), surface_light("none"), Bands(n),
                      lamps=parse_lamps(["rov-pair"]))
r = Renderer(w, h, n)
r.auto_display(scene, cam, setup)
frames = []
for k in range(8):
    t0 = time.perf_counter()
    r.draw_frame(scene, cam, setup)
    frames.append(1e3 * (time.perf_counter() - t0))
frame_ms = statistics.median(frames[2:])
lp = LampPass(r.deferred.device, w, h, n, slices=slices)
medium = setup.medium(scene.materials)
lp.set_inputs(setup.lamp_inputs(cam), response_weights=medium["response_weights"],
              material_bands=medium["material_bands"],
              sigmoid_centers_t=medium["sigmoid_centers_t"])
enc = r.deferred.device.create_command_encoder()
r.raster.render_to(r.deferred.gbuffer, scene, cam, encoder=enc)
t0 = time.perf_counter()
lp.encode_shadow_maps(enc, r.raster, scene)
r.deferred.device.queue.submit([enc.finish()])
lp.read_rgb()
maps_ms = 1e3 * (time.perf_counter() - t0)


class LampStep:
    def encode(self, encoder, timestamp_writes=None):
        lp.encode(encoder, cam, r.deferred.gbuffer.textures, timestamp_writes=timestamp_writes)


t = time_passes({"lamps": LampStep()}, frames=6, warmup=2, device=r.deferred.device)
print(f"{w}x{h} {n} bands, {slices} slices: frame without lamps {frame_ms:.1f} ms (wall, "
      f"draw_frame), lamp pass {t.ms['lamps']:.1f} ms ({t.method}), shadow maps drawn once "
      f"{maps_ms:.0f} ms; (frame + lamps) / frame = {(frame_ms + t.ms['lamps']) / frame_ms:.2f}")
