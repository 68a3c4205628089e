"""Write a small synthetic RGB-D photograph for the README's gallery.

The "photograph" is a ray-cast scene in air: a sandy floor, a painted wall
of colour bars 9 m away and four balls, lit by a sun and a sky. It is made
procedurally so that the gallery needs no third-party image. The colour
image is an 8-bit sRGB PNG and the depth map a 16-bit PNG of metric
z-depth in millimetres (the usual depth-camera format), which is what
``aquaspec render --rgbd IMAGE DEPTH --intrinsics fx,fy,cx,cy`` reads.

Usage: python tools/make_rgbd_example.py OUT_DIR
writes OUT_DIR/rgbd_photo.png and OUT_DIR/rgbd_depth.png (640x360) and prints
the intrinsics to pass to ``--intrinsics``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from PIL import Image

WIDTH, HEIGHT = 640, 360
FX = FY = 420.0
CX, CY = WIDTH / 2, HEIGHT / 2
FLOOR_Y_M = 1.1          # the floor 1.1 m below the optical axis (camera frame: y down)
WALL_Z_M = 9.0
SUN = np.array([-0.4, -0.8, -0.45])  # direction towards the sun, camera frame
SUN /= np.linalg.norm(SUN)
BALLS = [  # centre (x, y, z) m, radius m, linear albedo
    ((-1.3, FLOOR_Y_M - 0.45, 3.2), 0.45, (0.70, 0.06, 0.04)),
    ((0.35, FLOOR_Y_M - 0.35, 4.3), 0.35, (0.80, 0.62, 0.05)),
    ((1.6, FLOOR_Y_M - 0.55, 5.6), 0.55, (0.80, 0.80, 0.78)),
    ((-0.2, FLOOR_Y_M - 0.30, 6.8), 0.30, (0.05, 0.20, 0.60)),
]
BARS = [(0.70, 0.05, 0.05), (0.85, 0.35, 0.03), (0.85, 0.75, 0.05),
        (0.10, 0.50, 0.10), (0.05, 0.25, 0.65), (0.45, 0.10, 0.50), (0.85, 0.85, 0.85)]


def _sphere_hit(o, d, centre, radius):
    oc = o - np.asarray(centre)
    b = np.einsum("...i,...i->...", oc, d)
    c = np.einsum("...i,...i->...", oc, oc) - radius**2
    disc = b * b - c
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    return np.where((disc > 0) & (t > 1e-4), t, np.inf)


def make_rgbd():
    """The colour image (H, W, 3) uint8 sRGB and the z-depth (H, W) in metres."""
    j, i = np.meshgrid(np.arange(WIDTH) + 0.5, np.arange(HEIGHT) + 0.5)
    d = np.stack([(j - CX) / FX, (i - CY) / FY, np.ones_like(j)], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    o = np.zeros(3)

    t_floor = np.where(d[..., 1] > 1e-6, FLOOR_Y_M / np.maximum(d[..., 1], 1e-6), np.inf)
    t_wall = WALL_Z_M / d[..., 2]
    ts = [t_floor, t_wall] + [_sphere_hit(o, d, c, r) for c, r, _ in BALLS]
    t = np.min(ts, axis=0)
    which = np.argmin(ts, axis=0)
    p = d * t[..., None]

    albedo = np.zeros(p.shape)
    normal = np.zeros(p.shape)
    rng = np.random.default_rng(0)
    grain = rng.normal(0.0, 0.04, (HEIGHT, WIDTH))
    floor = which == 0
    ripple = 0.06 * np.sin(3.1 * p[..., 0] + 1.7 * np.sin(1.3 * p[..., 2])) * np.sin(2.3 * p[..., 2])
    albedo[floor] = np.array([0.55, 0.45, 0.30]) * (1 + ripple[floor] + grain[floor])[:, None]
    normal[floor] = (0.0, -1.0, 0.0)
    wall = which == 1
    bar = np.clip(((p[..., 0] + 7.0) / 2.0).astype(int), 0, len(BARS) - 1)
    albedo[wall] = np.asarray(BARS)[bar[wall]]
    normal[wall] = (0.0, 0.0, -1.0)
    for k, (centre, radius, rho) in enumerate(BALLS):
        m = which == k + 2
        albedo[m] = rho
        normal[m] = (p[m] - np.asarray(centre)) / radius

    lit = np.clip(np.einsum("...i,i->...", normal, SUN), 0.0, None)
    shadow_o = p + normal * 1e-3
    for centre, radius, _ in BALLS:
        lit = np.where(np.isfinite(_sphere_hit(shadow_o, np.broadcast_to(SUN, p.shape),
                                               centre, radius)), 0.0, lit)
    linear = np.clip(albedo * (0.3 + 0.9 * lit)[..., None], 0.0, 1.0)
    srgb = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * linear ** (1 / 2.4) - 0.055)
    return np.round(srgb * 255).astype(np.uint8), p[..., 2]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out_dir", type=Path)
    args = parser.parse_args(argv)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    rgb, z_m = make_rgbd()
    Image.fromarray(rgb).save(args.out_dir / "rgbd_photo.png", optimize=True)
    depth_mm = np.round(z_m * 1000).astype(np.uint16)
    Image.fromarray(depth_mm).save(args.out_dir / "rgbd_depth.png")
    print(f"--intrinsics {FX:g},{FY:g},{CX:g},{CY:g}")


if __name__ == "__main__":
    main()
