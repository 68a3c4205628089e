"""The live view's on-screen text: lines drawn into a small RGBA image.

:func:`text_overlay` draws lines of text (Pillow's default font) in white on
a translucent dark panel, an (h, w, 4) uint8 image with straight alpha that
:meth:`aquaspec.gpu.passes.present.PresentPass.set_overlay` draws over the
window's top-left corner. It is drawn on the CPU only when the text changes
(a few times per second), a few kilobytes uploaded; the frame itself never
leaves the GPU.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from aquaspec.errors import AquaspecError

#: Text height in pixels, the panel's margin and its opacity (0-255).
FONT_PX, MARGIN_PX, PANEL_ALPHA = 13, 4, 160


@lru_cache(maxsize=4)
def _font(size_px: int):
    return ImageFont.load_default(size=size_px)


def text_overlay(lines, *, font_px: int = FONT_PX, max_width: int | None = None) -> np.ndarray:
    """``lines`` (strings) as an RGBA8 panel, (h, w, 4) uint8, straight alpha.

    ``max_width``: crop the panel to at most this many pixels (the window's width).
    """
    lines = [str(line) for line in lines]
    if not lines:
        raise AquaspecError("an overlay needs at least one line of text")
    font = _font(int(font_px))
    probe = ImageDraw.Draw(Image.new("RGBA", (1, 1)))
    widths = [probe.textbbox((0, 0), line, font=font)[2] for line in lines]
    step = int(round(font_px * 1.3))
    w = max(widths) + 2 * MARGIN_PX
    h = step * len(lines) + 2 * MARGIN_PX
    if max_width is not None:
        w = max(1, min(w, int(max_width)))
    panel = Image.new("RGBA", (w, h), (0, 0, 0, PANEL_ALPHA))
    draw = ImageDraw.Draw(panel)
    for i, line in enumerate(lines):
        draw.text((MARGIN_PX, MARGIN_PX + i * step), line, font=font, fill=(255, 255, 255, 255))
    return np.asarray(panel, dtype=np.uint8).copy()
