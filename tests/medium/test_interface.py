"""The air-water interface (aquaspec.medium.interface): Snell, Fresnel, the window."""

import numpy as np
import pytest

from aquaspec.light.sun import air_to_sun
from aquaspec.medium import interface
from aquaspec.medium.interface import N_WATER, fresnel_transmittance, refract


def test_refraction_obeys_snell():
    rng = np.random.default_rng(1)
    n = rng.normal(size=(200, 3)) * [0.2, 1.0, 0.2]
    n[:, 1] = np.abs(n[:, 1]) + 0.5
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    d = np.broadcast_to(-air_to_sun(50.0, 20.0), n.shape)
    t, cos_i = refract(d, n)
    ok = cos_i > 0
    sin_i = np.sqrt(1 - cos_i[ok] ** 2)
    cos_t = -np.sum(t[ok] * n[ok], axis=1)
    np.testing.assert_allclose(np.linalg.norm(t[ok], axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.sqrt(1 - cos_t ** 2) * N_WATER, sin_i, atol=1e-12)
    # t lies in the plane of d and n
    np.testing.assert_allclose(np.einsum("ij,ij->i", np.cross(d[ok], n[ok]), t[ok]), 0,
                               atol=1e-12)


def test_fresnel():
    # Normal incidence: 1 - ((n-1)/(n+1))^2.
    np.testing.assert_allclose(fresnel_transmittance(1.0), 1 - (0.33 / 2.33) ** 2)
    assert fresnel_transmittance(0.0) == pytest.approx(0.0, abs=1e-12)


def test_snell_window_integrates_to_e0():
    # Radiance E0 n^2/pi inside the window, integrated with cos over the
    # window, gives back E0.
    mu = np.linspace(0, 1, 200001)
    l = interface.surface_from_below(1.0, mu)
    e = np.trapezoid(2 * np.pi * l * mu, mu)
    np.testing.assert_allclose(e, 1.0, rtol=1e-3)
