"""The forward cone: its defaults, its exact kernel, the tables it needs."""

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.transport.lightfield.bake import lightfield_tables
from aquaspec.transport.lightfield.cone import cone_spread_kernel, forward_cone


def test_cone_spread_kernel_holds_the_offset_distribution():
    """The kernel sums to 1, is symmetric, and its mass within radius r pixels
    is the CDF of the apparent offset at r / fy radians."""
    from aquaspec.medium.phase_bands import band_cone_offset_cdf
    offsets = np.radians(20.0) * np.concatenate([[0.0], np.geomspace(1e-5, 1.0, 255)])
    cdf = band_cone_offset_cdf("ff", 20.0, offsets, backscatter=0.0183)[0]
    fy = 60.0
    k = cone_spread_kernel(offsets, cdf, fy, subsamples=16)
    r = k.shape[0] // 2
    assert k.shape == (2 * r + 1, 2 * r + 1) and r == int(np.ceil(np.radians(20.0) * fy))
    assert k.sum() == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(k, k[::-1, ::-1], atol=1e-15)
    np.testing.assert_allclose(k, k.T, atol=1e-15)
    y, x = np.indices(k.shape) - r
    dist = np.hypot(x, y)
    for radius in (3.0, 6.0, 12.0):
        inside = k[dist <= radius].sum()
        want = np.interp(radius / fy, offsets, cdf)
        # Pixel cells straddle the circle: compare within the CDF between
        # radius -+ half a cell diagonal.
        lo = np.interp((radius - 0.71) / fy, offsets, cdf)
        hi = np.interp((radius + 0.71) / fy, offsets, cdf)
        assert lo - 1e-3 <= inside <= hi + 1e-3, (radius, inside, want)
    with pytest.raises(AquaspecError, match="pixels_per_radian"):
        cone_spread_kernel(offsets, cdf, 0.0)


def test_cone_spread_needs_a_cone():
    from aquaspec.colour.bands import Bands
    from aquaspec.medium.water import load_water
    bw = load_water("IB").on_bands(Bands(3))
    with pytest.raises(AquaspecError, match="cone_spread needs a forward cone"):
        lightfield_tables(bw, phase="ff", backscatter=0.0183, cone_spread=True)
    t = lightfield_tables(bw, phase="ff", backscatter=0.0183, forward_cone_deg=30.0,
                          cone_spread=True)
    assert t.cone.offset_cdf.shape == (3, t.cone.offset_rad.size)


def test_forward_cone_defaults():
    """No cone given: 15 degrees, 40 with the spread; a given one is kept."""
    from aquaspec.colour.bands import Bands
    from aquaspec.light.sky import surface_light
    from aquaspec.rendering.setup import SpectralSetup
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.medium.water import load_water
    assert forward_cone(None, False) == 15.0 and forward_cone(None, True) == 40.0
    assert forward_cone(25, True) == 25.0
    base = dict(water=load_water("IB"), sensor=get_sensor("human"),
                light=surface_light("overcast"), bands=Bands(3), ms_model="lightfield")
    assert SpectralSetup(**base, cone_spread=False).describe()["forward_cone_deg"] == 15.0
    spread = SpectralSetup(**base, cone_spread=True)
    assert spread.describe()["forward_cone_deg"] == 40.0 and spread.describe()["cone_spread"]
    assert SpectralSetup(**base, cone_spread=True, forward_cone_deg=30.0).cone_deg == 30.0
    # No cone_spread given: the light field's default is the spread (models.cone_spread_for).
    assert SpectralSetup(**base).describe()["cone_spread"] is True
    assert SpectralSetup(**base).cone_deg == 40.0


def test_default_model_is_the_light_field_with_the_spread():
    """The default multiple-scattering model is the one the validation chose;
    the seeds' model has no cone and refuses one."""
    from aquaspec.transport import models as model
    from aquaspec.colour.bands import Bands
    from aquaspec.light.sky import surface_light
    from aquaspec.rendering.setup import SpectralSetup
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.medium.water import load_water
    assert model.DEFAULT_MS_MODEL == "lightfield"
    assert model.cone_spread_for("lightfield", None) is True
    assert model.cone_spread_for("lightfield", False) is False
    assert model.cone_spread_for("seeds", None) is False
    with pytest.raises(AquaspecError, match="cone_spread is part of the light-field model"):
        model.cone_spread_for("seeds", True)
    base = dict(water=load_water("IB"), sensor=get_sensor("human"),
                light=surface_light("overcast"), bands=Bands(3))
    d = SpectralSetup(**base).describe()
    assert d["ms_model"] == "lightfield" and d["cone_spread"] and d["phase"] == "petzold"
    assert "cone_spread" not in SpectralSetup(**base, ms_model="seeds").describe()
    with pytest.raises(AquaspecError, match="cone_spread"):
        SpectralSetup(**base, ms_model="seeds", cone_spread=True)
