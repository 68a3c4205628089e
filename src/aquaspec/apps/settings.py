"""What a live view shows: :class:`ViewSettings`, the physics and the image size.

A frozen, hashable dataclass checked when made (each bad value named with what
is accepted): the live view keys its spectral setups by it, and the controls
panel (:mod:`aquaspec.apps.controls`) makes a changed copy with
``dataclasses.replace`` for every change, refused there if a value is wrong.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from aquaspec.apps.flight import SURFACE_MARGIN_M
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG
from aquaspec.light.waves import WIND_RANGE
from aquaspec.medium.phase import PHASE_FUNCTIONS
from aquaspec.medium.water import DEFAULT_SOURCE, SOURCES
from aquaspec.rendering.appearance import check_ms_model
from aquaspec.rendering.setup import SURFACE_MODELS
from aquaspec.scene.camera import check_size
from aquaspec.scene.seabed import Seabed
from aquaspec.transport.models import DEFAULT_MS_MODEL

#: Below this sun elevation (degrees) the light is the overcast sky.
OVERCAST_BELOW_DEG = 1.0


@dataclasses.dataclass(frozen=True)
class ViewSettings:
    """What a live view shows (checked when made).

    ``sun_elevation_deg`` below :data:`OVERCAST_BELOW_DEG` is the overcast
    sky; ``wind`` 0 a flat surface, else a wind sea (m/s, within
    :data:`aquaspec.light.waves.WIND_RANGE`) whose caustics move with the
    frames' time (it needs the sun).
    """

    width: int = 640
    height: int = 360
    water: str = "IB"
    #: Where a Jerlov type's data come from (:data:`aquaspec.medium.water.SOURCES`).
    water_source: str = DEFAULT_SOURCE
    depth_m: float = 5.0
    bands: int = 8
    sensor: str = "human"
    camspec: object = None
    ms_model: str = DEFAULT_MS_MODEL
    cone_spread: bool | None = None
    spread_scattering: str = "single"
    #: The light field's phase function (:data:`aquaspec.medium.phase.PHASE_FUNCTIONS`)
    #: and its parameters, e.g. ``(("g", 0.92),)`` for ``hg``.
    phase: str = "petzold"
    phase_params: tuple = ()
    sun_elevation_deg: float = 0.0
    sun_azimuth_deg: float = DEFAULT_SUN_AZIMUTH_DEG
    wind: float = 0.0
    #: A mesh file (OBJ/PLY/glTF/GLB/STL/OFF) shown instead of the built-in
    #: scene, placed 3 m in front of the camera in open water
    #: (:func:`aquaspec.scene.load.place_in_front`); None: the built-in scene.
    mesh: str | None = None
    #: An RGB-D photograph shown instead of a scene: ``(image path, depth path,
    #: (fx, fy, cx, cy))`` as :func:`aquaspec.scene.rgbd.load_rgbd` and
    #: :func:`~aquaspec.scene.rgbd.gbuffer_from_rgbd` take them; the view is
    #: the photograph's own (the camera moves only up and down).
    rgbd: tuple | None = None
    #: The water surface seen from below (:data:`aquaspec.rendering.setup.SURFACE_MODELS`);
    #: the seeds' model, which has no top boundary to change, is always shown
    #: with the index-matched one.
    surface: str = "flat"
    #: Linear RGB albedo replacing the mesh's colours (as ``render(albedo=)``).
    albedo: tuple | None = None
    #: ``(depth_m, albedo)``: a flat grey seabed, the light field's lower
    #: boundary, on which a mesh stands (a plane out to 0.9 of the camera's far
    #: plane); None: the built-in scene's sand, or deep water under a mesh or
    #: a photograph.
    seabed: tuple | None = None

    def __post_init__(self):
        check_size(self.width, self.height)
        d = float(self.depth_m)
        if not (np.isfinite(d) and d >= SURFACE_MARGIN_M):
            raise AquaspecError(
                f"camera depth {self.depth_m!r} m: the live view flies at least "
                f"{SURFACE_MARGIN_M:g} m under the surface (a camera above the sea or at the "
                "waterline is not flown live: `aquaspec render --camera-height` draws it); "
                f"accepted: {SURFACE_MARGIN_M:g} m or deeper")
        if self.surface not in SURFACE_MODELS:
            raise AquaspecError(f"surface {self.surface!r}; accepted: "
                                f"{', '.join(SURFACE_MODELS)}")
        if self.albedo is not None:
            if self.mesh is None:
                raise AquaspecError("albedo replaces a mesh's colours: it needs a mesh")
            albedo = tuple(float(v) for v in self.albedo)
            if len(albedo) != 3 or not all(0.0 <= v <= 1.0 for v in albedo):
                raise AquaspecError(f"albedo {self.albedo!r}; accepted: three numbers in [0, 1]")
            object.__setattr__(self, "albedo", albedo)
        if self.seabed is not None:
            if self.mesh is None and self.rgbd is None:
                raise AquaspecError("the built-in scene has its own sand: a seabed goes with a "
                                    "mesh or an RGB-D photograph")
            depth, grey = (float(v) for v in self.seabed)
            Seabed(depth, grey)                 # checked there
            if depth <= self.depth_m:
                raise AquaspecError(f"the seabed at {depth:g} m is not below the camera at "
                                    f"{self.depth_m:g} m; accepted: a deeper seabed")
            object.__setattr__(self, "seabed", (depth, grey))
        if self.rgbd is not None:
            if self.mesh is not None:
                raise AquaspecError("a view shows a mesh or an RGB-D photograph, not both")
            if len(self.rgbd) != 3 or len(tuple(self.rgbd[2])) != 4:
                raise AquaspecError(f"rgbd={self.rgbd!r}; accepted: (image path, depth path, "
                                    "(fx, fy, cx, cy))")
            object.__setattr__(self, "rgbd", (str(self.rgbd[0]), str(self.rgbd[1]),
                                              tuple(float(v) for v in self.rgbd[2])))
        object.__setattr__(self, "ms_model", check_ms_model(self.ms_model))
        e, w = self.sun_elevation_deg, self.wind
        if not (np.isfinite(e) and 0.0 <= e <= 90.0):
            raise AquaspecError(f"sun elevation {e!r} deg; accepted: 0 (overcast) to 90")
        if not np.isfinite(self.sun_azimuth_deg):
            raise AquaspecError(f"sun azimuth {self.sun_azimuth_deg!r} deg; accepted: a "
                                "finite angle")
        if not (np.isfinite(w) and (w == 0 or WIND_RANGE[0] <= w <= WIND_RANGE[1])):
            raise AquaspecError(f"wind {w!r} m/s; accepted: 0 (a flat surface) or "
                                f"{WIND_RANGE[0]} to {WIND_RANGE[1]}")
        if w > 0 and e < OVERCAST_BELOW_DEG:
            raise AquaspecError(f"wind {w:g} m/s focuses the sun's beam into caustics: it "
                                f"needs a sun elevation of at least {OVERCAST_BELOW_DEG:g} "
                                f"deg, not {e:g}")
        if self.water_source not in SOURCES:
            raise AquaspecError(f"water source {self.water_source!r}; accepted: "
                                f"{', '.join(SOURCES)}")
        if self.phase not in PHASE_FUNCTIONS:
            raise AquaspecError(f"phase function {self.phase!r}; accepted: "
                                f"{', '.join(PHASE_FUNCTIONS)}")
        if self.spread_scattering not in ("single", "multiple"):
            raise AquaspecError(f"spread_scattering={self.spread_scattering!r}; accepted: "
                                "'single', 'multiple'")

    @property
    def has_sun(self) -> bool:
        return self.sun_elevation_deg >= OVERCAST_BELOW_DEG

    def describe(self) -> dict:
        """The settings for a sidecar (JSON-ready)."""
        out = dataclasses.asdict(self)
        out["camspec"] = None if self.camspec is None else str(self.camspec)
        out["mesh"] = None if self.mesh is None else str(self.mesh)
        if self.rgbd is not None:
            out["rgbd"] = {"image": self.rgbd[0], "depth": self.rgbd[1],
                           "intrinsics": list(self.rgbd[2])}
        out["light"] = "sun-sky" if self.has_sun else "overcast"
        return out
