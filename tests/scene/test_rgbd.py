"""RGB-D images -> G-buffer: geometry against closed forms, and bad input."""

import numpy as np
import pytest
from PIL import Image

from aquaspec.errors import AquaspecError
from aquaspec.scene.gbuffer import PER_PIXEL
from aquaspec.scene.rgbd import gbuffer_from_rgbd, load_rgbd

W, H = 40, 30
INTR = (35.0, 33.0, 19.0, 16.0)
CAM_DEPTH = 5.0
NORMAL_TOL = 1e-9
DIST_RTOL = 1e-9


def unit_rays():
    """Pixel-centre rays from the intrinsics (camera looking along -z, level)."""
    fx, fy, cx, cy = INTR
    j, i = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    d = np.stack([(j - cx) / fx, -(i - cy) / fy, -np.ones_like(j)], -1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def plane_depth(normal, point):
    """Z-depth and ray distance of the plane through ``point`` with ``normal``."""
    o = np.array([0.0, -CAM_DEPTH, 0.0])
    d = unit_rays()
    t = (np.asarray(point) - o) @ normal / (d @ normal)
    return t * -d[..., 2], t


def grey(value=0.5):
    return np.full((H, W, 3), value)


class TestGbufferFromRgbd:
    def test_tilted_plane(self):
        n = np.array([0.3, 0.5, 1.0])
        n /= np.linalg.norm(n)
        z, t = plane_depth(n, (0.2, -CAM_DEPTH - 0.3, -4.0))
        g = gbuffer_from_rgbd(grey(), z, INTR, camera_depth_m=CAM_DEPTH, rgb_is_srgb=False)
        np.testing.assert_allclose(g.distance, t, rtol=1e-6)   # stored as float32
        np.testing.assert_allclose(g.normal.reshape(-1, 3), np.tile(n, (W * H, 1)),
                                   atol=1e-6)
        np.testing.assert_allclose(g.camera.position, [0, -CAM_DEPTH, 0])
        assert np.all(g.material == PER_PIXEL)

    def test_plane_seen_from_the_back_side_still_faces_camera(self):
        n = np.array([0.0, -0.4, -1.0])       # points away from the camera
        n /= np.linalg.norm(n)
        z, _ = plane_depth(n, (0.0, -CAM_DEPTH, -3.0))
        g = gbuffer_from_rgbd(grey(), z, INTR, camera_depth_m=CAM_DEPTH)
        np.testing.assert_allclose(g.normal.reshape(-1, 3), np.tile(-n, (W * H, 1)), atol=1e-6)

    def test_depth_step_keeps_normals_of_each_surface(self):
        z = np.full((H, W), 6.0)
        z[10:20, 12:25] = 2.0                  # a fronto-parallel square in front
        g = gbuffer_from_rgbd(grey(), z, INTR, camera_depth_m=CAM_DEPTH)
        # Every pixel, including those on the step, sees a plane facing +z.
        np.testing.assert_allclose(g.normal.reshape(-1, 3), np.tile([0, 0, 1.0], (W * H, 1)),
                                   atol=1e-6)

    def test_grey_photo_gives_flat_half_reflectance(self):
        from aquaspec.colour.reflectance import sigmoid_spectrum
        srgb_half = np.full((H, W, 3), 188, dtype=np.uint8)   # sRGB 188/255 ~ linear 0.50
        g = gbuffer_from_rgbd(srgb_half, np.full((H, W), 3.0), INTR, camera_depth_m=1.0)
        r = sigmoid_spectrum(g.sigmoid[0, 0], np.linspace(400, 700, 7))
        np.testing.assert_allclose(r, 0.5029, atol=0.01)
        assert np.all(g.sigmoid == g.sigmoid[0, 0])

    def test_other_forward(self):
        z = np.full((H, W), 2.0)
        g = gbuffer_from_rgbd(grey(), z, INTR, camera_depth_m=3.0, forward=(1, 0, 0))
        centre_like = g.positions()[..., 0]
        np.testing.assert_allclose(centre_like, 2.0, rtol=1e-6)   # plane x = 2
        np.testing.assert_allclose(g.normal[..., 0], -1.0, atol=1e-6)


class TestBadInput:
    def z(self):
        return np.full((H, W), 2.0)

    def test_size_mismatch(self):
        with pytest.raises(AquaspecError, match="same size"):
            gbuffer_from_rgbd(grey(), np.ones((H, W + 1)), INTR, camera_depth_m=1)

    @pytest.mark.parametrize("value,kind", [(np.nan, "1 NaN"), (0.0, "1 zero or negative"),
                                            (-2.0, "1 zero or negative"),
                                            (np.inf, "1 infinite")])
    def test_invalid_depth_names_count_and_position(self, value, kind):
        z = self.z()
        z[7, 3] = value
        z[9, 1] = value
        with pytest.raises(AquaspecError, match=r"2 invalid pixels") as e:
            gbuffer_from_rgbd(grey(), z, INTR, camera_depth_m=1)
        assert "row 7, column 3" in str(e.value)
        assert kind.replace("1", "2") in str(e.value)

    @pytest.mark.parametrize("intr", [(35.0, 33.0, 19.0), (0.0, 33.0, 19.0, 16.0),
                                      (35.0, -1.0, 19.0, 16.0), (35.0, 33.0, np.nan, 16.0),
                                      "abcd", None])
    def test_bad_intrinsics(self, intr):
        with pytest.raises(AquaspecError, match="intrinsics"):
            gbuffer_from_rgbd(grey(), self.z(), intr, camera_depth_m=1)

    @pytest.mark.parametrize("d", [-0.5, np.nan, np.inf])
    def test_bad_camera_depth(self, d):
        with pytest.raises(AquaspecError, match="camera_depth_m"):
            gbuffer_from_rgbd(grey(), self.z(), INTR, camera_depth_m=d)

    def test_float_rgb_out_of_range(self):
        with pytest.raises(AquaspecError, match=r"outside \[0, 1\]"):
            gbuffer_from_rgbd(grey(1.5), self.z(), INTR, camera_depth_m=1)


class TestLoadRgbd:
    def write_rgb(self, tmp_path):
        rgb = (np.arange(H * W * 3) % 251).astype(np.uint8).reshape(H, W, 3)
        p = tmp_path / "rgb.png"
        Image.fromarray(rgb).save(p)
        return rgb, p

    def test_png16_millimetres(self, tmp_path):
        rgb, p = self.write_rgb(tmp_path)
        mm = (1000 + np.arange(H * W)).reshape(H, W).astype(np.uint16)
        Image.fromarray(mm).save(tmp_path / "d.png")
        got_rgb, depth = load_rgbd(p, tmp_path / "d.png")
        np.testing.assert_array_equal(got_rgb, rgb)
        np.testing.assert_allclose(depth, mm / 1000.0)

    def test_npy_and_exr_metres(self, tmp_path):
        OpenEXR = pytest.importorskip("OpenEXR")
        _, p = self.write_rgb(tmp_path)
        z = np.linspace(0.5, 9.0, H * W).reshape(H, W).astype(np.float32)
        np.save(tmp_path / "d.npy", z)
        OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                     {"Z": z}).write(str(tmp_path / "d.exr"))
        for name in ("d.npy", "d.exr"):
            np.testing.assert_allclose(load_rgbd(p, tmp_path / name)[1], z)

    def test_zeros_in_png_are_reported(self, tmp_path):
        _, p = self.write_rgb(tmp_path)
        mm = np.full((H, W), 1500, np.uint16)
        mm[4, 5:8] = 0                          # holes, as depth cameras write them
        Image.fromarray(mm).save(tmp_path / "d.png")
        with pytest.raises(AquaspecError, match=r"3 invalid pixels.*row 4, column 5"):
            load_rgbd(p, tmp_path / "d.png")

    def test_8bit_depth_png_rejected(self, tmp_path):
        _, p = self.write_rgb(tmp_path)
        Image.fromarray(np.full((H, W), 9, np.uint8)).save(tmp_path / "d.png")
        with pytest.raises(AquaspecError, match="16-bit"):
            load_rgbd(p, tmp_path / "d.png")

    def test_size_mismatch_and_missing_files(self, tmp_path):
        _, p = self.write_rgb(tmp_path)
        np.save(tmp_path / "d.npy", np.ones((H + 1, W)))
        with pytest.raises(AquaspecError, match="same size"):
            load_rgbd(p, tmp_path / "d.npy")
        with pytest.raises(AquaspecError, match="does not exist"):
            load_rgbd(tmp_path / "nope.png", tmp_path / "d.npy")
        with pytest.raises(AquaspecError, match="accepted"):
            load_rgbd(p, tmp_path / "d.tiff")

    @pytest.mark.parametrize("array", [np.float64(2.0), np.ones(W), np.ones((H, W, 3))],
                             ids=["0-d", "1-d", "3 channels"])
    def test_npy_of_the_wrong_shape(self, tmp_path, array):
        # A 0-d or 1-d array raised IndexError (found by tests/io/test_fuzz_readers.py).
        _, p = self.write_rgb(tmp_path)
        np.save(tmp_path / "d.npy", array)
        with pytest.raises(AquaspecError, match=r"d\.npy' has shape .*; expected \(H, W\)"):
            load_rgbd(p, tmp_path / "d.npy")

    def test_npy_header_larger_than_file(self, tmp_path):
        _, p = self.write_rgb(tmp_path)
        np.save(tmp_path / "d.npy", np.ones((H, W)))
        data = (tmp_path / "d.npy").read_bytes()
        (tmp_path / "d.npy").write_bytes(data[:len(data) // 2])
        with pytest.raises(AquaspecError, match=r"could not read depth file .*d\.npy' as \.npy"):
            load_rgbd(p, tmp_path / "d.npy")

    def test_files_over_the_size_limit(self, tmp_path, monkeypatch):
        _, p = self.write_rgb(tmp_path)
        np.save(tmp_path / "d.npy", np.ones((700, 400)))          # 2.1 MB
        monkeypatch.setenv("AQUASPEC_MAX_FILE_MB", "2")
        with pytest.raises(AquaspecError, match=r"depth file .*d\.npy' is 2.14 MB, above the "
                                                "limit of 2 MB for depth files"):
            load_rgbd(p, tmp_path / "d.npy")

    def test_corrupt_image(self, tmp_path):
        (tmp_path / "bad.png").write_bytes(b"not a png")
        np.save(tmp_path / "d.npy", np.ones((H, W)))
        with pytest.raises(AquaspecError, match="could not read image"):
            load_rgbd(tmp_path / "bad.png", tmp_path / "d.npy")
