"""Lamps (aquaspec.light.lamp): the beam profile is Mitsuba's spot, power and
intensity agree through the profile's solid angle, spectra are normalised over
400-700 nm, camera-fixed lamps follow the camera, and bad input is refused
with the value named."""

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.light import lamp as L
from aquaspec.light.sky import surface_light
from aquaspec.scene.camera import Camera

#: The trapezoid rule's error on the profile's solid angle (20001 nodes).
SOLID_ANGLE_RTOL = 1e-6


class TestProfile:
    def test_mitsuba_spot_is_linear_in_angle(self):
        lamp = L.Lamp((0, 0, 0), cone_deg=40.0, beam_deg=20.0, power_w=1.0)
        a = np.radians([0.0, 19.9, 20.0, 25.0, 30.0, 35.0, 40.0, 41.0, 120.0])
        np.testing.assert_allclose(lamp.relative_intensity(a),
                                   [1, 1, 1, 0.75, 0.5, 0.25, 0, 0, 0], atol=1e-12)

    def test_default_beam_is_three_quarters_and_180_is_a_point_light(self):
        assert L.Lamp((0, 0, 0), cone_deg=40.0, power_w=1.0).beam_deg == 30.0
        point = L.Lamp((0, 0, 0), cone_deg=180.0, power_w=4 * np.pi)
        assert point.beam_deg == 180.0
        np.testing.assert_allclose(point.solid_angle_sr(), 4 * np.pi, rtol=SOLID_ANGLE_RTOL)
        np.testing.assert_allclose(point.on_axis_w_sr, 1.0, rtol=SOLID_ANGLE_RTOL)

    def test_solid_angle_closed_form(self):
        # Omega = 2 pi [ (1 - cos b) + int_b^g (g - a)/(g - b) sin a da ]
        b, g = np.radians(15.0), np.radians(35.0)
        ramp = (np.cos(b) * (g - b) - (np.sin(g) - np.sin(b))) / (g - b)
        expected = 2 * np.pi * ((1 - np.cos(b)) + ramp)
        lamp = L.Lamp((0, 0, 0), cone_deg=35.0, beam_deg=15.0, power_w=10.0)
        np.testing.assert_allclose(lamp.solid_angle_sr(), expected, rtol=SOLID_ANGLE_RTOL)
        np.testing.assert_allclose(lamp.on_axis_w_sr, 10.0 / expected, rtol=SOLID_ANGLE_RTOL)

    def test_measured_profile(self, tmp_path):
        f = tmp_path / "beam.csv"
        f.write_text("angle_deg,relative\n0,200\n10,100\n20,0\n")
        lamp = L.Lamp((0, 0, 0), profile=L.profile_from_csv(f), intensity_w_sr=3.0)
        assert lamp.cone_deg == 20.0
        np.testing.assert_allclose(lamp.relative_intensity(np.radians([0, 5, 10, 15, 25])),
                                   [1, 0.75, 0.5, 0.25, 0])


class TestSpectra:
    @pytest.mark.parametrize("kind", ["led", "halogen", "metal-halide", "uniform",
                                      "blackbody:5600"])
    def test_normalised_over_400_700(self, kind):
        s = L.lamp_spectrum(kind)
        bands = Bands(30, 400.0, 700.0)
        np.testing.assert_allclose(np.sum(s.on_bands(bands) * bands.weights_nm), 1.0,
                                   rtol=1e-9)

    def test_halogen_is_red_heavy_and_led_has_its_blue_pump(self):
        bands = Bands(30, 400.0, 700.0)
        hal = L.lamp_spectrum("halogen").on_bands(bands)
        led = L.lamp_spectrum("led").on_bands(bands)
        assert hal[-1] > 2 * hal[0]
        # The LED's pump near 450 nm stands above the dip near 480 nm.
        c = bands.centers_nm
        assert led[np.argmin(abs(c - 450))] > 1.3 * led[np.argmin(abs(c - 485))]

    def test_intensity_per_band(self):
        bands = Bands(10, 400.0, 700.0)
        lamp = L.Lamp((0, 0, 0), intensity_w_sr=6.0, spectrum="uniform")
        np.testing.assert_allclose(lamp.intensity_on(bands), 6.0 / 300.0)

    def test_csv_spectrum(self, tmp_path):
        f = tmp_path / "s.csv"
        f.write_text("wavelength_nm,power\n380,1\n720,3\n")
        s = L.lamp_spectrum(str(f))
        np.testing.assert_allclose(s.values[1] / s.values[0], 3.0)

    def test_bad_spectra(self, tmp_path):
        neg = tmp_path / "neg.csv"
        neg.write_text("wavelength_nm,power\n380,1\n500,-1\n720,3\n")
        with pytest.raises(AquaspecError, match="-1 at 500 nm"):
            L.lamp_spectrum(str(neg))
        with pytest.raises(AquaspecError, match="does not exist"):
            L.lamp_spectrum(str(tmp_path / "missing.csv"))
        garbage = tmp_path / "bad.csv"
        garbage.write_bytes(b"\x00\x01binary")
        with pytest.raises(AquaspecError, match="binary"):
            L.lamp_spectrum(str(garbage))
        short = tmp_path / "short.csv"
        short.write_text("wavelength_nm,power\n450,1\n600,3\n")
        with pytest.raises(AquaspecError, match="covering 400-700"):
            L.lamp_spectrum(str(short))
        with pytest.raises(AquaspecError, match="unknown lamp spectrum 'neon'"):
            L.lamp_spectrum("neon")
        with pytest.raises(AquaspecError, match="blackbody:T"):
            L.lamp_spectrum("blackbody:hot")


