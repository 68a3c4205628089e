"""Water data: Jerlov types, gap filling, derived Kd, user CSV."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError, DataRangeError
from aquaspec.medium.water import (JERLOV_TYPES, WaterDataWarning, derived_kd, load_water,
                            water_from_csv, list_waters)


def quiet_load(*args):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_water(*args)


class TestJerlov:
    @pytest.mark.parametrize("wtype", JERLOV_TYPES)
    def test_all_types_finite(self, wtype):
        w = quiet_load(wtype, "solonenko2015")
        assert w.wavelength_nm[0] <= 400 and w.wavelength_nm[-1] >= 700
        for q in (w.a, w.b, w.kd):
            assert np.all(np.isfinite(q)) and np.all(q >= 0)
        bw = w.on_bands(Bands(16))
        assert np.all(bw.c > bw.a)

    @pytest.mark.parametrize("wtype", ["IB", "II", "III", "1C", "3C", "5C"])
    def test_williamson_types_have_derived_kd(self, wtype):
        w = quiet_load(wtype, "williamson2022")
        assert w.kd_derived and w.wavelength_nm.size == 501
        np.testing.assert_allclose(w.kd, derived_kd(w.a, w.b))
        assert any("derived" in n for n in w.notes)

    def test_5c_650_filled_with_warning(self):
        with pytest.warns(WaterDataWarning) as rec:
            w = load_water("5C", "solonenko2015")
        msgs = [str(r.message) for r in rec]
        assert any("5C" in m and " a " in m and "650" in m for m in msgs)
        assert any("5C" in m and "Kd" in m and "650" in m for m in msgs)
        i = int(np.flatnonzero(w.wavelength_nm == 650)[0])
        assert np.isfinite(w.a[i]) and np.isfinite(w.kd[i])
        # Red light is absorbed by water itself: the fill is at least pure water.
        assert w.a[i] > 0.3 and w.kd[i] > w.a[i]
        assert w.filled

    def test_filled_spectrum_is_continuous(self):
        w = quiet_load("5C")
        i = int(np.flatnonzero(w.wavelength_nm == 575)[0])
        assert abs(w.kd[i + 1] / w.kd[i] - 1) < 1.0

    def test_case_insensitive(self):
        assert quiet_load("ib").name == "IB"

    def test_unknown_type(self):
        with pytest.raises(AquaspecError, match="unknown water type 'IV'.*IB"):
            load_water("IV")
        with pytest.raises(AquaspecError, match="unknown water type 'I'.*williamson2022"):
            load_water("I", "williamson2022")

    def test_unknown_source(self):
        with pytest.raises(AquaspecError, match="unknown water source 'mobley'"):
            load_water("IB", "mobley")

    def test_range_not_covered(self):
        w = quiet_load("IB")
        with pytest.raises(DataRangeError, match="300-700 nm.*400-750"):
            w.on_bands(Bands(8, 400, 750))

    def test_list(self):
        pairs = list_waters()
        assert ("solonenko2015", "9C") in pairs and ("williamson2022", "5C") in pairs
        assert len(pairs) == 16


class TestDerivedKd:
    def test_pure_absorber(self):
        np.testing.assert_allclose(derived_kd(0.5, 0.0, mu0=1.0), 0.5)

    def test_more_scattering_more_attenuation(self):
        assert derived_kd(0.1, 1.0) > derived_kd(0.1, 0.1)

    def test_bad_mu0(self):
        with pytest.raises(AquaspecError, match="mu0"):
            derived_kd(0.1, 0.1, mu0=0.2)


class TestCsv:
    def write(self, tmp_path, text):
        p = tmp_path / "water.csv"
        p.write_text(text)
        return p

    def test_good(self, tmp_path):
        p = self.write(tmp_path, "wavelength_nm,a,b,Kd\n400,0.1,0.2,0.15\n700,0.6,0.1,0.7\n")
        w = water_from_csv(p)
        assert not w.kd_derived
        np.testing.assert_allclose(w.on_bands(Bands(1)).a, [0.35])

    def test_without_kd_is_derived(self, tmp_path):
        p = self.write(tmp_path, "wavelength_nm,a,b\n400,0.1,0.2\n700,0.6,0.1\n")
        assert water_from_csv(p).kd_derived

    @pytest.mark.parametrize("text,match", [
        ("wavelength_nm,a\n400,0.1\n700,0.2\n", "missing column.*b"),
        ("wavelength_nm,a,b\n400,x,0.2\n700,0.6,0.1\n", "line 2.*'a'.*'x' is not a number"),
        ("wavelength_nm,a,b\n700,0.1,0.2\n400,0.6,0.1\n", "strictly ascend.*400 nm follows 700"),
        ("wavelength_nm,a,b\n400,-0.1,0.2\n700,0.6,0.1\n", "negative a=-0.1 at 400 nm"),
        ("", "empty file"),
    ])
    def test_malformed(self, tmp_path, text, match):
        with pytest.raises(AquaspecError, match=match):
            water_from_csv(self.write(tmp_path, text))

    def test_missing_file(self, tmp_path):
        with pytest.raises(AquaspecError, match="does not exist"):
            water_from_csv(tmp_path / "nope.csv")

    def test_binary_file(self, tmp_path):
        # Item 8: a UnicodeDecodeError traceback before.
        p = tmp_path / "water.csv"
        p.write_bytes(b"wavelength_nm,a,b\n\x89PNG\r\n\x1a\n\xff\xd8")
        with pytest.raises(AquaspecError, match=r"water file '.*water\.csv' is not UTF-8 text"):
            water_from_csv(p)


class TestNonScattering:
    """Item 13: b = 0 is a valid water; the seeds' model renders it, the light
    field refuses it up front saying why and what works."""

    KW = dict(phase="petzold", forward_cone_deg=40.0, cone_spread=True)

    def water(self, tmp_path):
        p = tmp_path / "clear.csv"
        p.write_text("wavelength_nm,a,b\n400,0.02,0\n700,0.6,0\n")
        return water_from_csv(p)

    def test_loads(self, tmp_path):
        w = self.water(tmp_path)
        assert np.all(w.b == 0) and np.all(w.kd > 0)

    def test_light_field_refuses_with_the_way_out(self, tmp_path):
        from aquaspec.transport.lightfield.bake import lightfield_tables
        bw = self.water(tmp_path).on_bands(Bands(4))
        with warnings.catch_warnings():
            warnings.simplefilter("error")   # no RuntimeWarning leaks
            with pytest.raises(AquaspecError, match=r"water 'clear' has scattering b = 0 at "
                                                    r"437\.5 nm, 512\.5 nm, 587\.5 nm, 662\.5 nm "
                                                    r"\(4 of 4 bands\).*--ms-model seeds"):
                lightfield_tables(bw, **self.KW)

    def test_seeds_render_it(self, tmp_path):
        from aquaspec.rendering.api import render
        res = render(water=self.water(tmp_path), bands=4, size=(32, 18), ms_model="seeds",
                     backend="numpy")
        assert np.all(np.isfinite(res.linear_rgb)) and res.linear_rgb.max() > 0

    def test_too_deep_for_the_light_field(self):
        # A seabed at 3000 m in IB: exp(-1259) at 662.5 nm underflows; the
        # message said "check a, b and the phase" (and leaked a RuntimeWarning).
        from aquaspec.transport.lightfield.bake import lightfield_tables
        bw = quiet_load("IB").on_bands(Bands(4))
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(AquaspecError, match=r"depth axis reaches 3000 m .* water 'IB' "
                                                    r"has dimmed the light by exp\(-1258\) at "
                                                    r"662\.5 nm.*above about 1670 m"):
                lightfield_tables(bw, seabed_depth_m=3000.0, seabed_albedo=0.2, **self.KW)
