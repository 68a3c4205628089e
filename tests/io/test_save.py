"""A render's files written as one set, all or none (aquaspec.io.save)."""

import numpy as np
import pytest
from PIL import Image

from aquaspec.errors import AquaspecError
from aquaspec.io import exr, linear, png, save, sidecar
from support.output_data import display_image, linear_image, render_params, listing


class TestSaveImage:
    def test_png_sidecar_and_exr(self, tmp_path):
        disp, lin = display_image(), linear_image()
        res = save.save_image(tmp_path / "r.png", disp, lin, render_params(),
                                linear_path=tmp_path / "r.exr")
        assert listing(tmp_path) == ["r.exr", "r.png", "r.png.json"]
        assert res["linear_format"] == "exr" and res["warnings"] == []
        side = sidecar.read_sidecar(tmp_path / "r.png")
        assert side == png.read_png_metadata(tmp_path / "r.png")
        assert side["files"] == {"png": "r.png", "sidecar": "r.png.json", "linear": "r.exr"}
        np.testing.assert_array_equal(linear.read_linear(tmp_path / "r.exr"),
                                      lin.astype(np.float32))
        with Image.open(tmp_path / "r.png") as im:
            np.testing.assert_array_equal(np.asarray(im), disp)

    def test_png_only(self, tmp_path):
        res = save.save_image(tmp_path / "r.png", display_image(), None, {"water": "II"})
        assert listing(tmp_path) == ["r.png", "r.png.json"]
        assert res["linear"] is None
        assert sidecar.read_sidecar(tmp_path / "r.png")["files"]["linear"] is None

    def test_fallback_recorded_in_sidecar(self, tmp_path, monkeypatch):
        monkeypatch.setattr(exr, "openexr", lambda: None)
        with pytest.warns(UserWarning):
            res = save.save_image(tmp_path / "r.png", display_image(), linear_image(), {},
                                    linear_path=tmp_path / "r.exr")
        assert listing(tmp_path) == ["r.npy", "r.png", "r.png.json"]
        side = sidecar.read_sidecar(tmp_path / "r.png")
        assert side["files"]["linear"] == "r.npy" and side["warnings"] == res["warnings"]

    def test_bad_linear_refused_before_any_file(self, tmp_path):
        lin = linear_image()
        lin[0, 1, 0] = np.nan
        with pytest.raises(AquaspecError, match="non-finite"):
            save.save_image(tmp_path / "r.png", display_image(), lin, {},
                              linear_path=tmp_path / "r.exr")
        assert listing(tmp_path) == []

    def test_linear_path_without_pixels(self, tmp_path):
        with pytest.raises(AquaspecError, match="without linear_rgb"):
            save.save_image(tmp_path / "r.png", display_image(), None, {},
                              linear_path=tmp_path / "r.exr")
