"""The forward cone's share of the lamps' lit surfaces (aquaspec.shading.lamp,
``split_cone``) and its spread in shade_gbuffer: the share against its
definition, light moved and not made, isotropic water hardly changed."""

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.light.lamp import Lamp
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import get_water
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import Camera
from aquaspec.scene.gbuffer import GBuffer
import aquaspec.shading.shade as shade
from aquaspec.shading.lamp import lamp_radiance

RHO = 0.5


def card_gbuffer(width=48, height=32, card_m=3.0):
    """Open water with a square card facing the camera at ``card_m`` in the
    middle third of the image (a camera 20 m deep looking along -z)."""
    cam = Camera((0.0, -20.0, 0.0), (0, 0, -1), (0, 1, 0), width, height, 40.0, 40.0,
                 width / 2, height / 2)
    dirs = cam.ray_directions()
    s = np.full((height, width), np.inf)
    card = np.zeros((height, width), bool)
    card[height // 3:2 * height // 3, width // 3:2 * width // 3] = True
    s[card] = card_m / -dirs[card][:, 2]
    normal = np.broadcast_to([0.0, 0.0, 1.0], s.shape + (3,))
    return GBuffer(cam, s, normal, np.zeros(s.shape, np.uint32), np.zeros(s.shape + (3,)),
                   [object()]), card


def setup_for(phase, **kw):
    lamp = Lamp((0.2, 0.0, 0.0), direction=(0.0, 0.0, -1.0), cone_deg=40.0, power_w=20.0)
    return SpectralSetup(get_water("II"), get_sensor("human"), surface_light("none"),
                         Bands(4), phase=phase, lamps=[lamp], **kw)


def shade_card(setup, split=True):
    g, card = card_gbuffer()
    medium = setup.medium([])
    medium["material_bands"] = np.full((1, 4), RHO)
    lamps = setup.lamp_inputs(g.camera)
    tables = setup.lightfield_tables()
    if split:
        out = shade.shade_gbuffer(g, **medium, lightfield=tables, lamps=lamps,
                                  return_radiance=True)
    else:
        real = shade.lamp_radiance

        def kept(*a, split_cone=False, **k):
            r = real(*a, **k)
            return (r, np.zeros_like(r)) if split_cone else r
        shade.lamp_radiance = kept
        try:
            out = shade.shade_gbuffer(g, **medium, lightfield=tables, lamps=lamps,
                                      return_radiance=True)
        finally:
            shade.lamp_radiance = real
    return out["radiance"], card


def test_share_is_the_surface_light_against_the_veil_it_hides():
    """split_cone's share is (1 - exp(-f b S)) L_s - (1 - exp(-<f b> S)) (V(inf) - V(S)),
    composed here from separate calls: the lit card minus the black card (L_s),
    the black card's veil V(S) and open water's V(inf) (marched veils)."""
    setup = setup_for("petzold")
    g, card = card_gbuffer(16, 12)
    (inp,) = setup.lamp_inputs(g.camera)
    kw = dict(veil="march", n_samples=64)
    lit = lambda m: np.full((int(m.sum()), 4), RHO)
    black = lambda m: np.zeros((int(m.sum()), 4))
    full, cone = lamp_radiance(g, [inp], rho_of_hits=lit, split_cone=True, **kw)
    v_s = lamp_radiance(g, [inp], rho_of_hits=black, **kw)
    open_g = GBuffer(g.camera, np.full(g.distance.shape, np.inf), g.normal, g.material,
                     g.sigmoid, g.materials)
    v_inf = lamp_radiance(open_g, [inp], rho_of_hits=black, **kw)
    fb = inp.forward_share * inp.b
    s = g.distance[card][:, None]
    want = (1 - np.exp(-fb * s)) * (full - v_s)[card] - (1 - np.exp(-fb.mean() * s)) * (
        v_inf - v_s)[card]
    np.testing.assert_allclose(cone[card], want, rtol=1e-9, atol=1e-12 * np.abs(want).max())
    assert np.all(cone[~card] == 0) and np.all(cone[card] > 0)
    # Without the forward cone (the seeds' model: f = 0) there is no share.
    seeds = setup_for("petzold", ms_model="seeds").lamp_inputs(g.camera)
    _, none = lamp_radiance(g, seeds, rho_of_hits=lit, split_cone=True, **kw)
    assert np.all(none == 0)


def test_the_cone_share_moves_light_from_the_card_to_the_water_around():
    """Forward-peaked water (Petzold): the card's own pixels give up light, the
    open water around gains it, the image's sum is kept (the pyramid's
    borders: 1e-3)."""
    spread, card = shade_card(setup_for("petzold"))
    kept, _ = shade_card(setup_for("petzold"), split=False)
    assert np.all(spread[card].sum(-1) < kept[card].sum(-1))
    around = np.zeros_like(card)
    around[card.shape[0] // 3 - 2:2 * card.shape[0] // 3 + 2,
           card.shape[1] // 3 - 2:2 * card.shape[1] // 3 + 2] = True
    around &= ~card
    gain = spread[around].sum() / kept[around].sum()
    assert gain > 1.05
    assert spread.sum() == pytest.approx(kept.sum(), rel=1e-3)
    assert np.abs(spread - kept).max() > 0.05 * kept.max()


def test_isotropic_water_hardly_changes():
    """Isotropic scattering has little of b in the forward cone: the image moves
    by under 1 % of its largest value."""
    spread, _ = shade_card(setup_for("isotropic"))
    kept, _ = shade_card(setup_for("isotropic"), split=False)
    assert np.abs(spread - kept).max() < 0.01 * kept.max()
