"""Linear images as float32 EXR or NPY (aquaspec.io.linear)."""

import json

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.io import exr, linear
from support.output_data import linear_image, render_params, listing


class TestLinear:
    def test_exr_round_trip_float32(self, tmp_path):
        import OpenEXR
        rgb = linear_image()
        info = linear.write_linear(tmp_path / "x.exr", rgb, render_params())
        assert info["format"] == "exr" and info["warning"] is None
        with OpenEXR.File(str(tmp_path / "x.exr"), separate_channels=True) as f:
            ch = f.channels()
            assert sorted(ch) == ["B", "G", "R"]
            back = np.stack([ch[c].pixels for c in "RGB"], axis=-1)
            meta = json.loads(f.header()["aquaspec"])
        assert back.dtype == np.float32
        np.testing.assert_allclose(back, rgb, rtol=np.finfo(np.float32).eps, atol=0)
        np.testing.assert_array_equal(back, rgb.astype(np.float32))
        assert meta["water"] == "IB" and len(meta["band_centers_nm"]) == 16
        np.testing.assert_array_equal(linear.read_linear(tmp_path / "x.exr"), back)

    def test_npy_round_trip(self, tmp_path):
        rgb = linear_image()
        info = linear.write_linear(tmp_path / "x.npy", rgb)
        assert info["format"] == "npy"
        assert listing(tmp_path) == ["x.npy"]
        back = np.load(tmp_path / "x.npy")
        assert back.dtype == np.float32
        np.testing.assert_array_equal(back, rgb.astype(np.float32))

    def test_exr_falls_back_to_npy_without_openexr(self, tmp_path, monkeypatch):
        monkeypatch.setattr(exr, "openexr", lambda: None)
        with pytest.warns(UserWarning, match="OpenEXR"):
            info = linear.write_linear(tmp_path / "x.exr", linear_image())
        assert info["format"] == "npy" and info["path"] == str(tmp_path / "x.npy")
        assert "x.npy" in info["warning"]
        assert listing(tmp_path) == ["x.npy"]

    @pytest.mark.parametrize("bad", [np.nan, np.inf])
    def test_non_finite_refused(self, tmp_path, bad):
        rgb = linear_image()
        rgb[3, 4, 2] = bad
        with pytest.raises(AquaspecError, match="row 3, column 4, channel 2"):
            linear.write_linear(tmp_path / "x.exr", rgb)
        assert listing(tmp_path) == []

    def test_float32_overflow_refused(self, tmp_path):
        rgb = linear_image()
        rgb[1, 1, 1] = 1e39
        with pytest.raises(AquaspecError, match="float32"):
            linear.write_linear(tmp_path / "x.npy", rgb)

    @pytest.mark.parametrize("name", ["x.tif", "x.png"])
    def test_bad_suffix(self, tmp_path, name):
        with pytest.raises(AquaspecError, match=r"accepted: \.exr, \.npy"):
            linear.write_linear(tmp_path / name, linear_image())

    def test_bad_shape(self, tmp_path):
        with pytest.raises(AquaspecError, match="shape"):
            linear.write_linear(tmp_path / "x.npy", np.zeros((4, 4)))
