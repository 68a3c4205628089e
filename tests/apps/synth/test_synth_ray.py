"""aquaspec synth on Ray: a local Ray on the loopback address renders the same
files as the local pool, byte for byte (images, layers, sidecars, failure
records, manifests)."""

from __future__ import annotations

import pytest

from aquaspec.apps.synth import synth
from support.synth_data import make_folder, write_config

PLAN = ('mode = "random"\nseed = 11\nsamples_per_input = 4\nwater = ["IB", "3C"]\n'
        'depth_m = {min = 2, max = 8}\nbands = 4\nlight = ["overcast", "sun-sky"]\n'
        'sun_elevation_deg = {min = 40, max = 70}\nwhite_balance = ["none", "grey-world"]\n')


def files_of(folder):
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.name != "summary.json"}


@pytest.mark.gpu
@pytest.mark.slow
def test_ray_equals_local_pool(tmp_path):
    ray = pytest.importorskip("ray")
    make_folder(tmp_path / "data", 5, holes={3: 12})
    cfg = write_config(tmp_path / "synth.toml", plan=PLAN, extra="layers = true\n")
    local = synth(cfg, output=tmp_path / "local", workers=2, progress=False)
    # (A grey-world balance of a sample whose red is all absorbed fails, recorded.)
    assert (local["planned"], local["pending"]) == (20, 0) and local["done"] >= 18
    ray.init(address="local", num_cpus=2, include_dashboard=False,
             _node_ip_address="127.0.0.1", log_to_driver=False)
    try:
        on_ray = synth(cfg, output=tmp_path / "ray", workers=2, ray=True, progress=False)
    finally:
        ray.shutdown()
    assert on_ray["executor"]["kind"] == "ray"
    assert (on_ray["done"], on_ray["failed"]) == (local["done"], local["failed"])
    a, b = files_of(tmp_path / "local"), files_of(tmp_path / "ray")
    assert sorted(a) == sorted(b)
    assert len([k for k in a if k.endswith(".png.json")]) == local["done"]
    differ = [k for k in a if a[k] != b[k]]
    assert not differ, differ
