"""Marine snow's light and discs (aquaspec.shading.particles) against closed forms."""

from types import SimpleNamespace

import numpy as np
import pytest

from aquaspec.scene.camera import Camera
from aquaspec.shading.particles import (ParticleLight, azimuthal_cosine, composite,
                                        lambert_phase, splat_image, splats,
                                        visible_irradiance_table)

#: Linear interpolation of the tables on angle nodes and their float32 texels.
TABLE_RTOL = 2e-3


def _tables(irr_of_mu, n_bands=2, n_mu=33, n_depth=9, c=(0.1, 0.3)):
    """A stand-in for LightfieldTables: ``E(d, n_y)/E0 = irr_of_mu(n_y)`` at every depth."""
    cos = np.cos(np.linspace(np.pi, 0.0, n_mu))
    irr = np.broadcast_to(irr_of_mu(cos)[None, None, :], (n_bands, n_depth, n_mu))
    return SimpleNamespace(irradiance_per_e0=irr.astype(np.float32), cosine=cos,
                           depth_m=np.linspace(0.0, 50.0, n_depth), max_depth_m=50.0,
                           ray_extinction=lambda a, b: np.asarray(c, float))


class TestClosedForms:
    def test_azimuthal_cosine_against_quadrature(self):
        phi = np.linspace(0.0, 2 * np.pi, 20001)
        for mu in (-0.9, -0.3, 0.0, 0.4, 0.95):
            for wy in (-0.8, 0.0, 0.5, 1.0):
                n = np.stack([np.sqrt(1 - mu ** 2) * np.cos(phi), np.full_like(phi, mu),
                              np.sqrt(1 - mu ** 2) * np.sin(phi)], axis=1)
                w = np.array([np.sqrt(1 - wy ** 2), wy, 0.0])
                want = np.trapezoid(np.maximum(n @ w, 0.0), phi)
                assert azimuthal_cosine(mu, wy) == pytest.approx(want, abs=1e-6)

    def test_visible_table_of_a_linear_field(self):
        """E = A + B n_y -> V = A + 2/3 B w_y (the visible hemisphere's projected mean)."""
        a, b = 2.0, 1.5
        t = _tables(lambda mu: a + b * mu)
        v = visible_irradiance_table(t)
        np.testing.assert_allclose(v[1, 4], a + 2.0 / 3.0 * b * t.cosine, rtol=TABLE_RTOL)

    def test_white_sphere_in_isotropic_light_has_its_radiance(self):
        """Isotropic radiance L: E/E0 = 1/4; a sphere of albedo rho shows rho L e^{-c r}."""
        radiance, rho = 3.0, 0.6
        t = _tables(lambda mu: np.full_like(mu, 0.25))
        light = ParticleLight.of(rho, tables=t, e0=np.full(2, 4 * np.pi * radiance), a=0, b=0,
                                 response_weights=np.eye(2, 3))
        p = np.array([[0.0, -3.0, -2.0], [1.0, -1.0, 0.5]])
        cam = np.array([0.0, -3.0, 0.0])
        r = np.linalg.norm(p - cam, axis=1)
        want = rho * radiance * np.exp(-np.outer(r, [0.1, 0.3]))
        np.testing.assert_allclose(light.radiance(p, cam), want, rtol=TABLE_RTOL)

    def test_lambert_phase_against_monte_carlo(self):
        """The disc-averaged radiance of a Lambert sphere in a beam F: (2/3) rho F Phi / pi."""
        n = np.random.default_rng(7).normal(size=(400000, 3))
        n /= np.linalg.norm(n, axis=1)[:, None]
        w = np.array([0.0, 0.0, 1.0])
        for alpha in (0.0, 0.7, 1.6, 2.5):
            s = np.array([np.sin(alpha), 0.0, np.cos(alpha)])
            # Mean over the projected disc: int_vis (n.s)+/pi (n.w) dn / pi.
            mc = np.mean(np.maximum(n @ s, 0.0) * np.maximum(n @ w, 0.0)) * 4.0 / np.pi
            assert mc == pytest.approx(2.0 / 3.0 / np.pi * lambert_phase(np.cos(alpha)),
                                       abs=2e-3)

    def test_sun_at_full_phase(self):
        """The sun behind the camera: (2/3) rho F / pi with F = F0 exp(-c* d / mu0)."""
        t = _tables(lambda mu: np.zeros_like(mu))
        to_sun = np.array([0.0, 0.6, 0.8])
        sun = SimpleNamespace(beam0=np.array([10.0, 20.0]), c_sun=np.array([0.2, 0.4]),
                              to_sun=to_sun, mu0=0.6)
        light = ParticleLight.of(0.5, tables=t, e0=np.ones(2), a=0, b=0,
                                 response_weights=np.eye(2, 3), sun=sun)
        cam = np.array([0.0, -4.0, 0.0])
        p = cam - 2.0 * to_sun
        f = np.array([10.0, 20.0]) * np.exp(-np.array([0.2, 0.4]) * -p[1] / 0.6)
        want = 2.0 / 3.0 * 0.5 * f / np.pi * np.exp(-np.array([0.1, 0.3]) * 2.0)
        np.testing.assert_allclose(light.radiance(p[None], cam)[0], want, rtol=1e-9)


