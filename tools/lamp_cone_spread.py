"""A measurement: the lamps' lit surfaces with their forward-cone share spread
over the image (the renderer, :mod:`aquaspec.shading.lamp`) and kept on their
own pixels (the renderer before 2026-11-28), against Mitsuba.

The light field's model counts light a surface sends towards the camera and
the water scatters by less than the forward cone's angle as arriving
(``exp(-(c - f b) S)`` instead of ``exp(-c S)``), and spreads that share over
the pixels around with the cone's kernel
(:mod:`aquaspec.transport.lightfield.conespread`). The lamps' lit surfaces'
share, ``(1 - exp(-f b S)) L_s`` less the same share of the veil they hide, is
spread too (``lamp_radiance(split_cone=True)`` in
:func:`aquaspec.shading.shade.shade_gbuffer`). This tool runs
``tools/lamp_vs_mitsuba.py`` (its cached Mitsuba images, ``--regions``) twice:
with the share kept on the lit surfaces' pixels (``lamp_radiance`` wrapped to
return no share), then as the renderer does.

Usage::

    python tools/lamp_cone_spread.py [--cases IB:hg,II:hg] [--spp 8192] --cache DIR
"""
import argparse
import sys
from pathlib import Path

import numpy as np

import aquaspec.shading.shade as shade

sys.path.insert(0, str(Path(__file__).parent))
import lamp_vs_mitsuba  # noqa: E402

_lamps = shade.lamp_radiance
state = {"spread": True}


def lamp_radiance(*args, split_cone=False, **kw):
    if state["spread"] or not split_cone:
        return _lamps(*args, split_cone=split_cone, **kw)
    full = _lamps(*args, **kw)
    return full, np.zeros_like(full)


shade.lamp_radiance = lamp_radiance

p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
p.add_argument("--cases", default="IB:hg,II:hg")
p.add_argument("--spp", default="8192")
p.add_argument("--cache", required=True)
args = p.parse_args()
for on in (False, True):
    state["spread"] = on
    print("the lamps' surface light's cone share spread (the renderer):" if on
          else "the share kept on the lit surfaces' pixels (before):")
    lamp_vs_mitsuba.main(["--spp", args.spp, "--cache", args.cache, "--cases", args.cases,
                          "--regions"])
