"""aquaspec synth with ``[render] camera_model``: each sample through the camera,
its noise seeded by the sample; a flat port refused for RGB-D inputs."""

from __future__ import annotations

import json

import numpy as np
import pytest

from aquaspec.apps.synth import synth
from aquaspec.apps.synth.config import config_from_dict
from aquaspec.errors import AquaspecError


def test_config_checks_the_camera_model():
    cfg = config_from_dict({"inputs": {"meshes": ["a.ply"]},
                            "render": {"camera_model": "dslr-flat-port"}})
    assert cfg.render.camera_model == "dslr-flat-port"
    assert cfg.render.describe()["camera_model"] == "dslr-flat-port"
    plain = config_from_dict({"inputs": {"meshes": ["a.ply"]}})
    assert "camera_model" not in plain.render.describe()      # ids kept
    with pytest.raises(AquaspecError, match="accepted: dslr-flat-port"):
        config_from_dict({"inputs": {"meshes": ["a.ply"]}, "render": {"camera_model": "gopro"}})
    with pytest.raises(AquaspecError, match="flat port"):
        config_from_dict({"inputs": {"folder": "pairs"},
                          "render": {"camera_model": "dslr-flat-port"}})
    cfg = config_from_dict({"inputs": {"folder": "pairs"},
                            "render": {"camera_model": "machine-vision-dome"}})
    assert cfg.render.camera_model == "machine-vision-dome"


@pytest.mark.gpu
def test_mesh_samples_through_the_camera(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    (tmp_path / "models").mkdir()
    trimesh.creation.box().export(tmp_path / "models" / "box.ply")
    cfg = tmp_path / "synth.toml"
    cfg.write_text('[inputs]\nmeshes = "models"\nmesh_size = [32, 24]\n'
                   '[plan]\nmode = "grid"\nbands = 4\ndepth_m = [4, 8]\n'
                   '[render]\ncamera_model = "dslr-flat-port"\n'
                   '[output]\nfolder = "out"\nmanifest = "csv"\n')
    summary = synth(cfg, progress=False)
    assert (summary["planned"], summary["done"]) == (2, 2)
    sidecars = sorted((tmp_path / "out").rglob("*.png.json"))
    seeds = set()
    for path in sidecars:
        doc = json.loads(path.read_text())
        cm = doc["camera_model"]
        assert cm["name"] == "dslr-flat-port" and cm["port"]["kind"] == "flat"
        seeds.add(cm["seed"])
        assert np.isfinite(cm["exposure_s_used"])
    assert len(sidecars) == 2 and len(seeds) == 2          # each sample its own noise
