"""PNG files with the parameters in a tEXt chunk (aquaspec.io.png)."""

import json
import struct
import zlib

import numpy as np
import pytest
from PIL import Image

from aquaspec.errors import AquaspecError
from aquaspec.io import png
from support.output_data import display_image, render_params, listing


class TestPng:
    @pytest.mark.parametrize("ch", [3, 4, 0])
    def test_uint8_round_trip_and_metadata(self, tmp_path, ch):
        img = display_image(ch=ch)
        p = png.write_png(tmp_path / "x.png", img, render_params())
        with Image.open(p) as im:
            np.testing.assert_array_equal(np.asarray(im), img)
        meta = png.read_png_metadata(p)
        assert meta["water"] == "IB" and meta["depth_m"] == 5.0 and meta["n_bands"] == 16
        assert meta["size"] == [320, 180]
        assert meta["aquaspec_version"] and meta["timestamp"]

    def test_metadata_is_a_text_chunk(self, tmp_path):
        p = png.write_png(tmp_path / "x.png", display_image(), {"water": "IB"})
        data = p.read_bytes()
        i = data.index(b"tEXt")
        (length,) = struct.unpack(">I", data[i - 4:i])
        key, text = data[i + 4:i + 4 + length].split(b"\0", 1)
        assert key == b"aquaspec" and json.loads(text)["water"] == "IB"

    def test_uint16_grey_round_trip(self, tmp_path):
        img = display_image(dtype=np.uint16, ch=0)
        p = png.write_png(tmp_path / "g.png", img, {})
        with Image.open(p) as im:
            np.testing.assert_array_equal(np.asarray(im), img)

    def test_uint16_rgb_is_valid_png(self, tmp_path):
        img = display_image(dtype=np.uint16)
        img[0, 0] = [0, 0x1234, 0xFFFF]
        p = png.write_png(tmp_path / "x16.png", img, {"bit_depth": 16})
        assert png.read_png_metadata(p)["bit_depth"] == 16
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
            png.write_png(tmp_path / "x.png", bad)
        assert listing(tmp_path) == []

    def test_wrong_suffix(self, tmp_path):
        with pytest.raises(AquaspecError, match="accepted: .png"):
            png.write_png(tmp_path / "x.jpg", display_image())

    def test_nan_metadata_refused_before_writing(self, tmp_path):
        with pytest.raises(AquaspecError, match=r"params\['depth_m'\]"):
            png.write_png(tmp_path / "x.png", display_image(), {"depth_m": float("nan")})
        assert listing(tmp_path) == []

    def test_read_metadata_of_foreign_png(self, tmp_path):
        p = tmp_path / "plain.png"
        Image.fromarray(display_image()).save(p)
        with pytest.raises(AquaspecError, match="no 'aquaspec'"):
            png.read_png_metadata(p)
