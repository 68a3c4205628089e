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

cp "$TMP/overcast.png" "$TMP/sun_caustics.png" "$TMP/turbid.png" "$TMP/lamps_deep.png" \
   "$TMP/rgbd_photo.png" "$TMP/rgbd_underwater.png" "$OUT/"
