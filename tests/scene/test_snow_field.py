"""Marine snow's particle set (aquaspec.scene.particles): count, seeding, sizes, drift, errors."""

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.scene.particles import (MAX_PARTICLES, MarineSnow, SnowField, parse_marine_snow,
                                      power_law_diameters)


class TestMarineSnow:
    def test_count_is_density_times_cube(self):
        snow = MarineSnow(100.0, range_m=1.5)
        assert snow.count == round(100.0 * 27.0)
        assert len(SnowField(snow).origin) == snow.count

    @pytest.mark.parametrize("kw, named", [
        ({"density_per_m3": -3.0}, "density_per_m3=-3.0"),
        ({"density_per_m3": 0.0}, "density_per_m3=0.0"),
        ({"density_per_m3": float("nan")}, "density_per_m3=nan"),
        ({"density_per_m3": 10.0, "seed": -1}, "seed=-1"),
        ({"density_per_m3": 10.0, "seed": 1.5}, "seed=1.5"),
        ({"density_per_m3": 10.0, "albedo": 1.2}, "albedo=1.2"),
        ({"density_per_m3": 10.0, "d_min_mm": 2.0, "d_max_mm": 1.0}, "d_max_mm=1.0"),
        ({"density_per_m3": 10.0, "blur_px": 0.5}, "blur_px=0.5"),
        ({"density_per_m3": 10.0, "current_m_s": (1.0, 2.0)}, "current_m_s"),
        ({"density_per_m3": 1e5, "range_m": 10.0}, f"at most {MAX_PARTICLES}"),
    ])
    def test_bad_input_is_named(self, kw, named):
        with pytest.raises(AquaspecError, match="accepted") as exc:
            MarineSnow(**kw)
        assert named in str(exc.value)


class TestParse:
    def test_forms(self):
        assert parse_marine_snow(None) is None
        assert parse_marine_snow(250) == MarineSnow(250.0)
        snow = parse_marine_snow("250,7,albedo=0.3,range=2,current=0.1:0:-0.2,dmax=3")
        assert snow == MarineSnow(250.0, seed=7, albedo=0.3, range_m=2.0,
                                  current_m_s=(0.1, 0.0, -0.2), d_max_mm=3.0)

    @pytest.mark.parametrize("spec, named", [
        ("-5", "density_per_m3=-5.0"), ("5,x", "'5,x'"), ("5,1,foo=2", "key 'foo'"),
        ("", "''"), ("5,1,current=1:2", "current_m_s")])
    def test_bad_specs(self, spec, named):
        with pytest.raises(AquaspecError, match="accepted") as exc:
            parse_marine_snow(spec)
        assert named in str(exc.value)


class TestDiameters:
    def test_power_law_cdf(self):
        """The drawn sizes follow N(<D) of n(D) ~ D^-3 on [0.5, 5] mm (KS distance)."""
        d = np.sort(power_law_diameters(np.random.default_rng(1).random(20000), 0.5, 5.0, 3.0))
        cdf = (0.5 ** -2 - d ** -2) / (0.5 ** -2 - 5.0 ** -2)
        ks = np.max(np.abs(cdf - (np.arange(d.size) + 0.5) / d.size))
        assert ks < 0.015
        assert d.min() >= 0.5 and d.max() <= 5.0

    def test_slope_one_and_fixed_size(self):
        u = np.array([0.0, 0.5, 1.0])
        np.testing.assert_allclose(power_law_diameters(u, 1.0, 4.0, 1.0), [1.0, 2.0, 4.0])
        np.testing.assert_allclose(power_law_diameters(u, 2.0, 2.0, 3.0), 2.0)


class TestField:
    def test_seeded(self):
        a, b = SnowField(MarineSnow(20.0, seed=3)), SnowField(MarineSnow(20.0, seed=3))
        np.testing.assert_array_equal(a.origin, b.origin)
        c = SnowField(MarineSnow(20.0, seed=4))
        assert not np.allclose(a.origin, c.origin)

    def test_around_the_camera_and_under_water(self):
        snow = MarineSnow(50.0, range_m=2.0)
        cam = np.array([0.3, -1.0, 7.0])
        pos, diam = SnowField(snow).at(cam, 12.5)
        assert np.all(np.abs(pos - cam) <= 2.0 + 1e-9)
        assert np.all(pos[:, 1] < 0.0)
        # About half the cube (y from -3 to 1) is under the surface.
        assert 0.7 * snow.count < len(pos) < 0.8 * snow.count
        assert len(diam) == len(pos)

    def test_drifts_with_the_current(self):
        """Away from the cube's faces, a particle moves by v t."""
        v = (0.1, -0.05, 0.2)
        field = SnowField(MarineSnow(20.0, range_m=2.0, current_m_s=v))
        cam = np.array([0.0, -5.0, 0.0])
        p0, _ = field.at(cam, 0.0)
        p1, _ = field.at(cam, 2.0)
        step = p1 - p0
        inside = np.all(np.abs(p0 - cam) < 1.5, axis=1)
        assert inside.sum() > 50
        np.testing.assert_allclose(step[inside], np.broadcast_to(np.multiply(v, 2.0),
                                                                 step[inside].shape), atol=1e-9)


def test_the_cells_in_view_hold_every_particle_in_view():
    """at(camera=) returns fewer particles, but every one a cull to the view keeps."""
    from aquaspec.scene.camera import Camera
    from aquaspec.shading.particles import in_view
    cam = Camera.look_at([0.3, -5.0, 0.2], [1.0, -5.5, -1.0], width=320, height=180)
    field = SnowField(MarineSnow(60.0, seed=2, range_m=3.3, current_m_s=(0.3, -0.1, 0.2)))
    for t in (0.0, 7.3, 55.0):
        every, _ = field.at(cam.position, t)
        cells, _ = field.at(cam.position, t, camera=cam, margin_px=20.0)
        assert len(cells) < 0.6 * len(every)
        seen = {tuple(p) for p in np.round(every[in_view(every, cam, 20.0)], 9)}
        assert seen and seen == {tuple(p) for p in np.round(cells[in_view(cells, cam, 20.0)], 9)}
