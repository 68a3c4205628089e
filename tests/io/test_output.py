"""Tests of image and metadata output (aquaspec.io.output)."""

import json
import os
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from aquaspec.io import output
from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError

F32 = dict(rtol=0, atol=0)   # float32 round trips must be bit exact


def _display(h=12, w=16, dtype=np.uint8, ch=3, seed=0):
    rng = np.random.default_rng(seed)
    top = np.iinfo(dtype).max
    return rng.integers(0, top + 1, size=(h, w, ch) if ch else (h, w), dtype=dtype)


def _linear(h=12, w=16, seed=1):
    rng = np.random.default_rng(seed)
    img = rng.lognormal(-3.0, 2.0, size=(h, w, 3))
    img[0, 0] = [1e-30, 7.5e4, 0.0]          # extremes float32 can still hold
    return img


def _params():
    return {
        "water": "IB", "depth_m": np.float64(5.0), "n_bands": np.int64(16),
        "band_centers_nm": np.linspace(409.375, 690.625, 16),
        "camera": {"sensor": "Canon 5D Mark II", "fov_y_deg": 60.0},
        "exposure": {"mode": "auto", "ev": np.float32(3.25)},
        "tonemap": "filmic", "size": (320, 180), "adapter": None,
        "sun": True,
    }


def _listing(d):
    return sorted(os.listdir(d))


class TestCheckWritable:
    def test_ok_returns_absolute_path_and_leaves_nothing(self, tmp_path):
        p = output.check_writable(tmp_path / "a.png", suffixes=(".png",))
        assert p == (tmp_path / "a.png") and p.is_absolute()
        assert _listing(tmp_path) == []

    def test_missing_directory_named(self, tmp_path):
        missing = tmp_path / "no" / "such"
        with pytest.raises(AquaspecError) as e:
            output.check_writable(missing / "x.png")
        assert str(missing) in str(e.value) and "does not exist" in str(e.value)

    def test_parent_is_a_file(self, tmp_path):
        f = tmp_path / "file"
        f.write_text("x")
        with pytest.raises(AquaspecError, match="not a directory"):
            output.check_writable(f / "x.png")

    def test_path_is_a_directory(self, tmp_path):
        with pytest.raises(AquaspecError, match="is a directory"):
            output.check_writable(tmp_path)

    def test_bad_suffix(self, tmp_path):
        with pytest.raises(AquaspecError, match=r"'\.jpg'.*accepted: \.png"):
            output.check_writable(tmp_path / "x.jpg", suffixes=(".png",))

    @pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0,
                        reason="root can write into a read-only directory")
    def test_read_only_directory(self, tmp_path):
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o500)
        try:
            with pytest.raises(AquaspecError) as e:
                output.check_writable(ro / "x.png")
            assert str(ro) in str(e.value) and "not writable" in str(e.value)
        finally:
            ro.chmod(0o700)

    def test_unwritable_directory_via_failing_create(self, tmp_path, monkeypatch):
        # Works for root too: the probe's creation is refused as the OS would.
        real_open = os.open

        def refuse(path, flags, *a, **k):
            if flags & os.O_CREAT:
                raise PermissionError(13, "Permission denied", str(path))
            return real_open(path, flags, *a, **k)

        monkeypatch.setattr(output.os, "open", refuse)
        with pytest.raises(AquaspecError) as e:
            output.write_png(tmp_path / "x.png", _display())
        assert str(tmp_path) in str(e.value) and "not writable" in str(e.value)


