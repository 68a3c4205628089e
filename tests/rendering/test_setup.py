"""The spectral setup (aquaspec.rendering.setup): frozen parameters, and what it
derives kept in its explicit cache."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import load_water
from aquaspec.rendering.setup import SetupCache, SpectralSetup
from aquaspec.scene.seabed import Seabed
from aquaspec.colour.reflectance import Reflectance


def _setup(**kw):
    return SpectralSetup(load_water("IB"), get_sensor("human"), surface_light("overcast"),
                         Bands(4), **kw)


class TestSpectralSetup:
    def test_parameters_cannot_change(self):
        setup = _setup()
        with pytest.raises(dataclasses.FrozenInstanceError):
            setup.phase = "hg"

    def test_tables_are_made_once_and_kept_in_the_cache(self):
        setup = _setup(cone_spread=False)
        assert isinstance(setup.cache, SetupCache) and setup.cache.lightfield_tables is None
        tables = setup.lightfield_tables()
        assert setup.cache.lightfield_tables is tables
        assert setup.lightfield_tables() is tables

    def test_the_cache_is_not_a_parameter(self):
        parts = (load_water("IB"), get_sensor("human"), surface_light("overcast"), Bands(4))
        a = SpectralSetup(*parts, cone_spread=False)
        b = SpectralSetup(*parts, cone_spread=False)
        a.lightfield_tables()
        assert a == b and "cache" not in repr(a)
        with pytest.raises(TypeError):
            SpectralSetup(load_water("IB"), get_sensor("human"), surface_light("overcast"),
                          Bands(4), cache=SetupCache())

    def test_replace_starts_an_empty_cache(self):
        setup = _setup(cone_spread=False)
        deep = setup.lightfield_tables()
        bed = Seabed(12.0, Reflectance.constant(0.3))
        shallow = dataclasses.replace(setup, seabed=bed)
        assert shallow.cache is not setup.cache and shallow.cache.lightfield_tables is None
        assert shallow.lightfield_tables() is not deep
        assert setup.lightfield_tables() is deep

    def test_sun_inputs_kept_and_none_without_a_sun(self):
        assert _setup().sun_inputs() is None
        sunny = SpectralSetup(load_water("IB"), get_sensor("human"),
                              surface_light("sun-sky", sun_elevation_deg=50.0), Bands(4),
                              cone_spread=False)
        sun = sunny.sun_inputs()
        assert sunny.sun_inputs() is sun and sunny.cache.sun_inputs is sun
        assert np.all(np.isfinite(sun.beam0))

    def test_waves_need_a_sun(self):
        from aquaspec.light.waves import Waves
        with pytest.raises(AquaspecError, match="need a light with a sun"):
            _setup(waves=Waves(3.0))
