"""Atomic writes (aquaspec.io.atomic): a bad destination is named before any work,
and a failed write leaves no file behind and an old file intact."""

import os
from pathlib import Path

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.io import atomic, exr, png, save
from support.output_data import display_image, linear_image, render_params, listing


class TestCheckWritable:
    def test_ok_returns_absolute_path_and_leaves_nothing(self, tmp_path):
        p = atomic.check_writable(tmp_path / "a.png", suffixes=(".png",))
        assert p == (tmp_path / "a.png") and p.is_absolute()
        assert listing(tmp_path) == []

    def test_missing_directory_named(self, tmp_path):
        missing = tmp_path / "no" / "such"
        with pytest.raises(AquaspecError) as e:
            atomic.check_writable(missing / "x.png")
        assert str(missing) in str(e.value) and "does not exist" in str(e.value)

    def test_parent_is_a_file(self, tmp_path):
        f = tmp_path / "file"
        f.write_text("x")
        with pytest.raises(AquaspecError, match="not a directory"):
            atomic.check_writable(f / "x.png")

    def test_path_is_a_directory(self, tmp_path):
        with pytest.raises(AquaspecError, match="is a directory"):
            atomic.check_writable(tmp_path)

    def test_bad_suffix(self, tmp_path):
        with pytest.raises(AquaspecError, match=r"'\.jpg'.*accepted: \.png"):
            atomic.check_writable(tmp_path / "x.jpg", suffixes=(".png",))

    @pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0,
                        reason="root can write into a read-only directory")
    def test_read_only_directory(self, tmp_path):
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o500)
        try:
            with pytest.raises(AquaspecError) as e:
                atomic.check_writable(ro / "x.png")
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

        monkeypatch.setattr(atomic.os, "open", refuse)
        with pytest.raises(AquaspecError) as e:
            png.write_png(tmp_path / "x.png", display_image())
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
            png.write_png(tmp_path / "x.png", display_image())
        assert listing(tmp_path) == []

    def test_failure_keeps_the_old_file_intact(self, tmp_path, monkeypatch):
        target = tmp_path / "x.png"
        png.write_png(target, display_image(seed=1), {"run": 1})
        before = target.read_bytes()

        def fail(*a, **k):
            raise RuntimeError("boom")

        monkeypatch.setattr(png, "_write_png16_rgb", fail)
        with pytest.raises(RuntimeError, match="boom"):
            png.write_png(target, display_image(dtype=np.uint16), {"run": 2})
        assert target.read_bytes() == before
        assert listing(tmp_path) == ["x.png"]

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

        monkeypatch.setattr(exr, "openexr", lambda: BrokenExr)
        with pytest.raises(RuntimeError, match="simulated"):
            save.save_image(tmp_path / "r.png", display_image(), linear_image(), render_params(),
                              linear_path=tmp_path / "r.exr")
        assert listing(tmp_path) == []

    def test_fsync_is_called_before_rename(self, tmp_path, monkeypatch):
        events = []
        real_fsync, real_replace = os.fsync, os.replace
        monkeypatch.setattr(atomic.os, "fsync", lambda fd: (events.append("fsync"),
                                                            real_fsync(fd))[1])
        monkeypatch.setattr(atomic.os, "replace", lambda a, b: (events.append("replace"),
                                                                real_replace(a, b))[1])
        png.write_png(tmp_path / "x.png", display_image())
        assert events.index("fsync") < events.index("replace")
