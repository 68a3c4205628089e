"""Jaffe's trade-off: the backscatter in front of a target falls as the lamp moves away
from the camera, in aquaspec and in Mitsuba 3 (every order of scattering).

A black card 1 m square 2 m ahead of the camera at 10 m (so the pixels on it
hold the water's light alone, the backscatter), a spot lamp (cone 40 degrees,
10 W, equal-energy spectrum) beside the camera at a separation ``s``, aimed
at the card's centre; no daylight; Jerlov II. For each separation, the mean
camera-independent band radiance over the card's pixels (the five bands'
mean), aquaspec (NumPy backend, default model, the glow included) and Mitsuba, plotted side by
side.

Usage::

    python tools/lamp_jaffe.py [--spp 4096] [--phase isotropic] [-o docs/images/lamp_jaffe.png]

Needs the ``validation`` extra (Mitsuba 3).
"""

from __future__ import annotations

import argparse

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.reflectance import Reflectance
from aquaspec.light.lamp import Lamp
from aquaspec.light.sky import surface_light
from aquaspec.medium.phase import HenyeyGreenstein
from aquaspec.medium.water import load_water
from aquaspec.rendering.api import render
from aquaspec.scene.camera import Camera
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.validation.reference import render_reference

SEPARATIONS_M = (0.1, 0.25, 0.5, 1.0, 2.0)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--spp", type=int, default=4096)
    p.add_argument("--water", default="II")
    p.add_argument("--phase", default="isotropic", choices=("isotropic", "hg"))
    p.add_argument("-o", "--output", default=None, help="the plot (PNG); default: none")
    args = p.parse_args(argv)
    water = load_water(args.water)
    g = HenyeyGreenstein().g if args.phase == "hg" else 0.0
    black = Reflectance("black", np.array([380.0, 720.0]), np.zeros(2))
    scene = Scene(materials=[black])
    card = np.array([[-0.5, -10.5, -2], [0.5, -10.5, -2], [0.5, -9.5, -2],
                     [-0.5, -9.5, -2]], float)
    scene.add(Mesh.flat(card, np.array([[0, 1, 2], [0, 2, 3]])))
    o = np.array([0.0, -10.0, 0.0])
    cam = Camera.look_at(o, o + [0.0, 0.0, -1.0], width=8, height=8, fov_y_deg=20.0)
    bands = Bands(5)
    ours, theirs, noise = [], [], []
    for sep in SEPARATIONS_M:
        pos = o + [sep, 0.0, 0.0]
        lamp = Lamp(pos, direction=np.array([0.0, -10.0, -2.0]) - pos, cone_deg=40.0,
                    power_w=10.0, spectrum="uniform", frame="world")
        ref = render_reference(scene, cam, water, surface_light("none"), spp=args.spp,
                               bands=bands, phase=args.phase, g=g,
                               lamps=[lamp])["band_radiance"].reshape(-1, bands.n).mean(-1)
        rad = render(water=water, scene=scene, camera=cam, bands=bands.n, light="none",
                     lamps=[lamp], backend="numpy", return_radiance=True, exposure=0,
                     seabed=None, phase=args.phase).radiance.reshape(-1, bands.n).mean(-1)
        ours.append(rad.mean())
        theirs.append(ref.mean())
        noise.append(ref.std(ddof=1) / np.sqrt(ref.size))
        print(f"separation {sep:4.2f} m: aquaspec {ours[-1]:.4g}, Mitsuba {theirs[-1]:.4g} "
              f"(+- {noise[-1]:.2g}), ratio {ours[-1] / theirs[-1]:.3f}", flush=True)
    if args.output:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5, 3.4), dpi=110)
        ax.plot(SEPARATIONS_M, ours, "o-", label="aquaspec (single scattering and glow)")
        ax.errorbar(SEPARATIONS_M, theirs, yerr=2 * np.asarray(noise), fmt="s--",
                    label="Mitsuba 3 (all orders)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("camera-lamp separation (m)")
        ax.set_ylabel("backscatter before a black card\n(W m$^{-2}$ sr$^{-1}$ nm$^{-1}$)")
        ax.set_title(f"Jerlov {args.water}, {args.phase}, card 2 m ahead", fontsize=9)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(args.output)
        print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
