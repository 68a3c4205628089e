"""`aquaspec render --scene`: the built-in scenes by name; a textured glTF's report."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from aquaspec.cli import main
from aquaspec.errors import AquaspecError
from aquaspec.rendering.api import render
from aquaspec.scene.builtin import RENDER_DEFAULT_VARIANT


@pytest.mark.gpu
class TestScene:
    def test_detailed_and_classic_in_the_sidecar(self, tmp_path):
        images = {}
        for name in ("classic", "detailed"):
            out = tmp_path / f"{name}.png"
            assert main(["render", "--scene", name, "--size", "96x54", "--bands", "4",
                         "-o", str(out)]) == 0
            side = json.loads((tmp_path / f"{name}.png.json").read_text())
            assert side["scene"]["kind"] == "builtin" and side["scene"]["builtin"] == name
            images[name] = np.asarray(Image.open(out), float)
        assert "measured" in side["scene"]["reflectances"]["seagrass"]
        # Not the same picture: the detailed scene's seagrass, crevices, ripples.
        assert np.abs(images["classic"] - images["detailed"]).mean() > 1.0

    def test_default_is_named_in_the_sidecar(self, tmp_path):
        out = tmp_path / "d.png"
        assert main(["render", "--size", "64x36", "--bands", "4", "-o", str(out)]) == 0
        side = json.loads((tmp_path / "d.png.json").read_text())
        assert side["scene"]["builtin"] == RENDER_DEFAULT_VARIANT

    def test_scene_with_a_mesh_is_an_error(self, tmp_path, capsys):
        code = main(["render", "--scene", "detailed", "--mesh", str(tmp_path / "m.obj"),
                     "--size", "64x36", "-o", str(tmp_path / "x.png")])
        assert code != 0
        assert "builtin='detailed'" in capsys.readouterr().err

    def test_unknown_scene_in_the_api(self):
        with pytest.raises(AquaspecError, match="'reef'.*classic, detailed"):
            render(builtin="reef", size=(32, 18), bands=4)


@pytest.mark.gpu
def test_textured_gltf_reports_its_material(tmp_path):
    """A glTF with base colour, normal map and metallic-roughness renders; the
    sidecar reports what was used and what was not."""
    import trimesh
    quad = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]],
                           process=False)
    rng = np.random.default_rng(0)
    normal = np.tile(np.array([150, 128, 240], np.uint8), (8, 8, 1))
    material = trimesh.visual.material.PBRMaterial(
        baseColorTexture=Image.fromarray(rng.integers(40, 220, (8, 8, 3), dtype=np.uint8)),
        normalTexture=Image.fromarray(normal), metallicFactor=0.0, roughnessFactor=0.8)
    quad.visual = trimesh.visual.TextureVisuals(uv=[[0, 0], [1, 0], [1, 1], [0, 1]],
                                                material=material)
    path = tmp_path / "tile.glb"
    quad.export(path)
    res = render(mesh=path, size=(64, 36), bands=4)
    (info,) = res.params["scene"]["materials"]
    assert info["roughness_factor"] == 0.8 and info["normal_map"]["size"] == [8, 8]
    # The quad is in view: the centre is not the open water of the corners.
    centre = res.display[14:22, 26:38].astype(float).mean(axis=(0, 1))
    assert np.abs(centre - res.display[0, 0].astype(float)).max() > 10
