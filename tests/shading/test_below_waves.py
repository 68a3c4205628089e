"""The wind sea seen from below (shading.below_waves): Snell's window broken by waves."""

from __future__ import annotations

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.light.sky import surface_light
from aquaspec.light.wave_facets import SurfaceFacets, surface_facets
from aquaspec.light.waves import Waves
from aquaspec.medium.interface import N_WATER, fresnel_transmittance
from aquaspec.medium.water import load_water
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import Camera
from aquaspec.shading.above_water import WAVE_T_TOP, sky_radiance_above, water_below_table
from aquaspec.medium.interface import fresnel_transmittance_out as transmittance_out
from aquaspec.shading.below_waves import surface_from_below, window_correction

BANDS = Bands(4)


def _looking_up(depth=4.0, size=48, pitch_deg=70.0, fov=90.0):
    p = np.array([0.0, -depth, 0.0])
    t = np.radians(pitch_deg)
    return Camera.look_at(p, p + [0.0, np.sin(t), -np.cos(t)], width=size, height=size,
                          fov_y_deg=fov)


def _setup(water="IB"):
    return SpectralSetup(load_water(water), get_sensor("human"), surface_light("overcast"),
                         BANDS, surface="flat")


def test_transmittance_out_is_fresnel_by_reciprocity():
    mu = np.array([1.0, 0.9, 0.75, 0.66, 0.5])
    cos_air = np.sqrt(np.clip(1 - N_WATER ** 2 * (1 - mu ** 2), 0, 1))
    inside = N_WATER ** 2 * (1 - mu ** 2) < 1
    np.testing.assert_allclose(transmittance_out(mu)[inside],
                               fresnel_transmittance(cos_air[inside]), rtol=1e-12)
    assert np.all(transmittance_out(mu)[~inside] == 0)


def test_the_flat_surface_from_below_is_the_light_field_s_top():
    """With an upright facet the formula is the flat light field's own top
    boundary (the sky through the window, the water mirrored outside it):
    so the correction of a flat sea is zero, and the formula agrees with the
    tables' top radiance within 1 %."""
    setup = _setup()
    tables, med = setup.lightfield_tables(), setup.medium([])
    sky = sky_radiance_above(tables, med["e0"])
    nodes, table = water_below_table(tables, a=med["a"], b=med["b"], e0=med["e0"],
                                     t_top=WAVE_T_TOP)
    vy = np.array([0.95, 0.8, 0.7, 0.6, 0.4, 0.2])
    v = np.stack([np.sqrt(1 - vy ** 2), vy, np.zeros_like(vy)], axis=1)
    mine = surface_from_below(v, np.tile([0.0, 1.0, 0.0], (len(v), 1)), sky, nodes, table)
    np.testing.assert_allclose(mine, tables.top_radiance(vy, med["e0"]), rtol=0.01)
    cam = _looking_up()
    flat = SurfaceFacets(np.zeros((8, 8, 2), np.float32), 4.0, 0.0)
    out = window_correction(cam, np.ones((48, 48), bool), tables, flat, a=med["a"], b=med["b"],
                            e0=med["e0"])
    assert np.all(out == 0)


def test_waves_break_the_window():
    """A 6 m/s sea: the window's edge is no longer a circle (rays outside the
    flat window see the sky through tilted facets, rays inside see the water
    mirrored); only open water looking up changes; the correction fades with
    exp(-c S)."""
    setup = _setup()
    tables, med = setup.lightfield_tables(), setup.medium([])
    facets = surface_facets(Waves(6.0, grid=64))
    cam = _looking_up()
    v = cam.ray_directions()
    open_up = np.ones(v.shape[:2], bool)
    open_up[:, :10] = False                      # a surface in the way on the left
    d = window_correction(cam, open_up, tables, facets, a=med["a"], b=med["b"], e0=med["e0"])
    assert np.all(d[:, :10] == 0) and np.all(d[v[..., 1] <= 0] == 0)
    window = v[..., 1] > np.sqrt(1 - 1 / N_WATER ** 2)
    outside = (v[..., 1] > 0) & ~window & open_up
    assert (d[outside][:, 1] > 0).any() and (d[window & open_up][:, 1] < 0).any()
    deep = window_correction(_looking_up(depth=40.0), open_up, tables, facets, a=med["a"],
                             b=med["b"], e0=med["e0"])
    assert np.abs(deep).max() < 0.2 * np.abs(d).max()
    assert np.all(np.isfinite(d))


