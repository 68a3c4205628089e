"""Fixtures shared by the light-field occlusion tests."""

import warnings

import pytest

from aquaspec.transport.lightfield.solve import solve_lightfield


@pytest.fixture(scope="module")
def ib():
    """Jerlov IB on 4 bands and its solved light field (Petzold, 32 streams)."""
    from aquaspec.colour.bands import Bands
    from aquaspec.medium.water import load_water
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bw = load_water("IB").on_bands(Bands(4))
    lf = solve_lightfield(bw.a, bw.b, phase="petzold", wavelength_nm=bw.bands.centers_nm,
                          n_streams=32)
    return bw, lf
