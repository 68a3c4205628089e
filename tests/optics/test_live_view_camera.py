"""`aquaspec view --camera-model`: the live view's frames through the camera."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from aquaspec.cli import main
from aquaspec.errors import AquaspecError

pytestmark = pytest.mark.gpu


def test_offscreen_frames_through_a_flat_port(tmp_path, capsys):
    out = tmp_path / "rec"
    assert main(["view", "--offscreen", "--frames", "2", "--size", "96x54", "--bands", "3",
                 "--sensor", "nikon5100-npl", "--camera-model", "dslr-flat-port:seed=2",
                 "--record", str(out)]) == 0
    frames = [np.asarray(Image.open(out / f"frame_0000{i}.png"), float) for i in range(2)]
    assert frames[0].shape == (54, 96, 3)
    # A new noise every frame: the two frames of one pose differ pixel by pixel.
    assert np.mean(np.abs(frames[0] - frames[1]) > 0) > 0.3
    assert "camera+display" in capsys.readouterr().out


def test_flat_port_refused_for_a_photograph(tmp_path):
    from aquaspec.apps.settings import ViewSettings
    from aquaspec.apps.view import run_view
    rgbd = (np.full((8, 8, 3), 0.5), np.full((8, 8), 2.0), (8.0, 8.0, 4.0, 4.0))
    with pytest.raises(AquaspecError, match="dome port"):
        run_view(ViewSettings(width=8, height=8, bands=3, rgbd=rgbd), offscreen=True, frames=1,
                 camera_model="dslr-flat-port")
    with pytest.raises(AquaspecError, match="accepted: dslr-flat-port"):
        run_view(ViewSettings(width=8, height=8, bands=3), offscreen=True, frames=1,
                 camera_model="gopro")