class TestAtomicWrite:
    def test_failing_writer_leaves_no_file(self, tmp_path, monkeypatch):
        from PIL import Image as PILImage

        def half_then_fail(self, fp, *a, **k):
            with open(fp, "wb") as f:
                f.write(b"\x89PNG\r\n\x1a\n partial")
            raise OSError("disk full (simulated)")

        monkeypatch.setattr(PILImage.Image, "save", half_then_fail)
        with pytest.raises(OSError, match="simulated"):
            output.write_png(tmp_path / "x.png", _display())
        assert _listing(tmp_path) == []

    def test_failure_keeps_the_old_file_intact(self, tmp_path, monkeypatch):
        target = tmp_path / "x.png"
        output.write_png(target, _display(seed=1), {"run": 1})
        before = target.read_bytes()

        def fail(*a, **k):
            raise RuntimeError("boom")

        monkeypatch.setattr(output, "_write_png16_rgb", fail)
        with pytest.raises(RuntimeError, match="boom"):
            output.write_png(target, _display(dtype=np.uint16), {"run": 2})
        assert target.read_bytes() == before
        assert _listing(tmp_path) == ["x.png"]

    def test_save_image_all_or_nothing(self, tmp_path, monkeypatch):
        class BrokenExr:
            ZIP_COMPRESSION, scanlineimage = 0, 0

            class File:
                def __init__(self, *a, **k):
                    pass

                def __enter__(self):
                    return self

                def __exit__(self, *a):
                    return False

                def write(self, path):
                    Path(path).write_bytes(b"v/1\x01 partial")
                    raise RuntimeError("EXR writer failed (simulated)")

        monkeypatch.setattr(output, "_openexr", lambda: BrokenExr)
        with pytest.raises(RuntimeError, match="simulated"):
            output.save_image(tmp_path / "r.png", _display(), _linear(), _params(),
                              linear_path=tmp_path / "r.exr")
        assert _listing(tmp_path) == []

    def test_fsync_is_called_before_rename(self, tmp_path, monkeypatch):
        events = []
        real_fsync, real_replace = os.fsync, os.replace
        monkeypatch.setattr(output.os, "fsync", lambda fd: (events.append("fsync"),
                                                            real_fsync(fd))[1])
        monkeypatch.setattr(output.os, "replace", lambda a, b: (events.append("replace"),
                                                                real_replace(a, b))[1])
        output.write_png(tmp_path / "x.png", _display())
        assert events.index("fsync") < events.index("replace")


class TestPng:
    @pytest.mark.parametrize("ch", [3, 4, 0])
    def test_uint8_round_trip_and_metadata(self, tmp_path, ch):
        img = _display(ch=ch)
        p = output.write_png(tmp_path / "x.png", img, _params())
        with Image.open(p) as im:
            np.testing.assert_array_equal(np.asarray(im), img)
        meta = output.read_png_metadata(p)
        assert meta["water"] == "IB" and meta["depth_m"] == 5.0 and meta["n_bands"] == 16
        assert meta["size"] == [320, 180]
        assert meta["aquaspec_version"] and meta["timestamp"]

    def test_metadata_is_a_text_chunk(self, tmp_path):
        p = output.write_png(tmp_path / "x.png", _display(), {"water": "IB"})
        data = p.read_bytes()
        i = data.index(b"tEXt")
        (length,) = struct.unpack(">I", data[i - 4:i])
        key, text = data[i + 4:i + 4 + length].split(b"\0", 1)
        assert key == b"aquaspec" and json.loads(text)["water"] == "IB"

    def test_uint16_grey_round_trip(self, tmp_path):
        img = _display(dtype=np.uint16, ch=0)
        p = output.write_png(tmp_path / "g.png", img, {})
        with Image.open(p) as im:
            np.testing.assert_array_equal(np.asarray(im), img)

    def test_uint16_rgb_is_valid_png(self, tmp_path):
        img = _display(dtype=np.uint16)
        img[0, 0] = [0, 0x1234, 0xFFFF]
        p = output.write_png(tmp_path / "x16.png", img, {"bit_depth": 16})
        assert output.read_png_metadata(p)["bit_depth"] == 16
        # Pillow reads 48-bit PNG as 8-bit RGB from the high bytes; this checks
        # our chunks, CRCs and byte order with an independent decoder.
        with Image.open(p) as im:
            im.load()
            assert im.size == (img.shape[1], img.shape[0])
            np.testing.assert_array_equal(np.asarray(im.convert("RGB")), img >> 8)
        # Full 16-bit check straight from the zlib stream (filter type 0 rows).
        data = p.read_bytes()
        i = data.index(b"IDAT")
        (length,) = struct.unpack(">I", data[i - 4:i])
        raw = np.frombuffer(zlib.decompress(data[i + 4:i + 4 + length]), np.uint8)
        rows = raw.reshape(img.shape[0], -1)
        assert np.all(rows[:, 0] == 0)
        back = rows[:, 1:].copy().view(">u2").reshape(img.shape)
        np.testing.assert_array_equal(back, img)

    @pytest.mark.parametrize("bad,match", [
        (np.zeros((4, 4, 3), np.float32), "uint8 or uint16"),
        (np.zeros((4, 4, 2), np.uint8), "shape"),
        (np.zeros((0, 4, 3), np.uint8), "no pixels"),
    ])
    def test_bad_images(self, tmp_path, bad, match):
        with pytest.raises(AquaspecError, match=match):
            output.write_png(tmp_path / "x.png", bad)
        assert _listing(tmp_path) == []

    def test_wrong_suffix(self, tmp_path):
        with pytest.raises(AquaspecError, match="accepted: .png"):
            output.write_png(tmp_path / "x.jpg", _display())

    def test_nan_metadata_refused_before_writing(self, tmp_path):
        with pytest.raises(AquaspecError, match=r"params\['depth_m'\]"):
            output.write_png(tmp_path / "x.png", _display(), {"depth_m": float("nan")})
        assert _listing(tmp_path) == []

    def test_read_metadata_of_foreign_png(self, tmp_path):
        p = tmp_path / "plain.png"
        Image.fromarray(_display()).save(p)
        with pytest.raises(AquaspecError, match="no 'aquaspec'"):
            output.read_png_metadata(p)


