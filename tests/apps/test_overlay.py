"""The live view's on-screen text (aquaspec.apps.overlay), without a GPU."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.apps.overlay import PANEL_ALPHA, text_overlay
from aquaspec.errors import AquaspecError


def test_text_overlay_is_a_translucent_panel_with_white_text():
    panel = text_overlay(["12.3 fps", "depth 5.00 m"])
    assert panel.dtype == np.uint8 and panel.ndim == 3 and panel.shape[2] == 4
    assert panel.shape[0] > 2 * 13                # two lines
    assert panel[0, 0, 3] == PANEL_ALPHA and panel[0, 0, :3].max() == 0
    assert (panel[..., :3].min(axis=-1) == 255).sum() > 20    # text pixels
    assert text_overlay(["x" * 200], max_width=50).shape[1] == 50
    with pytest.raises(AquaspecError, match="at least one line"):
        text_overlay([])
