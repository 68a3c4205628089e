"""The display transform's settings on the GPU: the Python side of ``tonemap.wgsl``.

White balance, colour matrix and exposure are folded into one 3x3 matrix
``2**EV * M @ diag(gains)`` (:func:`folded_matrix`; all three are linear),
then each pixel is tone mapped (:data:`TONEMAP_IDS`), sRGB encoded and rounded
to 8 bits: the GPU twin of :func:`aquaspec.colour.display.to_display` for 8-bit
output. Used by the display pass (:mod:`aquaspec.gpu.passes.display`) and,
fused into their last step, by both shading passes
(:class:`aquaspec.gpu.shading_output.ShadingOutput`).
"""

from __future__ import annotations

import numpy as np

from aquaspec.colour import display
from aquaspec.errors import AquaspecError
from aquaspec.gpu.layout import UniformLayout

#: Tone maps with a WGSL implementation, by id (``tonemap()`` in tonemap.wgsl);
#: the same names and curves as :data:`aquaspec.colour.display.TONEMAPS`.
TONEMAP_IDS = {"none": 0, "filmic": 1, "hable": 2, "reinhard": 3}

#: Uniforms of the display transform: the folded colour matrix rows and the tone map.
DISPLAY_LAYOUT = UniformLayout("DisplayParams", [
    ("m0", "vec3<f32>"), ("width", "u32"),
    ("m1", "vec3<f32>"), ("height", "u32"),
    ("m2", "vec3<f32>"), ("tonemap", "u32"),
])


def display_template(tonemap: str | None) -> dict:
    """Template values of a shader with the display transform: the uniform struct,
    whether it is applied (``tonemap`` None: linear output) and the tone map id."""
    return dict(display_struct=DISPLAY_LAYOUT.wgsl(), display_struct_name=DISPLAY_LAYOUT.name,
                display="false" if tonemap is None else "true",
                tonemap_id=TONEMAP_IDS[tonemap or "none"])


def folded_matrix(exposure_ev, gains=(1.0, 1.0, 1.0), matrix=None) -> np.ndarray:
    """``2**EV * M @ diag(gains)`` (3, 3), float64: the transform's whole linear step."""
    ev = display.check_ev(exposure_ev)
    g = np.asarray(gains, dtype=np.float64)
    if g.shape != (3,) or not np.all(np.isfinite(g)) or np.any(g <= 0):
        raise AquaspecError(f"white-balance gains {gains!r}; accepted: three finite, "
                            "positive numbers")
    m = np.eye(3) if matrix is None else np.asarray(matrix, dtype=np.float64)
    if m.shape != (3, 3) or not np.all(np.isfinite(m)):
        raise AquaspecError(f"colour matrix of shape {m.shape} is not accepted; accepted: "
                            "a finite 3x3 matrix, or None for the identity")
    return 2.0 ** ev * m * g[None, :]


def display_uniform(width: int, height: int, *, exposure_ev, white_balance_gains=(1.0, 1.0, 1.0),
                    matrix=None, tonemap="filmic") -> tuple[bytes, dict]:
    """The :data:`DISPLAY_LAYOUT` bytes of these settings for a ``width`` x ``height``
    image, and the settings as a dict (for sidecars); checks them."""
    if not isinstance(tonemap, str) or tonemap not in TONEMAP_IDS:
        raise AquaspecError(f"unknown tone map {tonemap!r}; accepted: "
                            + ", ".join(repr(k) for k in TONEMAP_IDS))
    m = folded_matrix(exposure_ev, white_balance_gains, matrix).astype(np.float32)
    if not np.all(np.isfinite(m)):
        raise AquaspecError(f"exposure EV {exposure_ev!r} with these gains overflows "
                            "float32 on the GPU; accepted: a smaller exposure")
    data = DISPLAY_LAYOUT.pack(m0=m[0], m1=m[1], m2=m[2], width=width, height=height,
                               tonemap=TONEMAP_IDS[tonemap])
    settings = {"exposure_ev": float(exposure_ev),
                "white_balance_gains": [float(g) for g in white_balance_gains],
                "matrix": None if matrix is None else np.asarray(matrix, float).tolist(),
                "tonemap": tonemap}
    return data, settings
