"""A measurement, not the renderer: the lamps' lit surfaces with their
forward-cone share spread over the image, as the daylight's is, against Mitsuba.

The light field's model counts light a surface sends towards the camera and
the water scatters by less than the forward cone's angle as arriving
(``exp(-(c - f b) S)`` instead of ``exp(-c S)``), and spreads that share,
``(exp(-(c - f b) S) - exp(-c S))`` of it, over the pixels around with the
cone's kernel (:mod:`aquaspec.transport.lightfield.conespread`). The lamps'
lit surfaces get the same extinction but no spread: their forward-scattered
light stays on their own pixels. This tool runs ``tools/lamp_vs_mitsuba.py``
(its cached Mitsuba images, ``--regions``) twice, as aquaspec renders now and
with the lamps' surface light's share ``1 - exp(-f b S)`` taken off its pixels
and spread with the daylight's kernel of the same render (the NumPy shading's
``pyramid_spread`` / ``spread_by_lambda``, wrapped here to keep it). Nothing
of this is in the renderer yet.

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

_spread, _by_lambda, _lamps = shade.pyramid_spread, shade.spread_by_lambda, shade.lamp_radiance
state = {"spread": None, "on": False}


def pyramid_spread(image, weights):
    state["spread"] = lambda x: _spread(x, weights)
    return _spread(image, weights)


def spread_by_lambda(cone, lam, nodes, weights):
    state["spread"] = lambda x: _by_lambda(x, lam, nodes, weights)
    return _by_lambda(cone, lam, nodes, weights)


def lamp_radiance(gbuffer, lamps, shadows=None, rho_of_hits=None, **kw):
    full = _lamps(gbuffer, lamps, shadows=shadows, rho_of_hits=rho_of_hits, **kw)
    if not state["on"] or state["spread"] is None:
        return full
    n = full.shape[-1]
    water = _lamps(gbuffer, lamps, shadows=shadows,
                   rho_of_hits=lambda m: np.zeros((int(m.sum()), n)), **kw)
    s = gbuffer.distance.astype(float)
    fb = np.asarray(lamps[0].forward_share) * np.asarray(lamps[0].b)
    cone = (full - water) * (1.0 - np.exp(-fb * np.where(np.isfinite(s), s, 0.0)[..., None]))
    return full - cone + state["spread"](cone)


shade.pyramid_spread, shade.spread_by_lambda = pyramid_spread, spread_by_lambda
shade.lamp_radiance = lamp_radiance

p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
p.add_argument("--cases", default="IB:hg,II:hg")
p.add_argument("--spp", default="8192")
p.add_argument("--cache", required=True)
args = p.parse_args()
for on in (False, True):
    state["on"] = on
    print("the lamps' surface light's cone share spread:" if on else "as rendered now:")
    lamp_vs_mitsuba.main(["--spp", args.spp, "--cache", args.cache, "--cases", args.cases,
                          "--regions"])
