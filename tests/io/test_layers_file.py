"""The image-formation layers' file (aquaspec.io.layers_file): EXR or NPZ round
trips, and what is refused before anything is written."""

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.io import layers_file
from aquaspec.io.save import save_image


class TestLayersFile:
    def layers(self):
        rng = np.random.default_rng(0)
        out = {k: rng.random((5, 7, 3)).astype(np.float32) for k in layers_file.COLOUR_LAYERS}
        out["range_m"] = rng.random((5, 7)).astype(np.float32) * 10
        return out

    @pytest.mark.parametrize("suffix", [".exr", ".npz"])
    def test_round_trip(self, tmp_path, suffix):
        src = self.layers()
        p = layers_file.write_layers(tmp_path / f"x{suffix}", src, {"water": {"name": "IB"}})
        got, meta = layers_file.read_layers(p)
        for k in layers_file.LAYER_NAMES:
            np.testing.assert_array_equal(got[k], src[k])
        assert meta["water"] == {"name": "IB"} and "aquaspec_version" in meta

    def test_refuses_bad_layers(self, tmp_path):
        src = self.layers()
        src["direct"][1, 2, 0] = np.nan
        with pytest.raises(AquaspecError, match="layer 'direct' has NaN"):
            layers_file.write_layers(tmp_path / "x.npz", src)
        assert list(tmp_path.iterdir()) == []
        with pytest.raises(AquaspecError, match="accepted suffixes|accepted: .exr, .npz"):
            layers_file.write_layers(tmp_path / "x.tif", self.layers())
        bad = self.layers()
        del bad["albedo"]
        with pytest.raises(AquaspecError, match=r"layers lack \['albedo'\]"):
            layers_file.write_layers(tmp_path / "x.npz", bad)
        bad = self.layers()
        bad["range_m"] = bad["range_m"][:4]
        with pytest.raises(AquaspecError, match="layer 'range_m' is"):
            layers_file.write_layers(tmp_path / "x.npz", bad)
        with pytest.raises(AquaspecError, match="no layers file"):
            layers_file.read_layers(tmp_path / "none.npz")

    def test_save_image_needs_layers(self, tmp_path):
        with pytest.raises(AquaspecError, match="without layers"):
            save_image(tmp_path / "a.png", np.zeros((2, 2, 3), np.uint8),
                       layers_path=tmp_path / "a.npz")
