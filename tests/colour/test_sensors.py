"""Sensors: built-ins, camspec and CSV loaders, band weights."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError, DataRangeError
from aquaspec.colour.sensors import (Sensor, builtin_sensors, get_sensor, human_sensor,
                                    load_camspec, sensor_from_csv)


class TestBuiltin:
    def test_names(self):
        assert set(builtin_sensors()) == {"human", "nikon-5100-npl", "sigma-sdmerill-npl"}

    def test_human_d65_is_srgb_white(self):
        # D65 seen by CIE 1931 -> sRGB over the observer's whole range is the
        # sRGB white point: equal channels.
        import colour
        b = Bands(470, 360, 830)
        d65 = colour.SDS_ILLUMINANTS["D65"]
        e = b.average(d65.wavelengths, d65.values, outside="zero")
        rgb = e @ human_sensor().band_weights(b)
        np.testing.assert_allclose(rgb / rgb.mean(), 1.0, atol=2e-3)

    def test_band_weights_converge(self):
        s = get_sensor("nikon-5100-npl")
        ref = s.band_weights(Bands(300)).sum(axis=0)
        for n in (8, 32):
            np.testing.assert_allclose(s.band_weights(Bands(n)).sum(axis=0), ref, rtol=1e-9)

    def test_outside_range(self):
        s = get_sensor("sigma-sdmerill-npl")   # 400-680 nm
        with pytest.raises(DataRangeError, match="400-680 nm.*400-700"):
            s.band_weights(Bands(8))
        w = s.band_weights(Bands(8), outside="zero")
        assert np.all(np.isfinite(w)) and w[-1].sum() < w[-2].sum()

    def test_unknown(self):
        with pytest.raises(AquaspecError, match="unknown sensor 'canon'.*human.*--camspec"):
            get_sensor("canon")


class TestCamspec:
    def test_28_cameras(self, camspec_path):
        cams = load_camspec(camspec_path)
        assert len(cams) == 28
        for s in cams.values():
            assert s.range_nm == (400.0, 720.0) and s.response.shape == (3, 33)
            np.testing.assert_allclose(s.response.max(), 1.0, atol=1e-3)

    def test_lookup_by_loose_name(self, camspec_path):
        s = get_sensor("canon 5d mark ii", camspec_path)
        assert s.name == "Canon 5DMarkII"

    def test_wrong_format(self, tmp_path):
        p = tmp_path / "cams.txt"
        p.write_text("just some text\nwith no numbers\n")
        with pytest.raises(AquaspecError, match="no cameras found.*camspec format"):
            load_camspec(p)

    def test_truncated_in_a_camera(self, tmp_path):
        # Item 4: the file ends after the name and one response line of the
        # last camera; that camera was dropped without a word.
        row = " ".join(["0.5"] * 33)
        p = tmp_path / "cams.txt"
        p.write_text(f"400nm-720nm, step 10nm\n\nCamA\n{row}\n{row}\n{row}\nCamB\n{row}\n")
        with pytest.raises(AquaspecError, match=r"camera 'CamB' \(line 7\) has 1 of its 3 "
                                                r"response lines \(R, G, B\) before the end of "
                                                "the file; is the file truncated"):
            load_camspec(p)

    def test_camera_cut_short_before_the_next(self, tmp_path):
        row = " ".join(["0.5"] * 33)
        p = tmp_path / "cams.txt"
        p.write_text(f"CamA\n{row}\n{row}\nCamB\n{row}\n{row}\n{row}\n")
        with pytest.raises(AquaspecError, match=r"camera 'CamA' \(line 1\) has 2 of its 3 "
                                                r"response lines \(R, G, B\) before line 4"):
            load_camspec(p)

    def test_real_file_loads_whole(self, camspec_path, tmp_path):
        # Cut the real database inside its last camera: refused, not 27 cameras.
        lines = camspec_path.read_text().splitlines()
        p = tmp_path / "cut.txt"
        p.write_text("\n".join(lines[:-2]) + "\n")
        with pytest.raises(AquaspecError, match="has 1 of its 3 response lines"):
            load_camspec(p)

    def test_wrong_count(self, tmp_path):
        p = tmp_path / "cams.txt"
        p.write_text("400nm-720nm, step 10nm\nCam\n1 2 3\n1 2 3\n1 2 3\n")
        with pytest.raises(AquaspecError, match="3 values, expected 33"):
            load_camspec(p)


class TestCsv:
    def test_good_and_bad(self, tmp_path):
        p = tmp_path / "cam.csv"
        p.write_text("wavelength_nm,r,g,b\n400,0,0,1\n550,0,1,0\n700,1,0,0\n")
        s = sensor_from_csv(p)
        assert s.name == "cam" and s.response.shape == (3, 3)
        q = tmp_path / "bad.csv"
        q.write_text("wavelength_nm,r,g\n400,0,0\n700,1,0\n")
        with pytest.raises(AquaspecError, match="missing column.*b"):
            get_sensor(str(q))


class TestZeroChannels:
    """Item 12: an all-zero sensor is refused at load, naming it and the channels."""

    def test_all_zero_csv(self, tmp_path):
        p = tmp_path / "dead.csv"
        p.write_text("wavelength_nm,r,g,b\n400,0,0,0\n700,0,0,0\n")
        with pytest.raises(AquaspecError, match=r"sensor 'dead' \(csv:.*dead\.csv\): channel\(s\) "
                                                "r, g, b are zero at every wavelength"):
            get_sensor(str(p))

    def test_one_dead_channel(self):
        with pytest.raises(AquaspecError, match=r"sensor 'x': channel\(s\) g are zero"):
            Sensor("x", [400, 700], [[1, 1], [0, 0], [0, 1]])

    def test_blind_where_the_matrix_is_fitted(self):
        # Responds, but only beyond 700 nm: the colour matrix cannot be fitted.
        s = Sensor("ir", [400, 700, 710, 800], [[0, 0, 1, 1], [0, 0, 1, 1], [0, 0, 1, 1]])
        with pytest.raises(AquaspecError, match=r"sensor 'ir': channel\(s\) r, g, b see nothing "
                                                "over 400-700 nm.*--colour-matrix none"):
            s.srgb_matrix()


class TestSrgbMatrix:
    def test_human_is_identity(self):
        np.testing.assert_array_equal(get_sensor("human").srgb_matrix(), np.eye(3))

    def test_camera_matrix_reproduces_colorchecker(self):
        # After the fit, the camera sees the chart about as the CIE observer
        # does: far closer than raw camera RGB read as sRGB.
        import colour
        from aquaspec.colour.reflectance import colorchecker
        s = get_sensor("nikon-5100-npl")
        b = Bands(60)
        d65 = colour.SDS_ILLUMINANTS["D65"]
        e = b.average(d65.wavelengths, d65.values)
        refl = np.stack([r.on_bands(b) for r in colorchecker()])
        cam = (refl * e) @ s.band_weights(b)
        ref = (refl * e) @ human_sensor().band_weights(b)
        raw = cam * ref[18].mean() / cam[18].mean()
        fitted = cam @ s.srgb_matrix().T
        err_fit = np.linalg.norm(fitted - ref, axis=1).mean()
        err_raw = np.linalg.norm(raw - ref, axis=1).mean()
        assert err_fit < 0.25 * err_raw
        assert np.linalg.norm(fitted[18] - ref[18]) < 0.05 * ref[18].mean()


def test_radiance_to_rgb():
    from aquaspec.colour.sensors import radiance_to_rgb
    w = np.array([[1.0, 0, 0], [0, 2.0, 0], [0, 0, 3.0], [1.0, 1.0, 1.0]])
    np.testing.assert_allclose(radiance_to_rgb([1.0, 1.0, 1.0, 2.0], w), [3, 4, 5])
