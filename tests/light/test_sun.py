"""The direct sun (aquaspec.light.sun): geometry and the sun-sky light."""

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import surface_light
from aquaspec.light import sun as S
from aquaspec.medium import interface


# ---- geometry and the light -------------------------------------------------------

@pytest.mark.parametrize("elev,az", [(60.0, 150.0), (10.0, 0.0), (90.0, 33.0), (1.0, 270.0)])
def test_refraction_follows_snell(elev, az):
    air = S.air_to_sun(elev, az)
    wat = S.refracted_to_sun(elev, az)
    assert np.isclose(np.linalg.norm(wat), 1.0)
    sin_air = np.hypot(air[0], air[2])
    sin_w = np.hypot(wat[0], wat[2])
    assert np.isclose(sin_air, interface.N_WATER * sin_w)
    if sin_air > 1e-9:      # same vertical plane, same side
        assert np.allclose(air[[0, 2]] / sin_air, wat[[0, 2]] / sin_w)
    # Never flatter than the edge of Snell's window.
    assert wat[1] >= np.sqrt(1 - 1 / interface.N_WATER ** 2) - 1e-12


def test_azimuth_convention():
    # 0: towards -z (ahead of the built-in camera); 90: towards +x.
    assert S.air_to_sun(0.0 + 1e-9, 0.0)[2] < -0.99
    assert S.air_to_sun(1e-9, 90.0)[0] > 0.99


def test_sun_sky_splits_e0_into_sky_and_sun():
    bands = Bands(10)
    light = surface_light("sun-sky", sun_elevation_deg=40.0, sun_azimuth_deg=10.0)
    e0, sky, sun = light.on_bands(bands), light.sky_on(bands), light.sun_horizontal_on(bands)
    assert np.allclose(sky + sun, e0)
    assert np.all(sun > sky)             # a clear day: the sun brings most of E0
    scaled = surface_light("sun-sky", sun_elevation_deg=40.0, total_w_m2=50.0)
    assert np.isclose(scaled.total_w_m2(), 50.0)
    # The sun is scaled with the light: its share of E0 is unchanged.
    assert np.allclose(scaled.sun_horizontal_on(bands) / scaled.on_bands(bands), sun / e0)
    assert light.describe()["sun"]["azimuth_deg"] == 10.0
    assert light.without_sun().sun is None
    assert surface_light("overcast").sun is None


@pytest.mark.parametrize("kw,what", [({"sun_azimuth_deg": float("nan")}, "azimuth"),
                                     ({"sun_elevation_deg": 0.5}, "elevation")])
def test_bad_sun_angles_are_named(kw, what):
    with pytest.raises(AquaspecError, match=what):
        surface_light("sun-sky", **kw)