def _camera(w=96, h=64):
    return Camera.look_at([0.0, -5.0, 0.0], [0.0, -5.0, -1.0], width=w, height=h)


class TestDiscs:
    def test_projection_and_coverage(self):
        cam = _camera()
        z, d = 2.0, 0.004
        rec = splats([[0.0, -5.0, -z]], [d], [[1.0, 2.0, 3.0]], cam, blur_px=1.5)
        assert rec.shape == (1, 8)
        assert rec[0, 0] == pytest.approx(cam.cx) and rec[0, 1] == pytest.approx(cam.cy)
        assert rec[0, 3] == pytest.approx(z)
        assert rec[0, 7] == pytest.approx(np.pi / 4 * (d * cam.fy / z) ** 2, rel=1e-6)
        assert rec[0, 2] == pytest.approx(max(0.5 * d * cam.fy / z, 0.75), rel=1e-6)
        # Behind the camera, or off the image: not drawn.
        assert len(splats([[0.0, -5.0, 1.0], [50.0, -5.0, -1.0]], [d, d], np.ones((2, 3)),
                          cam, blur_px=1.5)) == 0

    def test_circle_of_confusion_widens_the_disc(self):
        cam = _camera()
        rec = splats([[0.0, -5.0, -2.0]], [0.001], [[1.0, 1.0, 1.0]], cam, blur_px=1.0,
                     coc_px=lambda z: np.full(np.shape(z), 9.0))
        assert rec[0, 2] == pytest.approx(0.5 * (0.001 * cam.fy / 2.0 + 9.0), rel=1e-6)

    @pytest.mark.parametrize("radius, tol", [(0.5, 0.2), (2.0, 0.02), (7.3, 0.01)])
    def test_splat_keeps_the_coverage(self, radius, tol):
        """The disc's weights sum to about 1 (pi (R^2 + 1/12) is their integral)."""
        rng = np.random.default_rng(3)
        for _ in range(5):
            rec = np.array([[40 + rng.random(), 30 + rng.random(), radius, 1.0, 2.0, 3.0, 4.0,
                             0.25]])
            acc = splat_image(rec, np.full((64, 96), np.inf))
            assert acc[..., 3].sum() == pytest.approx(0.25, rel=tol)
            np.testing.assert_allclose(acc[..., :3].sum(axis=(0, 1)), 0.25 * np.array(
                [2.0, 3.0, 4.0]) * acc[..., 3].sum() / 0.25, rtol=1e-9)

    def test_depth_test(self):
        """A surface nearer than the particle hides it; farther (or open water) does not."""
        dist = np.full((64, 96), np.inf)
        dist[:, :48] = 1.0
        rec = np.array([[47.0, 30.0, 6.0, 2.0, 1.0, 1.0, 1.0, 1.0]])
        acc = splat_image(rec, dist)
        assert np.all(acc[:, :48, 3] == 0)
        assert acc[:, 48:, 3].sum() > 0.3
        acc_near = splat_image(rec * [1, 1, 1, 0.4, 1, 1, 1, 1], dist)
        assert acc_near[:, :48, 3].sum() > 0.3

    def test_composite(self):
        lin = np.full((1, 3, 3), 2.0)
        acc = np.array([[[0, 0, 0, 0], [0.5, 0.5, 0.5, 0.25], [6.0, 6.0, 6.0, 3.0]]], float)
        out = composite(lin, acc)
        np.testing.assert_allclose(out[0, :, 0], [2.0, 2.0 * 0.75 + 0.5, 2.0])


def test_the_scenes_shadow_takes_the_sun_off():
    """A shadow map that occludes everything leaves the diffuse light alone; one
    that occludes nothing leaves the sun's part too."""
    from aquaspec.scene.shadowmap import shadow_map_spec
    t = _tables(lambda mu: np.full_like(mu, 0.25))
    to_sun = np.array([0.0, 0.6, 0.8])
    sun = SimpleNamespace(beam0=np.array([10.0, 20.0]), c_sun=np.array([0.2, 0.4]),
                          to_sun=to_sun, mu0=0.6)
    cam = np.array([0.0, -4.0, 0.0])
    spec = shadow_map_spec(np.array([[-5.0, -9.0, -5.0], [5.0, 0.0, 5.0]]), cam, to_sun,
                           size=64)
    p = np.array([[0.5, -4.5, -2.0], [-1.0, -3.0, -1.0]])
    kw = dict(tables=t, e0=np.ones(2), a=0, b=0, response_weights=np.eye(2, 3), sun=sun)
    open_water = ParticleLight.of(0.5, **kw).radiance(p, cam)
    lit = ParticleLight.of(0.5, **kw, sun_shadow=(np.full((64, 64), -np.inf), spec))
    dark = ParticleLight.of(0.5, **kw, sun_shadow=(np.full((64, 64), np.inf), spec))
    no_sun = ParticleLight.of(0.5, **{**kw, "sun": None}).radiance(p, cam)
    np.testing.assert_allclose(lit.radiance(p, cam), open_water, rtol=1e-12)
    np.testing.assert_allclose(dark.radiance(p, cam), no_sun, rtol=1e-12)
    assert np.all(open_water > 1.5 * no_sun)
