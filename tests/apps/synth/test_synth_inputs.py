"""aquaspec synth's inputs: finding pairs, depth units, holes, bad files."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from aquaspec.apps.synth.config import InputsConfig
from aquaspec.apps.synth.inputs import discover, read_pair
from aquaspec.errors import AquaspecError
from support.synth_data import INTRINSICS, depth_mm, make_folder, rgb_image


def inputs(folder, **kw):
    return InputsConfig(folder=folder, intrinsics=INTRINSICS, **kw)


class TestDiscover:
    def test_pairs_matched_by_name(self, tmp_path):
        make_folder(tmp_path, 3)
        pairs, missing = discover(inputs(tmp_path))
        assert [p.name for p in pairs] == ["img000", "img001", "img002"]
        assert pairs[1].image == "rgb/img001.png" and pairs[1].depth == "depth/img001.png"
        assert pairs[0].intrinsics == INTRINSICS and missing == []

    def test_missing_depth_is_an_error_naming_the_image(self, tmp_path):
        make_folder(tmp_path, 3, missing=(1,))
        with pytest.raises(AquaspecError, match="1 image\\(s\\) have no depth map: img001.*"
                                                "missing_depth = 'skip'"):
            discover(inputs(tmp_path))

    def test_missing_depth_skipped_on_request(self, tmp_path):
        make_folder(tmp_path, 3, missing=(1,))
        pairs, missing = discover(inputs(tmp_path, missing_depth="skip"))
        assert [p.name for p in pairs] == ["img000", "img002"] and missing == ["img001"]

    def test_no_rgb_folder(self, tmp_path):
        with pytest.raises(AquaspecError, match="has no rgb/ folder"):
            discover(inputs(tmp_path))

    def test_no_intrinsics(self, tmp_path):
        make_folder(tmp_path, 1)
        with pytest.raises(AquaspecError, match="'img000' has no intrinsics"):
            discover(InputsConfig(folder=tmp_path))

    def test_csv_manifest_with_per_image_intrinsics(self, tmp_path):
        make_folder(tmp_path, 2)
        (tmp_path / "pairs.csv").write_text(
            "name,image,depth,fx,fy,cx,cy\n"
            "a,rgb/img000.png,depth/img000.png,40,41,30,20\n"
            "b,rgb/img001.png,depth/img001.png,,,,\n")
        pairs, _ = discover(InputsConfig(manifest=tmp_path / "pairs.csv", intrinsics=INTRINSICS))
        assert [(p.name, p.intrinsics) for p in pairs] == [("a", (40.0, 41.0, 30.0, 20.0)),
                                                           ("b", INTRINSICS)]

    def test_parquet_manifest(self, tmp_path):
        pq = pytest.importorskip("pyarrow.parquet")
        import pyarrow as pa
        make_folder(tmp_path, 1)
        pq.write_table(pa.table({"image": ["rgb/img000.png"], "depth": ["depth/img000.png"]}),
                       tmp_path / "pairs.parquet")
        pairs, _ = discover(inputs(None, manifest=tmp_path / "pairs.parquet"))
        assert [p.name for p in pairs] == ["rgb/img000"]

    def test_manifest_bad_intrinsics(self, tmp_path):
        (tmp_path / "pairs.csv").write_text("image,depth,fx,fy,cx,cy\na.png,a.png,0,1,2,3\n")
        with pytest.raises(AquaspecError, match="row 2 has intrinsics"):
            discover(InputsConfig(manifest=tmp_path / "pairs.csv"))


class TestReadPair:
    def pair(self, tmp_path, depth, suffix=".npy", **kw):
        make_folder(tmp_path, 1)
        (tmp_path / "depth" / "img000.png").unlink()
        path = tmp_path / "depth" / f"img000{suffix}"
        if suffix == ".npy":
            np.save(path, depth)
        else:
            Image.fromarray(depth).save(path)
        cfg = inputs(tmp_path, **kw)
        pairs, _ = discover(cfg)
        return read_pair(pairs[0], cfg)

    def test_png_in_millimetres(self, tmp_path):
        make_folder(tmp_path, 1)
        cfg = inputs(tmp_path)
        rgbd = read_pair(discover(cfg)[0][0], cfg)
        np.testing.assert_allclose(rgbd.depth_m, depth_mm(0) * 1e-3)
        assert rgbd.hole_count == 0 and rgbd.rgb.shape == (48, 64, 3)

    def test_units_and_scale(self, tmp_path):
        d = depth_mm(0).astype(np.float64) / 10.0          # centimetres
        rgbd = self.pair(tmp_path, d, depth_unit="cm", depth_scale=2.0)
        np.testing.assert_allclose(rgbd.depth_m, d * 0.02)

    def test_wrong_unit_is_named(self, tmp_path):
        with pytest.raises(AquaspecError, match="median of 2.*read as 'm'.*accepted: "
                                                "\\[inputs\\] depth_unit mm, cm, m"):
            self.pair(tmp_path, depth_mm(0).astype(np.float64), depth_unit="m")

    def test_holes_filled_from_the_nearest_valid_pixel(self, tmp_path):
        d = depth_mm(0).astype(np.float64) * 1e-3
        d[10, 10], d[0, 0], d[20, 30] = np.nan, 0.0, -1.0
        rgbd = self.pair(tmp_path, d)
        assert rgbd.hole_count == 3 and rgbd.holes[10, 10] and rgbd.holes[0, 0]
        assert np.all(np.isfinite(rgbd.depth_m)) and rgbd.depth_m.min() > 0
        assert rgbd.depth_m[0, 0] in (d[0, 1], d[1, 0], d[1, 1])

    def test_holes_refused_on_request(self, tmp_path):
        d = depth_mm(0).astype(np.float64) * 1e-3
        d[5, 7] = np.nan
        with pytest.raises(AquaspecError, match="1 invalid pixels.*row 5, column 7.*holes = "
                                                "'mask' or 'fill'"):
            self.pair(tmp_path, d, holes="error")

    def test_all_holes(self, tmp_path):
        with pytest.raises(AquaspecError, match="no valid pixel"):
            self.pair(tmp_path, np.zeros((48, 64)))

    def test_mismatched_sizes_named(self, tmp_path):
        make_folder(tmp_path, 1, mismatched=(0,))
        cfg = inputs(tmp_path)
        with pytest.raises(AquaspecError, match="is 64x48 but depth .* is 63x48"):
            read_pair(discover(cfg)[0][0], cfg)

    def test_eight_bit_png_depth_refused(self, tmp_path):
        make_folder(tmp_path, 1)
        Image.fromarray(rgb_image(0)[..., 0]).save(tmp_path / "depth" / "img000.png")
        cfg = inputs(tmp_path)
        with pytest.raises(AquaspecError, match="expected a single-channel 16-bit PNG"):
            read_pair(discover(cfg)[0][0], cfg)


class TestMeshes:
    def test_folder_and_files(self, tmp_path):
        trimesh = pytest.importorskip("trimesh")
        (tmp_path / "models" / "sub").mkdir(parents=True)
        trimesh.creation.box().export(tmp_path / "models" / "box.ply")
        trimesh.creation.icosphere().export(tmp_path / "models" / "sub" / "ball.obj")
        (tmp_path / "models" / "notes.txt").write_text("not a mesh")
        cfg = InputsConfig(meshes=(tmp_path / "models",), mesh_size=(32, 24))
        found, _ = discover(cfg)
        assert [(m.name, m.mesh, m.size) for m in found] == [
            ("mesh:box", "box.ply", (32, 24)), ("mesh:sub/ball", "sub/ball.obj", (32, 24))]

    def test_rgbd_and_meshes_together(self, tmp_path):
        trimesh = pytest.importorskip("trimesh")
        make_folder(tmp_path, 1)
        trimesh.creation.box().export(tmp_path / "box.glb")
        found, _ = discover(inputs(tmp_path, meshes=(tmp_path / "box.glb",)))
        assert [f.describe()["kind"] for f in found] == ["rgbd", "mesh"]

    def test_not_a_mesh(self, tmp_path):
        (tmp_path / "a.txt").write_text("x")
        with pytest.raises(AquaspecError, match="neither a folder nor a mesh file; accepted "
                                                "suffixes: .obj"):
            discover(InputsConfig(meshes=(tmp_path / "a.txt",)))
