"""The wind sea's facets and the sun's glitter (light.wave_facets)."""

from __future__ import annotations

import numpy as np

from aquaspec.light.wave_facets import SurfaceFacets, glitter, surface_facets
from aquaspec.light.waves import Waves, cox_munk_slope_variance, resolved_slope_variance
from aquaspec.medium.interface import fresnel_transmittance


def test_facets_are_the_tile_s_slopes_periodic_and_bilinear():
    waves = Waves(7.0, grid=32, tile_m=4.0)
    f = surface_facets(waves)
    m = f.slopes.shape[0]
    i, j = 5, 17
    x, z = j * 4.0 / m, i * 4.0 / m
    np.testing.assert_allclose(f.slopes_at(x, z), f.slopes[i, j], rtol=1e-6)
    np.testing.assert_allclose(f.slopes_at(x + 8.0, z - 4.0), f.slopes[i, j], rtol=1e-5)
    mid = f.slopes_at(x + 0.5 * 4.0 / m, z)
    np.testing.assert_allclose(mid, 0.5 * (f.slopes[i, j] + f.slopes[i, j + 1]), rtol=1e-5)
    n = f.normals(np.array([x]), np.array([z]))[0]
    np.testing.assert_allclose(n, np.array([-f.slopes[i, j, 0], 1.0, -f.slopes[i, j, 1]])
                               / np.sqrt(1 + np.sum(f.slopes[i, j] ** 2)), rtol=1e-6)
    # What the tile resolves plus what it leaves to the glitter is Cox & Munk's.
    assert 0 < f.s2 < cox_munk_slope_variance(7.0)
    np.testing.assert_allclose(f.s2 + resolved_slope_variance(waves),
                               cox_munk_slope_variance(7.0), rtol=1e-9)


def test_glitter_reflects_the_sun_s_energy():
    """On a flat mean surface, the glitter's radiance integrated over the
    directions it leaves in (cosine-weighted) is the sun's irradiance on the
    surface times the Fresnel reflectance (within the small-slope
    approximation's few per cent), and the brightest way is near the mirror's."""
    s2, e_sun = 0.02, 1.0
    elev = np.radians(50.0)
    to_sun = np.array([0.0, np.sin(elev), -np.cos(elev)])
    # Ways the reflected light leaves: w (up); the view ray is v = -w.
    theta = np.linspace(0.0, np.radians(89.0), 400)
    phi = np.linspace(-np.pi, np.pi, 801)
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    w = np.stack([np.sin(tt) * np.sin(pp), np.cos(tt), -np.sin(tt) * np.cos(pp)], -1).reshape(-1, 3)
    g = glitter(-w, np.tile([0.0, 1.0, 0.0], (len(w), 1)), to_sun, [e_sun], s2)[:, 0]
    dw = np.sin(tt).ravel() * (theta[1] - theta[0]) * (phi[1] - phi[0])
    reflected = np.sum(g * w[:, 1] * dw)
    expect = e_sun * np.sin(elev) * (1 - fresnel_transmittance(np.sin(elev)))
    np.testing.assert_allclose(reflected, expect, rtol=0.05)
    mirror = np.array([0.0, np.sin(elev), np.cos(elev)])
    peak = w[np.argmax(g)]
    assert np.degrees(np.arccos(min(1.0, peak @ mirror))) < 8.0


def test_a_flat_tile_has_upright_facets():
    f = SurfaceFacets(np.zeros((8, 8, 2), np.float32), 2.0, 0.0)
    np.testing.assert_allclose(f.normals(np.array([0.3, 5.0]), np.array([-1.0, 0.2])),
                               [[0.0, 1.0, 0.0]] * 2)