class TestBadInput:
    def test_lamp_outside_the_water(self):
        with pytest.raises(AquaspecError, match="y = 0.5 m is not under water"):
            L.Lamp((0, 0.5, 0), frame="world", power_w=1.0)
        with pytest.raises(AquaspecError, match="not under water"):
            L.Lamp((0, 0.0, 0), frame="world", power_w=1.0)
        cam = Camera((0, -0.2, 0), (0, 0, -1), (0, 1, 0), 8, 8, 8.0, 8.0, 4.0, 4.0)
        with pytest.raises(AquaspecError, match="on the camera is at y = 0.3 m"):
            L.Lamp((0, 0.5, 0), power_w=1.0).placed(cam)

    @pytest.mark.parametrize("power", [0.0, -3.0, float("nan")])
    def test_power(self, power):
        with pytest.raises(AquaspecError, match="power"):
            L.Lamp((0, 0, 0), power_w=power)

    def test_power_or_intensity(self):
        with pytest.raises(AquaspecError, match="exactly one"):
            L.Lamp((0, 0, 0))
        with pytest.raises(AquaspecError, match="exactly one"):
            L.Lamp((0, 0, 0), power_w=1.0, intensity_w_sr=1.0)

    @pytest.mark.parametrize("cone", [0.0, 181.0, 360.0])
    def test_cone(self, cone):
        with pytest.raises(AquaspecError, match=f"cone {cone!r} degrees"):
            L.Lamp((0, 0, 0), cone_deg=cone, power_w=1.0)

    def test_beam_wider_than_cone_and_zero_direction(self):
        with pytest.raises(AquaspecError, match="beam 50.0 degrees"):
            L.Lamp((0, 0, 0), cone_deg=30.0, beam_deg=50.0, power_w=1.0)
        with pytest.raises(AquaspecError, match="non-zero"):
            L.Lamp((0, 0, 0), direction=(0, 0, 0), power_w=1.0)


class TestPlacement:
    def test_camera_frame(self):
        cam = Camera.look_at((1.0, -5.0, 2.0), (1.0, -5.0, 12.0), width=8, height=8)
        lamp = L.Lamp((0.5, 0.1, 0.0), direction=(0, 0, -1), power_w=1.0).placed(cam)
        # The camera looks along +z: its right is -x, its forward +z.
        np.testing.assert_allclose(lamp.position, [0.5, -4.9, 2.0], atol=1e-12)
        np.testing.assert_allclose(lamp.direction, [0, 0, 1], atol=1e-12)
        assert lamp.frame == "world"


class TestParse:
    def test_spec(self):
        (lamp,) = L.parse_lamp("pos=0.25,0,0;dir=0,-1,-1;cone=30;power=20;spectrum=halogen")
        np.testing.assert_allclose(lamp.direction, [0, -2 ** -0.5, -2 ** -0.5])
        assert (lamp.cone_deg, lamp.power_w, lamp.spectrum.name) == (30.0, 20.0, "halogen")

    def test_preset(self):
        pair = L.parse_lamps(["rov-pair"])
        assert len(pair) == 2
        np.testing.assert_allclose(sorted(p.position[0] for p in pair), [-0.5, 0.5])

    @pytest.mark.parametrize("spec, match", [
        ("sun", "a preset"), ("pos=1,2;power=1", "three numbers"),
        ("pos=0,0,0;power=1;colour=red", "unknown key 'colour'"),
        ("pos=0,0,0;power=x", "power='x'"), ("cone=20;power=1", "no pos"),
        ("pos=0,0,0;power=1;power=2", "given twice"),
        ("pos=0,0,0;power=1;cone=200", "cone 200.0 degrees")])
    def test_bad_specs(self, spec, match):
        with pytest.raises(AquaspecError, match=match):
            L.parse_lamp(spec)


def test_light_none_is_dark():
    light = surface_light("none")
    assert light.on_bands(Bands(8)).max() == 0.0
    assert light.describe()["total_w_m2_400_700"] == 0.0
    with pytest.raises(AquaspecError, match="no daylight"):
        surface_light("none", total_w_m2=10.0)
