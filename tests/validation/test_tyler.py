"""The light-field model's deep radiance distribution against Tyler (1958)."""

import json

import numpy as np
import pytest

from aquaspec.cli import main
from aquaspec.errors import AquaspecError
from aquaspec.transport.lightfield.solve import solve_lightfield
from aquaspec.validation.tyler import (TYLER_C, fit_albedo, tyler_check, tyler_k_inf,
                                       tyler_mean_radiance)


@pytest.fixture(scope="module")
def check():
    return tyler_check()


def test_tyler_tables_read_as_published():
    tilt, rad = tyler_mean_radiance(66.1)
    assert tilt[0] == 0 and tilt[-1] == 180 and tilt.size == 19
    # Brightest looking up, darkest looking down, decaying in between.
    assert rad[0] == rad.max() and rad[-1] == rad.min() and rad[0] / rad[-1] > 100
    # Deeper is darker at every tilt.
    _, shallower = tyler_mean_radiance(53.7)
    assert np.all(shallower > rad)


def test_k_inf_is_between_the_tables_decay_rates():
    k = tyler_k_inf()
    assert 0.12 < k < 0.2
    assert k < TYLER_C
    # The shape is still settling: the pair above gives a slightly different rate.
    assert abs(tyler_k_inf((41.3, 53.7)) - k) < 0.02


def test_fitted_albedo_reproduces_k_inf():
    k = tyler_k_inf()
    w0 = fit_albedo(k, TYLER_C, "hg", g=0.92)
    lf = solve_lightfield([TYLER_C * (1 - w0)], [TYLER_C * w0], phase="hg", g=0.92)
    assert lf.k_inf[0] == pytest.approx(k, rel=1e-6)
    # Forward-peaked scattering barely deflects light, so K stays near the
    # absorption; isotropic scattering lengthens the paths, so the same K
    # needs much less absorption (a higher albedo).
    assert fit_albedo(k, TYLER_C, "isotropic") > w0


def test_realistic_phase_functions_match_tylers_shape(check):
    res = {r["phase"]: r for r in check["results"]}
    # Three decades from zenith to nadir: the ocean phase functions stay
    # within a factor 1.5 of the measurement at every tilt ...
    for phase in ("petzold", "ff", "hg"):
        assert res[phase]["max_abs_log_ratio"] < np.log(1.55), phase
        assert 0.6 < res[phase]["omega0"] < 0.85
    # ... while isotropic scattering is off by two orders of magnitude.
    assert res["isotropic"]["max_abs_log_ratio"] > np.log(50)


def test_bad_input():
    with pytest.raises(AquaspecError, match=r"Tyler depth 50.*accepted: 4.24"):
        tyler_mean_radiance(50)
    with pytest.raises(AquaspecError, match=r"must lie between 0 and c"):
        fit_albedo(0.5, 0.4, "petzold")
    with pytest.raises(AquaspecError, match=r"second must be deeper"):
        tyler_k_inf((66.1, 53.7))


def test_cli_writes_json_and_plot(tmp_path, capsys):
    assert main(["validate", "--tyler", "-o", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "Tyler (1958)" in out and "max |ln ratio|" in out
    doc = json.loads((tmp_path / "tyler.json").read_text())
    assert {r["phase"] for r in doc["results"]} == {"petzold", "ff", "hg", "isotropic"}
    assert (tmp_path / "tyler.png").stat().st_size > 1000


@pytest.mark.parametrize("phase,kw", [("hg", {"g": 0.92}), ("isotropic", {})])
def test_asymptotic_shape_is_the_deep_radiance(phase, kw):
    lf = solve_lightfield([0.1], [0.3], phase=phase, n_streams=24, **kw)
    mu = np.linspace(-1, 1, 41)
    depth = 40.0 / (lf.kappa[0, 1] - lf.kappa[0, 0])
    deep = lf.radiance(depth, mu)[0]
    shape = lf.asymptotic_radiance(mu)[0]
    np.testing.assert_allclose(shape / shape[-1], deep / deep[-1], rtol=1e-6)
