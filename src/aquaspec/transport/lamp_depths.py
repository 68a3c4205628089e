"""The distances a lamp's veil columns and glow table are kept at.

Metres from the camera (the veil's columns, :mod:`aquaspec.transport.lamp_froxels`)
or from the lamp (the glow's table, :mod:`aquaspec.transport.lamp_halo`): 0,
then geometric from a few centimetres to :data:`DEPTH_MAX_M` (steps of 14 %
of the distance), then infinity; and the fractional index of any distance
among them, one logarithm.
"""

from __future__ import annotations

import numpy as np

#: Distances the columns are read at: 0, then ``LAMP_DEPTHS - 1`` geometric
#: from DEPTH_M0 (offset) to DEPTH_MAX_M, then infinity (:func:`depth_boundaries`).
LAMP_DEPTHS = 64
DEPTH_M0 = 0.05
DEPTH_MAX_M = 200.0


def depth_step(depths: int = LAMP_DEPTHS) -> float:
    """``h``: the logarithmic step of :func:`depth_boundaries`."""
    return float(np.log1p(DEPTH_MAX_M / DEPTH_M0) / (depths - 1))


def depth_boundaries(depths: int = LAMP_DEPTHS) -> np.ndarray:
    """The distances the columns are read at, (depths + 1,), m:
    ``t_j = DEPTH_M0 (exp(j h) - 1)`` for ``j < depths`` (``t_0 = 0``,
    ``t_{depths-1} = DEPTH_MAX_M``) and ``inf`` last."""
    j = np.arange(depths)
    return np.append(DEPTH_M0 * np.expm1(j * depth_step(depths)), np.inf)


def depth_coordinate(s, depths: int = LAMP_DEPTHS) -> np.ndarray:
    """The index ``x`` in [0, depths] of distances ``s`` (m, ``inf`` allowed)
    among :func:`depth_boundaries`: ``ln(1 + s / DEPTH_M0) / h`` up to
    DEPTH_MAX_M, then ``depths - 1 + (1 - DEPTH_MAX_M / s)`` (``depths`` at infinity)."""
    s = np.maximum(np.asarray(s, dtype=float), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        near = np.log1p(np.minimum(s, DEPTH_MAX_M) / DEPTH_M0) / depth_step(depths)
        far = depths - 1 + (1.0 - DEPTH_MAX_M / np.maximum(s, DEPTH_MAX_M))
    return np.where(s <= DEPTH_MAX_M, near, far)
