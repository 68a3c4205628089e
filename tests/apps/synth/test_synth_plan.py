"""aquaspec synth's plan: grid and random draws, sample ids, groups, value checks."""

from __future__ import annotations

import pytest

from aquaspec.apps.synth.config import config_from_dict
from aquaspec.apps.synth.inputs import discover
from aquaspec.apps.synth.plan import check_values, chunks, plan_samples
from aquaspec.errors import AquaspecError
from support.synth_data import INTRINSICS, make_folder


def setup(tmp_path, n=3, **plan):
    make_folder(tmp_path / "data", n)
    cfg = config_from_dict({"inputs": {"folder": "data", "intrinsics": list(INTRINSICS)},
                            "plan": plan}, base=tmp_path)
    return cfg, discover(cfg.inputs)[0]


class TestPlanSamples:
    def test_grid_is_every_combination(self, tmp_path):
        cfg, pairs = setup(tmp_path, mode="grid", water=["IB", "3C"],
                           depth_m={"min": 2, "max": 6, "steps": 3})
        samples = plan_samples(cfg, pairs)
        assert len(samples) == 3 * 2 * 3
        assert {s.params["depth_m"] for s in samples} == {2.0, 4.0, 6.0}
        assert len({s.sample_id for s in samples}) == len(samples)

    def test_random_is_reproducible_and_per_input(self, tmp_path):
        plan = dict(seed=5, samples_per_input=4, water=["IB", "II", "3C"],
                    depth_m={"min": 1, "max": 9}, light=["overcast", "sun-sky"],
                    sun_elevation_deg={"min": 20, "max": 80})
        cfg, pairs = setup(tmp_path, **plan)
        a = plan_samples(cfg, pairs)
        b = plan_samples(cfg, pairs)
        assert [(s.sample_id, s.params) for s in a] == [(s.sample_id, s.params) for s in b]
        # An input's draws do not depend on the other inputs.
        alone = plan_samples(cfg, pairs[1:2])
        assert [s.sample_id for s in alone] == [s.sample_id for s in a if s.pair.name == "img001"]
        assert all(1 <= s.params["depth_m"] <= 9 for s in a)
        other = plan_samples(config_from_dict({**_doc(cfg), "plan": {**plan, "seed": 6}},
                                              base=tmp_path), pairs)
        assert {s.sample_id for s in other}.isdisjoint({s.sample_id for s in a})

    def test_sun_parameters_only_with_a_sun(self, tmp_path):
        cfg, pairs = setup(tmp_path, n=1, mode="grid", light=["overcast", "sun-sky"],
                           sun_elevation_deg=[30, 60], wind_m_s=[0, 3])
        samples = plan_samples(cfg, pairs)
        overcast = [s for s in samples if s.params["light"] == "overcast"]
        assert len(overcast) == 1 and overcast[0].params["sun_elevation_deg"] is None
        sunny = [s for s in samples if s.params["light"] == "sun-sky"]
        assert len(sunny) == 4 and {s.params["wind_m_s"] for s in sunny} == {None, 3.0}

    @pytest.mark.parametrize("plan, match", [
        ({"samples_per_input": 0}, "zero samples: \\[plan\\] samples_per_input = 0"),
        ({"mode": "grid", "water": []}, "zero samples: \\[plan\\] water is an empty list"),
    ])
    def test_zero_samples(self, tmp_path, plan, match):
        cfg, pairs = setup(tmp_path, n=1, **plan)
        with pytest.raises(AquaspecError, match=match):
            plan_samples(cfg, pairs)

    def test_zero_inputs(self, tmp_path):
        cfg, _ = setup(tmp_path, n=1)
        with pytest.raises(AquaspecError, match="zero samples: no input pairs"):
            plan_samples(cfg, [])


class TestChunks:
    def test_units_hold_one_group(self, tmp_path):
        cfg, pairs = setup(tmp_path, n=5, samples_per_input=3, water=["IB", "3C"],
                           bands=[4, 8])
        samples = plan_samples(cfg, pairs)
        units = chunks(samples, workers=2, max_size=3)
        assert sorted(s.sample_id for u in units for s in u) == sorted(s.sample_id
                                                                       for s in samples)
        assert all(len({s.group for s in u}) == 1 and len(u) <= 3 for u in units)
        assert len({tuple(u[0].group) for u in units}) == len({s.group for s in samples})


class TestCheckValues:
    @pytest.mark.parametrize("plan, match", [
        ({"water": ["IB", "XX"]}, "XX"),
        ({"sensor": "no-such-camera"}, "no-such-camera"),
        ({"light": "moon"}, "light has the value 'moon'; accepted: overcast"),
        ({"bands": 0}, "bands has the value 0; accepted: integers 1"),
        ({"sun_elevation_deg": {"min": 0, "max": 30}}, "sun elevation 0.0 deg; accepted: 1 to 90"),
        ({"exposure": "bright"}, "exposure has the value 'bright'; accepted: 'auto' or EV"),
        ({"white_balance": "auto"}, "white_balance has the value 'auto'"),
        ({"depth_m": -1}, "depth_m has the value -1; accepted: metres >= 0"),
    ])
    def test_bad_value_named_before_any_work(self, tmp_path, plan, match):
        cfg, _ = setup(tmp_path, n=1, **plan)
        with pytest.raises(AquaspecError, match=match):
            check_values(cfg)


def _doc(cfg):
    return {"inputs": {"folder": "data", "intrinsics": list(INTRINSICS)}}


def test_csv_water_relative_to_the_config(tmp_path):
    (tmp_path / "lake.csv").write_text("wavelength_nm,a,b,Kd\n400,0.1,0.2,0.15\n700,0.6,0.1,0.7\n")
    cfg, pairs = setup(tmp_path, n=1, water="lake.csv")
    check_values(cfg)                                   # found beside the config, not in cwd
    assert plan_samples(cfg, pairs)[0].params["water"] == "lake.csv"
    cfg, _ = setup(tmp_path, n=1, water="sea.csv")
    with pytest.raises(AquaspecError, match="sea.csv"):
        check_values(cfg)
