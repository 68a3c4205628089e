"""The GPU sensor pass against its NumPy twin (aquaspec.optics.sensor, lens).

Without noise the two agree to the ADC's rounding; with noise, in
distribution: flat grey frames at three exposure levels against the EMVA
1288 photon transfer curve (as tests/optics/test_sensor.py) and against the
NumPy twin's sample statistics.
"""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.optics.lens import ThinLens
from aquaspec.optics.presets import CAMERA_MODELS

pytestmark = pytest.mark.gpu

SIDE = 400
N = SIDE * SIDE
#: Standard errors allowed (as in test_sensor.py).
Z = 4.5


@pytest.fixture(scope="module")
def sensor_pass(device):
    from aquaspec.gpu.passes.camera_sensor import CameraSensorPass
    return CameraSensorPass(SIDE, SIDE, device=device)


def _run(p, sensor, rgb, per_unit, *, iso=100.0, t=0.01, **kw):
    p.upload(rgb)
    p.set_exposure(sensor, electrons_per_unit=per_unit, exposure_s=t, iso=iso, **kw)
    p.run()
    return p.read_raw(), p.read_linear()


@pytest.mark.parametrize("preset", list(CAMERA_MODELS))
def test_without_noise_matches_numpy_to_the_rounding(sensor_pass, preset):
    s = CAMERA_MODELS[preset].sensor
    rng = np.random.default_rng(0)
    rgb = rng.uniform(0.0, 1.2, (SIDE, SIDE, 3))
    per_unit = np.array([3000.0, 9000.0, 12000.0])
    intr = (300.0, 300.0, 200.0, 200.0)
    trans = np.array([0.5, 0.55, 0.6])               # a port's transmission per channel
    raw, lin = _run(sensor_pass, s, rgb, per_unit, intrinsics=intr, noise=False,
                    transmission=trans)
    j, i = np.meshgrid(np.arange(SIDE) + 0.5, np.arange(SIDE) + 0.5)
    vig = ThinLens().vignetting_factor((j - 200) / 300, (i - 200) / 300)[..., None] * trans
    mu = np.minimum(rgb * vig * per_unit + s.dark_current_e_per_s * 0.01, s.full_well_e)
    expect = np.clip(np.floor(s.black_level_dn + s.gain(100.0) * mu + 0.5), 0, s.max_dn)
    # float32 on the GPU: a value within 1e-3 DN of a half may round the other way.
    assert np.abs(raw.astype(float) - expect).max() <= 1
    assert np.mean(raw != expect) < 1e-3
    unsat = expect < s.max_dn
    step = 1.0 / (s.gain(100.0) * per_unit)                 # one DN in camera RGB
    assert np.all(np.abs(lin - rgb * vig)[unsat] <= np.broadcast_to(1.01 * step,
                                                                    lin.shape)[unsat])


@pytest.mark.parametrize("preset", list(CAMERA_MODELS))
def test_flat_grey_frames_on_the_photon_transfer_curve(sensor_pass, preset):
    s = CAMERA_MODELS[preset].sensor
    t = 0.01
    for k, mu_e in enumerate((30.0, 1500.0, 0.5 * s.full_well_e)):
        raw, _ = _run(sensor_pass, s, np.ones((SIDE, SIDE, 3)), [mu_e] * 3, t=t, seed=k)
        ref = s.capture(np.full((SIDE, SIDE), mu_e), t, 100.0, np.random.default_rng(k))
        mu_y, var_y = float(s.mean_dn(mu_e, t, 100.0)), float(s.variance_dn(mu_e, t, 100.0))
        se_mean, se_var = np.sqrt(var_y / N), var_y * np.sqrt(2.0 / (N - 1))
        for c in range(3):
            frame = raw[..., c].astype(float)
            assert abs(frame.mean() - mu_y) < Z * se_mean, (preset, mu_e, c, frame.mean(), mu_y)
            assert abs(frame.var(ddof=1) - var_y) < Z * se_var, (preset, mu_e, c, frame.var())
            # GPU and NumPy samples: differences of two estimates, sqrt(2) SE.
            assert abs(frame.mean() - ref.mean()) < Z * np.sqrt(2) * se_mean
            assert abs(frame.var(ddof=1) - ref.var(ddof=1)) < Z * np.sqrt(2) * se_var


def test_seed_and_frame(sensor_pass):
    s = CAMERA_MODELS["dslr-flat-port"].sensor
    grey = np.full((SIDE, SIDE, 3), 1.0)
    a, _ = _run(sensor_pass, s, grey, [50.0] * 3, seed=1, frame=0)
    b, _ = _run(sensor_pass, s, grey, [50.0] * 3, seed=1, frame=0)
    c, _ = _run(sensor_pass, s, grey, [50.0] * 3, seed=1, frame=1)
    np.testing.assert_array_equal(a, b)
    assert np.mean(a != c) > 0.5
    # The channels and neighbouring pixels are not correlated.
    x = a.astype(float) - a.mean()
    assert abs(np.corrcoef(x[..., 0].ravel(), x[..., 1].ravel())[0, 1]) < 0.02
    assert abs(np.corrcoef(x[:, 1:, 0].ravel(), x[:, :-1, 0].ravel())[0, 1]) < 0.02
