"""The colour-science tables, copied once into the cache: the same numbers, without the import."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from aquaspec import cache

from aquaspec.colour import data as colourdata


@pytest.fixture
def fresh_cache(tmp_path, monkeypatch):
    """An empty cache directory, and tables() forgotten before and after."""
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path))
    colourdata.tables.cache_clear()
    yield tmp_path
    colourdata.tables.cache_clear()


def test_the_tables_are_colour_sciences(fresh_cache):
    import colour
    wl, cmfs = colourdata.cmfs_1931()
    ref = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    np.testing.assert_array_equal(wl, ref.wavelengths)
    np.testing.assert_array_equal(cmfs, ref.values)
    wl, e = colourdata.d65()
    np.testing.assert_array_equal(wl, colour.SDS_ILLUMINANTS["D65"].wavelengths)
    np.testing.assert_array_equal(e, colour.SDS_ILLUMINANTS["D65"].values)
    checker = colourdata.colorchecker_spectra()
    sds = colour.SDS_COLOURCHECKERS["BabelColor Average"]
    assert [name for name, _, _ in checker] == list(sds.keys())
    for (_, wl, r), sd in zip(checker, sds.values()):
        np.testing.assert_array_equal(wl, sd.wavelengths)
        np.testing.assert_array_equal(r, sd.values)
    cams = colourdata.camera_sensitivities()
    assert list(cams) == list(colour.MSDS_CAMERA_SENSITIVITIES)
    for key, (wl, rgb) in cams.items():
        np.testing.assert_array_equal(rgb, colour.MSDS_CAMERA_SENSITIVITIES[key].values)


def test_the_cache_file_is_named_by_version_and_read_back(fresh_cache):
    first = colourdata.cmfs_1931()
    files = list(fresh_cache.glob("colour-science-*.npz"))
    assert [f.name for f in files] == [
        f"colour-science-{cache.package_version('colour-science')}-v{colourdata._LAYOUT}.npz"]
    assert not list(fresh_cache.glob("*.part*")), "the temporary file was left behind"
    colourdata.tables.cache_clear()
    second = colourdata.cmfs_1931()
    np.testing.assert_array_equal(first[1], second[1])


def test_a_second_process_does_not_import_colour(fresh_cache):
    colourdata.tables()
    code = ("import sys; from aquaspec.colour.sensors import get_sensor; s = get_sensor('human'); "
            "from aquaspec.colour.reflectance import colorchecker; assert len(colorchecker()) == 24; "
            "from aquaspec.light.sky import surface_light; surface_light('d65'); "
            "print('colour' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False", out.stderr


def test_a_damaged_file_is_rebuilt(fresh_cache):
    colourdata.tables()
    (path,) = fresh_cache.glob("colour-science-*.npz")
    path.write_bytes(b"not a zip file")
    colourdata.tables.cache_clear()
    wl, e = colourdata.d65()
    assert wl.size == e.size > 50
    with np.load(path) as z:
        np.testing.assert_array_equal(z["d65/values"], e)


def test_off_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.CACHE_ENV, "off")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    colourdata.tables.cache_clear()
    try:
        assert cache.cache_dir() is None
        assert colourdata.cmfs_1931()[1].shape[1] == 3
    finally:
        colourdata.tables.cache_clear()
    assert not list(tmp_path.iterdir())


def test_callers_get_copies(fresh_cache):
    wl, e = colourdata.d65()
    e[:] = -1.0
    assert colourdata.d65()[1].min() >= 0.0
