"""The thin lens's blur and vignetting, and the dome port's virtual image, each
against a computation written apart from the code (image distances of the
lens equation; rays traced through two concentric spheres)."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.optics.dispersion import GLASSES, water_index_QuanFry1995
from aquaspec.optics.dome_port import DomePort
from aquaspec.optics.flat_port import FlatPort
from aquaspec.optics.lens import ThinLens, defocus


class TestThinLens:
    def test_blur_from_image_distances(self):
        lens = ThinLens(focal_length_mm=50.0, f_number=4.0, focus_distance_m=2.0)
        f, a = 0.05, 0.05 / 4.0
        sensor = 1.0 / (1.0 / f - 1.0 / 2.0)          # where the focused image lies
        f_px = 2000.0
        for z in (0.5, 1.0, 3.0, 10.0):
            zi = 1.0 / (1.0 / f - 1.0 / z)
            blur_m = a * abs(zi - sensor) / zi          # similar triangles behind the lens
            got = lens.blur_diameter_px(z, 2.0, f_px)
            np.testing.assert_allclose(got, blur_m * f_px / f, rtol=1e-12)
        assert lens.blur_diameter_px(2.0, 2.0, f_px) == 0.0
        np.testing.assert_allclose(lens.blur_diameter_px(np.inf, 2.0, f_px),
                                   a * f / (2.0 - f) * f_px / f)

    def test_vignetting_cos4(self):
        lens = ThinLens()
        theta = np.radians(30.0)
        np.testing.assert_allclose(lens.vignetting_factor(np.tan(theta), 0.0), np.cos(theta) ** 4)
        assert ThinLens(vignetting="none").vignetting_factor(1.0, 1.0) == 1.0
        with pytest.raises(AquaspecError, match="accepted: cos4, none"):
            ThinLens(vignetting="cos3")

    def test_defocus_keeps_energy_and_spreads_a_point_to_its_disc(self):
        img = np.zeros((81, 81, 1))
        img[40, 40, 0] = 1.0
        out = defocus(img, np.full((81, 81), 16.0))      # radius 8 px
        assert abs(out.sum() - 1.0) < 1e-9
        y, x = np.mgrid[:81, :81]
        # Centred where the point was (no shift from the FFT's wrap-around).
        assert abs((x * out[..., 0]).sum() - 40) < 1e-9 and abs((y * out[..., 0]).sum() - 40) < 1e-9
        r2 = ((x - 40) ** 2 + (y - 40) ** 2) * out[..., 0]
        # A uniform disc of radius R has mean squared radius R^2 / 2.
        assert abs(r2.sum() / out.sum() - 8.0 ** 2 / 2) < 0.05 * 32
        sharp = defocus(img, np.zeros((81, 81)))
        np.testing.assert_array_equal(sharp, img)


def _refract(d, normal, n1, n2):
    cos_i = -np.dot(normal, d)
    eta = n1 / n2
    return eta * d + (eta * cos_i - np.sqrt(1.0 - eta * eta * (1.0 - cos_i ** 2))) * normal


def _sphere_hit(p, d, radius):
    """First hit of the ray p + s d (s > 0) with the sphere |x| = radius centred at 0."""
    b = np.dot(p, d)
    c = np.dot(p, p) - radius ** 2
    s = -b - np.sqrt(b * b - c)
    if s <= 1e-12:
        s = -b + np.sqrt(b * b - c)
    return p + s * d


class TestDomePort:
    @pytest.mark.parametrize("distance", [0.5, 1.0, 3.0])
    def test_virtual_image_against_traced_rays(self, distance):
        dome = DomePort(radius_m=0.05, thickness_m=0.006)
        lam = 550.0
        n_w, n_g = float(water_index_QuanFry1995(lam)), float(GLASSES["bk7"].index(lam))
        src = np.array([0.0, 0.0, distance])                 # on a chief ray (the z axis)
        crossings = []
        for ang in (1e-5, 2e-5):                              # paraxial rays towards the dome
            d = np.array([np.sin(ang), 0.0, -np.cos(ang)])
            p = _sphere_hit(src, d, 0.05)
            d = _refract(d, p / np.linalg.norm(p), n_w, n_g)
            p = _sphere_hit(p, d, 0.044)
            d = _refract(d, p / np.linalg.norm(p), n_g, 1.0)
            # Back-extend the ray in air to the z axis: where the lens sees the point.
            s = -p[0] / d[0]
            crossings.append(p[2] + s * d[2])
        traced = (4 * crossings[0] - crossings[1]) / 3        # Richardson: the paraxial limit
        np.testing.assert_allclose(dome.virtual_distance(distance, lam), traced, rtol=1e-5)
        assert dome.virtual_distance(distance, lam) < distance

    def test_image_of_infinity_near_four_radii(self):
        thin = DomePort(radius_m=0.05, thickness_m=0.0)
        n_w = float(water_index_QuanFry1995(550.0))
        np.testing.assert_allclose(thin.virtual_distance(np.inf), 0.05 * n_w / (n_w - 1))
        with pytest.raises(AquaspecError, match="inside the dome"):
            thin.virtual_distance(0.01)


class TestFlatPortFocus:
    def test_on_axis_virtual_distance_is_the_reduced_thickness(self):
        port = FlatPort(thickness_m=0.01, gap_m=0.04)
        n_w, n_g = port.indices(550.0)
        got = port.virtual_distance(0.0, 550.0, 2.0)
        np.testing.assert_allclose(got, 0.04 + 0.01 / n_g + 2.0 / n_w)
        # Off axis the image lies nearer still (the tangential focus moves in).
        assert port.virtual_distance(0.8, 550.0, 2.0) < got / np.cos(np.arctan(0.8))


class TestRadianceInAir:
    def test_normal_incidence_closed_form(self):
        # On the axis both ports pass (1 - R_wg)(1 - R_ga) of the basic radiance
        # L/n^2, with R = ((n1 - n2)/(n1 + n2))^2 at normal incidence.
        lam = np.array([450.0, 550.0, 650.0])
        n_w, n_g = water_index_QuanFry1995(lam), GLASSES["bk7"].index(lam)
        t = (1 - ((n_g - n_w) / (n_g + n_w)) ** 2) * (1 - ((n_g - 1) / (n_g + 1)) ** 2)
        np.testing.assert_allclose(FlatPort().radiance_factor(0.0, lam), t / n_w ** 2, rtol=1e-12)
        np.testing.assert_allclose(DomePort().radiance_factor(lam), t / n_w ** 2, rtol=1e-12)
        assert np.all(t / n_w ** 2 < 0.56)

    def test_flat_port_loses_more_off_axis(self):
        f = FlatPort().radiance_factor(np.array([0.0, 0.6, 1.2]), 550.0)
        assert np.all(np.diff(f) < 0) and f[-1] / f[0] > 0.95
