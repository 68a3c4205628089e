#!/bin/sh
# Render the README's gallery into docs/images (640x360, 16 bands; about a
# minute on two cores with a cold cache). Run from the repository root:
#   sh tools/gallery.sh
set -eu
A=${AQUASPEC:-.venv/bin/aquaspec}
PY=${PYTHON:-.venv/bin/python}
OUT=docs/images
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
mkdir -p "$OUT" "${XDG_RUNTIME_DIR:=/tmp/xdg-$(id -u)}"
export XDG_RUNTIME_DIR

"$A" render --water IB --depth 5 --size 640x360 --bands 16 -o "$TMP/overcast.png"
"$A" render --water IB --depth 4 --light sun-sky --sun-elevation 55 --sun-azimuth 150 --wind 3 \
    --size 640x360 --bands 16 -o "$TMP/sun_caustics.png"
"$A" render --water 3C --depth 6 --size 640x360 --bands 16 -o "$TMP/turbid.png"
"$A" render --water II --depth 60 --light none --lamp rov-pair --size 640x360 --bands 16 \
    -o "$TMP/lamps_deep.png"
"$PY" tools/make_rgbd_example.py "$TMP"
"$A" render --rgbd "$TMP/rgbd_photo.png" "$TMP/rgbd_depth.png" --intrinsics 420,420,320,180 \
    --water IB --depth 5 --bands 16 -o "$TMP/rgbd_underwater.png"

# The sea surface's row (1280x720, 16 bands).
"$A" render --camera-height 5 --look-down 30 --water IB -o "$TMP/surface_above_ib.png"
"$A" render --camera-height 5 --look-down 30 --water 3C -o "$TMP/surface_above_3c.png"
"$A" render --camera-height 0 --look-down 8 --water IB -o "$TMP/surface_half.png"
"$A" render --camera-height 5 --look-down 25 --water IB --light sun-sky --sun-elevation 35 \
    --sun-azimuth 0 --wind 6 -o "$TMP/surface_glitter.png"
"$A" render --camera-height 2.5 --look-down 55 --water IB --light sun-sky --sun-elevation 55 \
    --sun-azimuth 150 --wind 4 -o "$TMP/surface_above_scene.png"
"$PY" - "$TMP/surface_window.png" <<'PYEOF'
import sys
import numpy as np
import aquaspec
from aquaspec.io.save import save_image
from aquaspec.scene.builtin import builtin_scene
from aquaspec.scene.camera import Camera
scene, cam = builtin_scene(5.0, width=1280, height=720)
a = np.radians(60)          # the built-in camera turned 60 degrees up
f = np.asarray(cam.forward) * np.cos(a) + np.asarray(cam.true_up) * np.sin(a)
up = Camera.look_at(cam.position, cam.position + f, width=1280, height=720, fov_y_deg=90.0)
r = aquaspec.render(water="IB", scene=scene, camera=up, size=(1280, 720), bands=16)
save_image(sys.argv[1], r.display, None, r.params)
PYEOF
"$PY" - "$TMP/surface_window_waves.png" <<'PYEOF'
import sys
import numpy as np
import aquaspec
from aquaspec.io.save import save_image
from aquaspec.scene.camera import Camera
p = np.array([0.0, -4.0, 0.0])   # 4 m down in open water, looking 60 degrees up
a = np.radians(60)
cam = Camera.look_at(p, p + [0.0, np.sin(a), -np.cos(a)], width=1280, height=720, fov_y_deg=90.0)
r = aquaspec.render(water="IB", camera=cam, light="sun-sky", sun_elevation_deg=50,
                    sun_azimuth_deg=0, waves=6.0, bands=16)
save_image(sys.argv[1], r.display, None, r.params)
PYEOF

cp "$TMP/overcast.png" "$TMP/sun_caustics.png" "$TMP/turbid.png" "$TMP/lamps_deep.png" \
   "$TMP/rgbd_photo.png" "$TMP/rgbd_underwater.png" "$TMP/surface_above_ib.png" \
   "$TMP/surface_above_3c.png" "$TMP/surface_half.png" "$TMP/surface_window.png" \
   "$TMP/surface_glitter.png" "$TMP/surface_window_waves.png" "$TMP/surface_above_scene.png" \
   "$OUT/"
