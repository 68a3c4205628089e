"""Frame time of the classic and the detailed built-in scene, in one process.

Both scenes' frames alternated (``Renderer.draw_frame``: geometry, shading,
display, submitted and waited for), each with its own renderer, after one
warm-up frame each; prints the median wall-clock and process-CPU time per
frame and the detailed / classic ratios. 1280x720, 8 bands, Jerlov IB, the
default model. Usage: python tools/builtin_frame_time.py [FRAMES] [LIGHT]
"""

import sys
import time

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import get_water
from aquaspec.rendering.renderer import Renderer
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.builtin import builtin_scene


def main(argv):
    reps = int(argv[0]) if argv else 10
    light = argv[1] if len(argv) > 1 else "overcast"
    w, h, bands = 1280, 720, 8
    setup = SpectralSetup(get_water("IB"), get_sensor("human"), surface_light(light),
                          Bands(bands))
    runs = {}
    for variant in ("classic", "detailed"):
        scene, cam = builtin_scene(5.0, width=w, height=h, variant=variant)
        r = Renderer(w, h, bands)
        r.set_spectral(setup, scene.materials)
        r.auto_display(scene, cam, setup)
        r.draw_frame(scene, cam, setup)
        runs[variant] = (r, scene, cam, [], [])
    for _ in range(reps):
        for r, scene, cam, wall, cpu in runs.values():
            t, c = time.perf_counter(), time.process_time()
            r.draw_frame(scene, cam, setup)
            wall.append(time.perf_counter() - t)
            cpu.append(time.process_time() - c)
    med = {v: (np.median(x[3]), np.median(x[4])) for v, x in runs.items()}
    for v, (wt, ct) in med.items():
        print(f"{v}: {runs[v][1].n_triangles} triangles, median {1000 * wt:.1f} ms wall, "
              f"{1000 * ct:.1f} ms CPU per frame")
    print(f"detailed / classic: {med['detailed'][0] / med['classic'][0]:.3f} (wall), "
          f"{med['detailed'][1] / med['classic'][1]:.3f} (CPU)")


if __name__ == "__main__":
    main(sys.argv[1:])
