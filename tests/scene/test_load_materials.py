"""glTF PBR materials and OBJ/MTL maps in the mesh loader: normal maps, reported parameters."""

import numpy as np
import trimesh
from PIL import Image

from aquaspec.scene import load_mesh

QUAD_V = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
QUAD_F = [[0, 1, 2], [0, 2, 3]]
QUAD_UV = [[0, 0], [1, 0], [1, 1], [0, 1]]


def _normal_image(tilt_x=0.4):
    n = np.array([tilt_x, 0.0, np.sqrt(1 - tilt_x ** 2)])
    return np.tile(np.round((n + 1) / 2 * 255).astype(np.uint8), (4, 4, 1))


class TestGltf:
    def test_normal_map_and_metallic_roughness_reported(self, tmp_path):
        quad = trimesh.Trimesh(QUAD_V, QUAD_F, process=False)
        colour = np.full((4, 4, 3), 200, np.uint8)
        material = trimesh.visual.material.PBRMaterial(
            baseColorTexture=Image.fromarray(colour), normalTexture=Image.fromarray(
                _normal_image()), metallicFactor=0.25, roughnessFactor=0.7,
            metallicRoughnessTexture=Image.fromarray(np.zeros((2, 2, 3), np.uint8)))
        quad.visual = trimesh.visual.TextureVisuals(uv=QUAD_UV, material=material)
        quad.export(tmp_path / "q.glb")
        scene = load_mesh(tmp_path / "q.glb")
        m = scene.meshes[0]
        assert m.texture is not None and m.normal_map is not None
        np.testing.assert_allclose(m.normal_map[0, 0], [0.4, 0.0, np.sqrt(1 - 0.16)], atol=0.01)
        (info,) = scene.info["materials"]
        assert info["metallic_factor"] == 0.25 and info["roughness_factor"] == 0.7
        assert info["metallic_roughness_texture"] == [2, 2]
        assert info["normal_map"]["source"] == "glTF normalTexture"
        assert info["base_colour_texture"] == [4, 4]
        assert "not used" in info["rendered"]
        # The tangent frame of the quad: u along +x, the map tilts the normal to +x.
        t = m.tangents()
        np.testing.assert_allclose(t[:, :3], np.tile([1.0, 0, 0], (4, 1)), atol=1e-9)

    def test_defaults_of_gltf_when_factors_are_absent(self, tmp_path):
        quad = trimesh.Trimesh(QUAD_V, QUAD_F, process=False)
        quad.visual = trimesh.visual.TextureVisuals(
            uv=QUAD_UV, material=trimesh.visual.material.PBRMaterial(
                baseColorFactor=[255, 128, 0, 255]))
        quad.export(tmp_path / "plain.glb")
        scene = load_mesh(tmp_path / "plain.glb")
        (info,) = scene.info["materials"]
        assert info["metallic_factor"] == 1.0 and info["roughness_factor"] == 1.0
        assert scene.meshes[0].normal_map is None
        assert info["albedo_linear_rgb"][0] == 1.0


class TestObjMtl:
    def _write(self, tmp_path, mtl_lines, images):
        for name, arr in images.items():
            Image.fromarray(arr).save(tmp_path / name)
        (tmp_path / "q.mtl").write_text("newmtl m\n" + "\n".join(mtl_lines) + "\n")
        obj = ["mtllib q.mtl", "usemtl m"]
        obj += [f"v {x} {y} {z}" for x, y, z in QUAD_V]
        obj += [f"vt {u} {v}" for u, v in QUAD_UV]
        obj += ["f 1/1 2/2 3/3", "f 1/1 3/3 4/4"]
        (tmp_path / "q.obj").write_text("\n".join(obj) + "\n")
        return load_mesh(tmp_path / "q.obj")

    def test_map_kd_and_norm(self, tmp_path):
        scene = self._write(tmp_path, ["Kd 1 1 1", "map_Kd kd.png", "norm n.png"],
                            {"kd.png": np.full((4, 4, 3), 128, np.uint8),
                             "n.png": _normal_image(0.3)})
        m = scene.meshes[0]
        assert m.texture is not None and m.normal_map is not None
        np.testing.assert_allclose(m.normal_map[1, 1, 0], 0.3, atol=0.01)
        assert scene.info["materials"][0]["normal_map"]["source"] == "MTL norm"

    def test_bump_normal_map_used_height_map_reported(self, tmp_path):
        scene = self._write(tmp_path, ["Kd 0.5 0.5 0.5", "map_Bump -bm 1.0 b.png"],
                            {"b.png": _normal_image(0.2)})
        assert scene.meshes[0].normal_map is not None
        scene = self._write(tmp_path, ["Kd 0.5 0.5 0.5", "map_Bump h.png"],
                            {"h.png": np.full((4, 4, 3), 90, np.uint8)})
        assert scene.meshes[0].normal_map is None
        assert scene.info["materials"][0]["ignored"] == ["MTL map_bump (a height map)"]