class TestLinear:
    def test_exr_round_trip_float32(self, tmp_path):
        import OpenEXR
        rgb = _linear()
        info = output.write_linear(tmp_path / "x.exr", rgb, _params())
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
        np.testing.assert_array_equal(output.read_linear(tmp_path / "x.exr"), back)

    def test_npy_round_trip(self, tmp_path):
        rgb = _linear()
        info = output.write_linear(tmp_path / "x.npy", rgb)
        assert info["format"] == "npy"
        assert _listing(tmp_path) == ["x.npy"]
        back = np.load(tmp_path / "x.npy")
        assert back.dtype == np.float32
        np.testing.assert_array_equal(back, rgb.astype(np.float32))

    def test_exr_falls_back_to_npy_without_openexr(self, tmp_path, monkeypatch):
        monkeypatch.setattr(output, "_openexr", lambda: None)
        with pytest.warns(UserWarning, match="OpenEXR"):
            info = output.write_linear(tmp_path / "x.exr", _linear())
        assert info["format"] == "npy" and info["path"] == str(tmp_path / "x.npy")
        assert "x.npy" in info["warning"]
        assert _listing(tmp_path) == ["x.npy"]

    @pytest.mark.parametrize("bad", [np.nan, np.inf])
    def test_non_finite_refused(self, tmp_path, bad):
        rgb = _linear()
        rgb[3, 4, 2] = bad
        with pytest.raises(AquaspecError, match="row 3, column 4, channel 2"):
            output.write_linear(tmp_path / "x.exr", rgb)
        assert _listing(tmp_path) == []

    def test_float32_overflow_refused(self, tmp_path):
        rgb = _linear()
        rgb[1, 1, 1] = 1e39
        with pytest.raises(AquaspecError, match="float32"):
            output.write_linear(tmp_path / "x.npy", rgb)

    @pytest.mark.parametrize("name", ["x.tif", "x.png"])
    def test_bad_suffix(self, tmp_path, name):
        with pytest.raises(AquaspecError, match=r"accepted: \.exr, \.npy"):
            output.write_linear(tmp_path / name, _linear())

    def test_bad_shape(self, tmp_path):
        with pytest.raises(AquaspecError, match="shape"):
            output.write_linear(tmp_path / "x.npy", np.zeros((4, 4)))


