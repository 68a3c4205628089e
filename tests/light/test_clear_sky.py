"""The CIE standard clear sky's radiance distribution (aquaspec.light.sky)."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.light.sky import clear_sky_norm, clear_sky_shape


def _to_sun(elevation_deg, azimuth_rad=0.7):
    e = np.radians(elevation_deg)
    return np.array([np.cos(e) * np.sin(azimuth_rad), np.sin(e), -np.cos(e) * np.cos(azimuth_rad)])


@pytest.mark.parametrize("elevation", [10.0, 35.0, 70.0])
def test_the_shape_keeps_the_horizontal_irradiance(elevation):
    """int shape cos Z d omega = pi (a uniform sky's), by a finer rule in
    (Z, azimuth) than the normaliser's."""
    to_sun = _to_sun(elevation)
    z = (np.arange(600) + 0.5) * (np.pi / 2) / 600
    az = (np.arange(1200) + 0.5) * 2 * np.pi / 1200
    d = np.stack([np.sin(z)[:, None] * np.cos(az)[None], np.cos(z)[:, None] * np.ones(1200)[None],
                  np.sin(z)[:, None] * np.sin(az)[None]], axis=-1)
    w = np.cos(z) * np.sin(z) * (np.pi / 2 / 600) * (2 * np.pi / 1200)
    integral = float(np.sum(clear_sky_shape(d, to_sun) * w[:, None]))
    assert integral == pytest.approx(np.pi, rel=2e-4)


def test_zenith_against_the_horizon_square_to_the_sun():
    """CIE type 12: L(zenith) / L(horizon, 90 degrees from the sun) =
    (1 - e^-0.32) (1 + 10 (e^(-3 chi) - e^(-3 pi / 2)) + 0.45 cos^2 chi) with
    chi the sun's zenith angle (the horizon point: gradation 1, indicatrix 1)."""
    elevation = 40.0
    to_sun = _to_sun(elevation, 0.0)
    side = np.array([1.0, 0.0, 0.0])
    chi = np.radians(90.0 - elevation)
    expect = (1 - np.exp(-0.32)) * (1 + 10 * (np.exp(-3 * chi) - np.exp(-3 * np.pi / 2))
                                    + 0.45 * np.cos(chi) ** 2)
    got = clear_sky_shape(np.array([[0.0, 1.0, 0.0], side]), to_sun)
    assert got[0] / got[1] == pytest.approx(expect, rel=1e-12)
    # Brightest towards the sun, darkest about 90 degrees from it, overhead.
    assert clear_sky_shape(to_sun, to_sun) > 5 * got[0]
    assert clear_sky_norm(to_sun) == pytest.approx(clear_sky_norm(to_sun, nodes=512), rel=1e-4)
