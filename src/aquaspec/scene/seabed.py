"""The seabed as the light field's lower boundary: depth and reflectance."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError


@dataclass(frozen=True)
class Seabed:
    """A flat Lambertian seabed as the light field's lower boundary.

    ``depth_m`` (> 0, m below the surface) and ``reflectance``: an object
    with ``on_bands(bands)`` (:class:`aquaspec.colour.reflectance.Reflectance`, e.g.
    the built-in scene's sand) or a number in [0, 1] (grey). The light field
    (``lightfield_tables(seabed_depth_m=, seabed_albedo=)``,
    :mod:`aquaspec.transport.lightfield.bake`) then carries the light the seabed
    reflects up (SPEC: leaving it out made targets 9-15 % too dark in Jerlov
    I); the seabed *mesh* a scene draws is separate geometry.
    """

    depth_m: float
    reflectance: object = 0.2

    def __post_init__(self):
        d = self.depth_m
        if isinstance(d, bool) or not isinstance(d, (int, float, np.number)) \
                or not np.isfinite(d) or d <= 0:
            raise AquaspecError(f"seabed depth_m={d!r}; accepted: a finite depth > 0 m")
        r = self.reflectance
        if not hasattr(r, "on_bands"):
            if isinstance(r, bool) or not isinstance(r, (int, float, np.number)) \
                    or not 0.0 <= float(r) <= 1.0:
                raise AquaspecError(f"seabed reflectance={r!r}; accepted: a Reflectance or "
                                    "a number in [0, 1]")

    def albedo_on(self, bands) -> np.ndarray:
        """Band albedo (n,) on ``bands``."""
        r = self.reflectance
        if hasattr(r, "on_bands"):
            return np.asarray(r.on_bands(bands), dtype=float)
        return np.full(bands.n, float(r))

    def describe(self) -> dict:
        r = self.reflectance
        return {"depth_m": float(self.depth_m),
                "reflectance": getattr(r, "name", None) if hasattr(r, "on_bands") else float(r)}