class TestSidecar:
    def test_round_trip_converts_numpy(self, tmp_path):
        params = _params()
        params["bands"] = Bands(16)
        p = output.write_sidecar(tmp_path / "r.png", params)
        assert p == tmp_path / "r.png.json"
        doc = json.loads(p.read_text())
        assert doc == output.read_sidecar(tmp_path / "r.png")
        assert doc["depth_m"] == 5.0 and isinstance(doc["n_bands"], int)
        assert doc["exposure"] == {"mode": "auto", "ev": 3.25}
        np.testing.assert_allclose(doc["band_centers_nm"], params["band_centers_nm"], rtol=0)
        assert doc["bands"] == {"n": 16, "lo_nm": 400.0, "hi_nm": 700.0}
        assert doc["sun"] is True and doc["adapter"] is None
        assert doc["aquaspec_version"] == output.aquaspec_version()
        assert doc["timestamp"].endswith("+00:00")

    def test_given_version_and_timestamp_are_kept(self, tmp_path):
        p = output.write_sidecar(tmp_path / "r.png", {"timestamp": "2024-01-01T00:00:00+00:00",
                                                      "aquaspec_version": "9.9"})
        doc = json.loads(p.read_text())
        assert doc["timestamp"].startswith("2024") and doc["aquaspec_version"] == "9.9"

    @pytest.mark.parametrize("where,value", [
        ("depth_m", np.float64("nan")),
        ("camera", {"fov_y_deg": float("inf")}),
        ("band_centers_nm", np.array([400.0, np.nan])),
    ])
    def test_nan_refused_with_key(self, tmp_path, where, value):
        params = _params()
        params[where] = value
        with pytest.raises(AquaspecError) as e:
            output.write_sidecar(tmp_path / "r.png", params)
        assert where in str(e.value) and "NaN" in str(e.value)
        assert _listing(tmp_path) == []

    def test_unsupported_type(self, tmp_path):
        with pytest.raises(AquaspecError, match=r"params\['obj'\].*object"):
            output.write_sidecar(tmp_path / "r.png", {"obj": object()})


class TestSaveImage:
    def test_png_sidecar_and_exr(self, tmp_path):
        disp, lin = _display(), _linear()
        res = output.save_image(tmp_path / "r.png", disp, lin, _params(),
                                linear_path=tmp_path / "r.exr")
        assert _listing(tmp_path) == ["r.exr", "r.png", "r.png.json"]
        assert res["linear_format"] == "exr" and res["warnings"] == []
        side = output.read_sidecar(tmp_path / "r.png")
        assert side == output.read_png_metadata(tmp_path / "r.png")
        assert side["files"] == {"png": "r.png", "sidecar": "r.png.json", "linear": "r.exr"}
        np.testing.assert_array_equal(output.read_linear(tmp_path / "r.exr"),
                                      lin.astype(np.float32))
        with Image.open(tmp_path / "r.png") as im:
            np.testing.assert_array_equal(np.asarray(im), disp)

    def test_png_only(self, tmp_path):
        res = output.save_image(tmp_path / "r.png", _display(), None, {"water": "II"})
        assert _listing(tmp_path) == ["r.png", "r.png.json"]
        assert res["linear"] is None
        assert output.read_sidecar(tmp_path / "r.png")["files"]["linear"] is None

    def test_fallback_recorded_in_sidecar(self, tmp_path, monkeypatch):
        monkeypatch.setattr(output, "_openexr", lambda: None)
        with pytest.warns(UserWarning):
            res = output.save_image(tmp_path / "r.png", _display(), _linear(), {},
                                    linear_path=tmp_path / "r.exr")
        assert _listing(tmp_path) == ["r.npy", "r.png", "r.png.json"]
        side = output.read_sidecar(tmp_path / "r.png")
        assert side["files"]["linear"] == "r.npy" and side["warnings"] == res["warnings"]

    def test_bad_linear_refused_before_any_file(self, tmp_path):
        lin = _linear()
        lin[0, 1, 0] = np.nan
        with pytest.raises(AquaspecError, match="non-finite"):
            output.save_image(tmp_path / "r.png", _display(), lin, {},
                              linear_path=tmp_path / "r.exr")
        assert _listing(tmp_path) == []

    def test_linear_path_without_pixels(self, tmp_path):
        with pytest.raises(AquaspecError, match="without linear_rgb"):
            output.save_image(tmp_path / "r.png", _display(), None, {},
                              linear_path=tmp_path / "r.exr")
