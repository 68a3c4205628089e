"""Refusing NaN and infinity: nothing non-finite is quietly written or displayed.

:func:`check_finite` guards every image on its way out, the linear files
(:mod:`aquaspec.io.linear`) and the display chain
(:mod:`aquaspec.colour.display`) alike.
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError


def check_finite(arr, what="image") -> None:
    """Raise :class:`AquaspecError` if ``arr`` holds NaN or infinity.

    The message gives how many values are bad and the index of the first one,
    so the pass that produced them can be found; nothing non-finite is ever
    quietly clipped into an output image.
    """
    arr = np.asarray(arr)
    bad = ~np.isfinite(arr)
    n_bad = int(np.count_nonzero(bad))
    if n_bad:
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        value = arr[first]
        where = (f"(row {first[0]}, column {first[1]}, channel {first[2]})"
                 if arr.ndim == 3 else f"index {first}")
        raise AquaspecError(
            f"{what} has {n_bad} non-finite value(s) of {arr.size}; the first is "
            f"{value!r} at {where}; accepted: finite values only")
