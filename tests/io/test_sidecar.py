"""JSON sidecars and the parameters' JSON (aquaspec.io.sidecar, aquaspec.io.metadata)."""

import json

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.io import metadata, sidecar
from support.output_data import render_params, listing


class TestSidecar:
    def test_round_trip_converts_numpy(self, tmp_path):
        params = render_params()
        params["bands"] = Bands(16)
        p = sidecar.write_sidecar(tmp_path / "r.png", params)
        assert p == tmp_path / "r.png.json"
        doc = json.loads(p.read_text())
        assert doc == sidecar.read_sidecar(tmp_path / "r.png")
        assert doc["depth_m"] == 5.0 and isinstance(doc["n_bands"], int)
        assert doc["exposure"] == {"mode": "auto", "ev": 3.25}
        np.testing.assert_allclose(doc["band_centers_nm"], params["band_centers_nm"], rtol=0)
        assert doc["bands"] == {"n": 16, "lo_nm": 400.0, "hi_nm": 700.0}
        assert doc["sun"] is True and doc["adapter"] is None
        assert doc["aquaspec_version"] == metadata.aquaspec_version()
        assert doc["timestamp"].endswith("+00:00")

    def test_given_version_and_timestamp_are_kept(self, tmp_path):
        p = sidecar.write_sidecar(tmp_path / "r.png", {"timestamp": "2024-01-01T00:00:00+00:00",
                                                      "aquaspec_version": "9.9"})
        doc = json.loads(p.read_text())
        assert doc["timestamp"].startswith("2024") and doc["aquaspec_version"] == "9.9"

    @pytest.mark.parametrize("where,value", [
        ("depth_m", np.float64("nan")),
        ("camera", {"fov_y_deg": float("inf")}),
        ("band_centers_nm", np.array([400.0, np.nan])),
    ])
    def test_nan_refused_with_key(self, tmp_path, where, value):
        params = render_params()
        params[where] = value
        with pytest.raises(AquaspecError) as e:
            sidecar.write_sidecar(tmp_path / "r.png", params)
        assert where in str(e.value) and "NaN" in str(e.value)
        assert listing(tmp_path) == []

    def test_unsupported_type(self, tmp_path):
        with pytest.raises(AquaspecError, match=r"params\['obj'\].*object"):
            sidecar.write_sidecar(tmp_path / "r.png", {"obj": object()})


def test_recorded_version_is_the_package_version():
    import aquaspec
    assert metadata.aquaspec_version() == aquaspec.__version__