def test_the_sun_seen_through_the_flat_surface_keeps_its_energy():
    """Looking straight up at a sun near the zenith: the disc summed over the
    image (radiance times each pixel's solid angle, the attenuation taken
    out) is the sun's irradiance through the surface, T E_sun (the n^2 of
    the radiance and the 1/n^2 of the solid angle cancel); at least one
    pixel is lit at a coarse size."""
    from aquaspec.shading.below_waves import sun_disc_below
    e_air, a, b = np.array([2.0]), np.array([0.05]), np.array([0.0])
    to_sun = np.array([0.0, 1.0, 0.0])
    for size, tol in ((33, 1.0), (801, 0.03)):
        p = np.array([0.0, -2.0, 0.0])
        cam = Camera.look_at(p, p + [0.0, 1.0, 0.0], width=size, height=size, fov_y_deg=4.0,
                             up=(0.0, 0.0, -1.0))
        v = cam.ray_directions().reshape(-1, 3)
        disc = sun_disc_below(cam, np.ones((size, size), bool), None, to_sun, e_air,
                              a=a, b=b).reshape(-1, 1)
        s = 2.0 / v[:, 1]
        solid = (v @ cam.forward) ** 3 / (cam.fx * cam.fy)
        total = np.sum(disc[:, 0] * np.exp(0.05 * s) * solid)
        assert (disc > 0).sum() >= 1
        np.testing.assert_allclose(total, fresnel_transmittance(1.0) * e_air[0], rtol=tol)


def test_the_glitter_from_below_transmits_the_sun_s_beam():
    """The sun's transmitted glitter over unresolved slopes (below_waves.glitter_below),
    integrated over the directions it arrives from (cosine-weighted), is the
    transmitted beam's irradiance on the mean surface, E_sun sin(elev) T(sin elev),
    within 1 % (measured 0.1-0.7 % for s2 0.005-0.05, elevations 25-90 deg), and
    it is brightest near the ray the flat surface refracts into the sun (within
    4 deg: 2.9 at 30 deg with s2 = 0.05, the slope law's Jacobian pulls it up)."""
    from aquaspec.shading.below_waves import glitter_below
    th = np.linspace(0.0, np.radians(89.5), 700)
    ph = np.linspace(-np.pi, np.pi, 721)
    tt, pp = np.meshgrid(th, ph, indexing="ij")
    v = np.stack([np.sin(tt) * np.sin(pp), np.cos(tt), -np.sin(tt) * np.cos(pp)],
                 -1).reshape(-1, 3)
    dw = np.sin(tt).ravel() * (th[1] - th[0]) * (ph[1] - ph[0])
    up = np.tile([0.0, 1.0, 0.0], (len(v), 1))
    for s2, elev in ((0.02, 60.0), (0.05, 30.0), (0.01, 90.0)):
        e = np.radians(elev)
        to_sun = np.array([0.0, np.sin(e), -np.cos(e)])
        g = glitter_below(v, up, to_sun, [2.0], s2)[:, 0]
        total = np.sum(g * v[:, 1] * dw)
        np.testing.assert_allclose(total, 2.0 * np.sin(e) * fresnel_transmittance(np.sin(e)),
                                   rtol=0.01)
        sin_w = np.cos(e) / N_WATER                  # the flat surface's refracted ray
        seen = np.array([0.0, np.sqrt(1 - sin_w ** 2), -sin_w])
        assert np.degrees(np.arccos(min(1.0, v[np.argmax(g)] @ seen))) < 4.0


def test_waves_turn_the_sun_s_disc_into_glitter():
    """Under a 6 m/s sea the sun from below spreads over many pixels (the
    tile's facets and the unresolved slopes), where the flat surface's disc
    lights a few; the glitter's variance is widened only on coarse images."""
    from aquaspec.shading.below_waves import glitter_variance_below, sun_disc_below
    facets = surface_facets(Waves(6.0, grid=64))
    to_sun = np.array([0.0, np.sin(np.radians(70.0)), -np.cos(np.radians(70.0))])
    p = np.array([0.0, -2.0, 0.0])
    sin_w = np.cos(np.radians(70.0)) / N_WATER
    cam = Camera.look_at(p, p + [0.0, np.sqrt(1 - sin_w ** 2), -sin_w], width=64, height=64,
                         fov_y_deg=30.0)
    kw = dict(a=np.array([0.05]), b=np.array([0.01]))
    flat = sun_disc_below(cam, np.ones((64, 64), bool), None, to_sun, [1.0], **kw)
    wavy = sun_disc_below(cam, np.ones((64, 64), bool), facets, to_sun, [1.0], **kw)
    assert (flat > 0).sum() <= 12 and (wavy > 1e-3 * wavy.max()).sum() > 100
    assert np.all(np.isfinite(wavy))
    assert glitter_variance_below(cam, facets.s2) == facets.s2
    coarse = Camera.look_at(p, p + [0.0, 1.0, 0.0], width=16, height=16, fov_y_deg=120.0,
                            up=(0.0, 0.0, -1.0))
    assert glitter_variance_below(coarse, facets.s2) > facets.s2
