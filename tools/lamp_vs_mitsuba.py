"""A first look at what aquaspec's lamps leave out: a card lit by a spot lamp, against
Mitsuba 3 with every order of scattering.

A grey card (reflectance 0.5) 1 m square, 2 m ahead of the camera at 10 m; a
spot lamp (cone 40 degrees, 10 W, equal-energy spectrum) 0.2 m beside the
camera, looking ahead; no daylight; 16x8 pixels over 40 degrees; 5 bands.
aquaspec renders with the NumPy backend (direct light and single scattering,
the default light-field model's extinctions; ``--ms-model monzon2022`` for c);
Mitsuba's ``volpathmis`` without a path-length limit. Prints aquaspec /
Mitsuba per band, on the card's pixels and on the open water around it.

aquaspec's model is printed with the lamps' glow (their light scattered more
than once, :mod:`aquaspec.transport.lamp_halo`; "+halo") and without it.
``--cache DIR`` keeps Mitsuba's images there (one ``.npy`` per water, phase
function and sample count) and reads them back on the next run.

Usage::

    python tools/lamp_vs_mitsuba.py [--spp 8192] [--cases IB:isotropic,II:hg,...] [--cache DIR]
        [--max-depth N] [--regions]

``--max-depth 2`` limits Mitsuba to light scattered once (against aquaspec's
single scattering with ``c``: ``monzon2022`` without the glow).

Needs the ``validation`` extra (Mitsuba 3). HG is g = 0.92, as aquaspec's default.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.reflectance import Reflectance
from aquaspec.light.lamp import Lamp
from aquaspec.light.sky import surface_light
from aquaspec.medium.phase import HenyeyGreenstein
from aquaspec.medium.water import load_water
from aquaspec.rendering.api import render
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import Camera
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.validation.reference import render_reference

CASES = "IB:isotropic,IB:hg,II:isotropic,II:hg,3C:isotropic"


def card_scene():
    grey = Reflectance("grey", np.array([380.0, 720.0]), np.array([0.5, 0.5]))
    scene = Scene(materials=[grey])
    card = np.array([[-0.5, -10.5, -2], [0.5, -10.5, -2], [0.5, -9.5, -2],
                     [-0.5, -9.5, -2]], float)
    scene.add(Mesh.flat(card, np.array([[0, 1, 2], [0, 2, 3]])))
    o = np.array([0.0, -10.0, 0.0])
    cam = Camera.look_at(o, o + [0.0, 0.0, -1.0], width=16, height=8, fov_y_deg=40.0)
    lamp = Lamp(o + [0.2, 0.0, 0.0], direction=(0.0, 0.0, -1.0), cone_deg=40.0, power_w=10.0,
                spectrum="uniform", frame="world")
    return scene, cam, lamp, card_coverage(cam, o)


def card_coverage(cam, o, sub: int = 8):
    """The share of each pixel's footprint on the card (the camera's field cut
    into ``sub`` x ``sub`` subpixels). Mitsuba's box filter averages a pixel
    over its footprint, aquaspec samples its centre: the regions compared are
    the pixels wholly on the card and wholly off it. (Pixels whose centre only
    was on the card, counted as open water before 2026-11-28, made the open
    water with HG 0.92 look 1.25-1.35x too bright: the card is 30-100x the
    veil there.)"""
    fine = Camera.look_at(o, o + [0.0, 0.0, -1.0], width=cam.width * sub,
                          height=cam.height * sub, fov_y_deg=40.0)
    dirs = fine.ray_directions()
    hits = o + dirs * (2.0 / -dirs[..., 2])[..., None]
    on = (np.abs(hits[..., 0]) < 0.5) & (np.abs(hits[..., 1] + 10) < 0.5)
    return on.reshape(cam.height, sub, cam.width, sub).mean(axis=(1, 3))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--spp", type=int, default=8192)
    p.add_argument("--cases", default=CASES, help=f"WATER:PHASE,... (default {CASES})")
    p.add_argument("--cache", type=Path, help="keep Mitsuba's images in this directory")
    p.add_argument("--regions", action="store_true",
                   help="also the open water in three parts: the lamp's side (columns 12-15), "
                        "around the card (4-11: its shadow in the beam), the far side (0-3)")
    p.add_argument("--max-depth", type=int, default=-1,
                   help="Mitsuba's path length limit (-1: none; 2: light scattered once)")
    args = p.parse_args(argv)
    lamp_inputs = SpectralSetup.lamp_inputs

    def without_halo(self, camera):
        return [dataclasses.replace(i, halo=False) for i in lamp_inputs(self, camera)]
    scene, cam, lamp, coverage = card_scene()
    on_card, off_card = coverage >= 1.0, coverage <= 0.0
    print(f"{int(on_card.sum())} pixels wholly on the card, {int(off_card.sum())} wholly off it "
          f"(open water), {int((~on_card & ~off_card).sum())} on its edge left out")
    bands = Bands(5)
    for case in args.cases.split(","):
        water_name, phase = case.split(":")
        water = load_water(water_name)
        g = HenyeyGreenstein().g if phase == "hg" else 0.0
        t0 = time.time()
        depth = "" if args.max_depth < 0 else f"_depth{args.max_depth}"
        cached = (None if args.cache is None
                  else args.cache / f"{water_name}_{phase}_{args.spp}{depth}.npy")
        if cached is not None and cached.exists():
            ref = np.load(cached)
        else:
            ref = render_reference(scene, cam, water, surface_light("none"), spp=args.spp,
                                   bands=bands, phase=phase, g=g, lamps=[lamp],
                                   max_depth=args.max_depth)["band_radiance"]
            if cached is not None:
                cached.parent.mkdir(parents=True, exist_ok=True)
                np.save(cached, ref)
        seconds = time.time() - t0
        for model in ("monzon2022", "lightfield"):
            for halo in (False, True):
                SpectralSetup.lamp_inputs = lamp_inputs if halo else without_halo
                try:
                    rad = render(water=water, scene=scene, camera=cam, bands=bands.n,
                                 light="none", lamps=[lamp], backend="numpy",
                                 return_radiance=True, exposure=0, seabed=None, ms_model=model,
                                 phase=phase).radiance
                finally:
                    SpectralSetup.lamp_inputs = lamp_inputs
                cols = np.broadcast_to(np.arange(cam.width), off_card.shape)
                parts = [("card", on_card), ("water", off_card)]
                if args.regions:
                    parts += [("lamp side", off_card & (cols >= 12)),
                              ("around card", off_card & (cols >= 4) & (cols <= 11)),
                              ("far side", off_card & (cols <= 3))]
                for region, mask in parts:
                    ratio = rad[mask].mean(0) / ref[mask].mean(0)
                    label = model + ("+halo" if halo else "")
                    print(f"{water_name:3s} {phase:9s} {label:15s} {region:11s} "
                          + " ".join(f"{x:5.2f}" for x in ratio), flush=True)
        print(f"    (Mitsuba {args.spp} spp, max_depth {args.max_depth}, {seconds:.0f} s)",
              flush=True)


if __name__ == "__main__":
    main()
