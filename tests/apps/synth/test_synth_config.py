"""aquaspec synth's configuration: what is accepted, and errors naming what is not."""

from __future__ import annotations

import pytest

from aquaspec.apps.synth.config import config_from_dict, load_config
from aquaspec.errors import AquaspecError

INPUTS = {"folder": "data", "intrinsics": [50, 50, 32, 24]}


def cfg(**tables):
    return config_from_dict({"inputs": INPUTS, **tables}, base="/tmp/base")


class TestLoadConfig:
    def test_defaults_and_paths_relative_to_the_file(self, tmp_path):
        path = tmp_path / "c.toml"
        path.write_text('[inputs]\nfolder = "data"\n[output]\nfolder = "out"\n')
        c = load_config(path)
        assert c.inputs.folder == tmp_path / "data"
        assert c.output.folder == tmp_path / "out"
        assert c.inputs.holes == "mask" and c.inputs.depth_unit is None
        assert c.plan.mode == "random" and c.plan.dimensions["water"].values == ("IB",)
        assert c.output.manifest == ("csv", "parquet")

    def test_overrides(self, tmp_path):
        path = tmp_path / "c.toml"
        path.write_text('[inputs]\nfolder = "data"\n')
        c = load_config(path, output=tmp_path / "elsewhere", layers=True)
        assert c.output.folder == tmp_path / "elsewhere" and c.output.layers

    def test_not_toml(self, tmp_path):
        path = tmp_path / "c.toml"
        path.write_text("[inputs\n")
        with pytest.raises(AquaspecError, match="not valid TOML"):
            load_config(path)

    def test_missing_file(self, tmp_path):
        with pytest.raises(AquaspecError, match="cannot be read"):
            load_config(tmp_path / "nope.toml")


class TestErrors:
    @pytest.mark.parametrize("doc, match", [
        ({"inputs": INPUTS, "plann": {}}, "unknown key 'plann'.*accepted: inputs, plan"),
        ({"inputs": {"folder": "a", "manifest": "b.csv"}}, "needs one of folder .* and/or meshes"),
        ({"inputs": {**INPUTS, "depth_unit": "inch"}}, "depth_unit = 'inch'; accepted: mm, cm, m"),
        ({"inputs": {**INPUTS, "holes": "ignore"}}, "holes = 'ignore'; accepted: mask, fill"),
        ({"inputs": {**INPUTS, "depth_scale": 0}}, "depth_scale = 0; accepted: a finite number > 0"),
        ({"inputs": {**INPUTS, "intrinsics": [1, 2, 3]}}, r"accepted: \[fx, fy, cx, cy\]"),
        ({"inputs": INPUTS, "plan": {"colour": "red"}}, "unknown key 'colour' in \\[plan\\]"),
        ({"inputs": INPUTS, "plan": {"mode": "sobol"}}, "mode = 'sobol'; accepted: random, grid"),
        ({"inputs": INPUTS, "plan": {"water": {"min": 1, "max": 2}}}, "a range is for numbers"),
        ({"inputs": INPUTS, "plan": {"depth_m": {"min": 5, "max": 2}}}, "max 2 < min 5"),
        ({"inputs": INPUTS, "plan": {"mode": "grid", "depth_m": {"min": 2, "max": 5}}},
         "a grid needs steps"),
        ({"inputs": INPUTS, "plan": {"seed": -1}}, "seed = -1; accepted: an integer >= 0"),
        ({"inputs": INPUTS, "render": {"tonemap": "sepia"}}, "tonemap = 'sepia'"),
        ({"inputs": INPUTS, "render": {"marine_snow": "-2"}}, "density_per_m3=-2.0"),
        ({"inputs": INPUTS, "render": {"marine_snow": True}}, "marine_snow = True; accepted"),
        ({"inputs": INPUTS, "output": {"manifest": ["xlsx"]}}, "accepted: one or more of csv"),
        ({"inputs": INPUTS, "output": {"layers": "yes"}}, "layers = 'yes'; accepted: true"),
    ])
    def test_bad_value_is_named(self, doc, match):
        with pytest.raises(AquaspecError, match=match):
            config_from_dict(doc)

    def test_ranges_and_lists(self):
        c = cfg(plan={"mode": "grid", "depth_m": {"min": 2, "max": 6, "steps": 3},
                      "water": ["IB", "II"]})
        d = c.plan.dimensions["depth_m"]
        assert (d.low, d.high, d.steps) == (2.0, 6.0, 3)
        assert c.plan.dimensions["water"].values == ("IB", "II")


class TestMarineSnow:
    def test_spec_kept_and_each_sample_seeded_by_its_id(self):
        from aquaspec.apps.synth.task import _marine_snow
        c = config_from_dict({"inputs": INPUTS, "render": {"marine_snow": 300}})
        assert c.render.marine_snow == "300" and c.render.describe()["marine_snow"] == "300"
        assert "marine_snow" not in config_from_dict({"inputs": INPUTS}).render.describe()
        a, b = _marine_snow("300,0,albedo=0.3", "img001-0"), _marine_snow("300", "img001-1")
        assert a.seed != b.seed and a.albedo == 0.3
        assert _marine_snow("300", "img001-0").seed == a.seed      # the same on a rerun
        assert _marine_snow(None, "img001-0") is None
