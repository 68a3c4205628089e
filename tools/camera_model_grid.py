"""Draw a grid target seen through a camera model's flat port: docs/images/camera_model_flat_port_grid.png.

A plane of white lines 1.5 m in front of the built-in scene's camera
(1280x720, 60 degree vertical field in air), rendered as a pinhole image in
water and resampled through the ``dslr-flat-port`` preset's port at 450,
550 and 650 nm, shown as the blue, green and red channels: the pincushion
distortion bows the straight lines in towards the centre, and the port's
lateral colour splits them into colour fringes towards the corners (the
inset enlarges the top-left corner 4x). The dashed rectangle is where the same field of view
in water would end without the distortion (a camera of the port's paraxial
focal length, f n_w).

    python tools/camera_model_grid.py [OUT.png]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from aquaspec.optics.presets import CAMERA_MODELS
from aquaspec.optics.remap import Intrinsics, port_image, water_intrinsics

OUT = Path(__file__).resolve().parents[1] / "docs" / "images" / "camera_model_flat_port_grid.png"
Z_M, SPACING_M, LINE_M = 1.5, 0.1, 0.004
WAVELENGTHS_NM = (650.0, 550.0, 450.0)          # R, G, B


def main(out=OUT) -> None:
    f = 360.0 / np.tan(np.radians(30.0))
    sensor = Intrinsics(1280, 720, f, f, 640.0, 360.0)
    port = CAMERA_MODELS["dslr-flat-port"].port
    water = water_intrinsics(sensor, port, WAVELENGTHS_NM, 0.3)
    tx, ty = water.tangents()
    # Anti-aliased lines: distance to the nearest grid line on the plane, in pixels.
    px_m = Z_M / water.fx
    dist = np.minimum(np.abs((tx * Z_M + SPACING_M / 2) % SPACING_M - SPACING_M / 2),
                      np.abs((ty * Z_M + SPACING_M / 2) % SPACING_M - SPACING_M / 2))
    grid = np.clip(1.0 - (dist - LINE_M / 2) / px_m, 0.0, 1.0)
    img = port_image(np.repeat(grid[..., None], 3, axis=-1), WAVELENGTHS_NM, port, sensor,
                     water, z_water=np.full(grid.shape, Z_M))
    rgb = (np.clip(img, 0, 1) * 255).astype(np.uint8)
    pic = Image.fromarray(rgb)
    inset = pic.crop((0, 0, 160, 90)).resize((640, 360), Image.NEAREST)
    draw = ImageDraw.Draw(pic)
    # Undistorted frame of the paraxial focal length f * n_w(550): a corner of
    # the sensor maps to the water angle of the port's corner ray.
    n_w = float(port.indices(550.0)[0])
    tan_w = float(port.water_ray(np.hypot(640, 360) / f, 550.0)[0])
    scale = f * n_w * tan_w / np.hypot(640, 360)
    hw, hh = 640 * scale, 360 * scale
    for k in range(0, int(4 * (hw + hh)), 16):
        pts = [(640 - hw, 360 - hh), (640 + hw, 360 - hh), (640 + hw, 360 + hh),
               (640 - hw, 360 + hh), (640 - hw, 360 - hh)]
        _dash(draw, pts, k)
    pic.paste(inset, (1280 - 640 - 8, 720 - 360 - 8))
    draw.rectangle((1280 - 648, 720 - 368, 1279 - 8, 719 - 8), outline=(255, 255, 0), width=2)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    pic.save(out)
    print(f"wrote {out}")


def _dash(draw, pts, start):
    """One 8-pixel dash of the polyline ``pts`` starting ``start`` pixels along it."""
    along = 0.0
    for (x0, y0), (x1, y1) in zip(pts, pts[1:]):
        seg = float(np.hypot(x1 - x0, y1 - y0))
        if along <= start < along + seg:
            a = (start - along) / seg
            b = min(a + 8.0 / seg, 1.0)
            draw.line((x0 + a * (x1 - x0), y0 + a * (y1 - y0),
                       x0 + b * (x1 - x0), y0 + b * (y1 - y0)), fill=(255, 255, 0), width=1)
            return
        along += seg


if __name__ == "__main__":
    main(*sys.argv[1:])
