"""What a live view shows: the built-in scene, a mesh, or an RGB-D photograph.

:class:`ViewScene` is made from :class:`aquaspec.apps.settings.ViewSettings`
when the view starts and holds what stays fixed while it runs:

- ``scene``: a :class:`~aquaspec.scene.mesh.Scene` (``builtin_scene(depth_m)``,
  the camera 1.5 m above the sand; or a mesh file placed in front of the
  camera, in open water or standing on ``settings.seabed``'s plane) or an
  RGB-D photograph's :class:`~aquaspec.scene.gbuffer.GBuffer` (made once);
- ``seabed``: the light field's lower boundary, or None;
- ``flight``: the :class:`~aquaspec.apps.flight.FlightController` bound to
  the water: above the seabed and the floor under the camera
  (:class:`aquaspec.apps.floor.FloorMap`), or for a photograph, seen only
  along its own rays, its view fixed, moving only up and down, with its
  highest point under the surface and its lowest above the seabed.

World units are metres, y up, the water surface at y = 0.
"""

from __future__ import annotations

import numpy as np

from aquaspec.apps.flight import SURFACE_MARGIN_M, FlightController
from aquaspec.apps.floor import FloorMap
from aquaspec.apps.settings import ViewSettings
from aquaspec.errors import AquaspecError
from aquaspec.scene.builtin import builtin_scene
from aquaspec.scene.gbuffer import GBuffer
from aquaspec.scene.load import load_mesh, place_in_front
from aquaspec.scene.rgbd import gbuffer_from_rgbd, load_rgbd
from aquaspec.scene.seabed import Seabed, plane_radius_m, with_seabed_plane


class ViewScene:
    """The scene, seabed and flight of a live view (module docstring).

    Parameters
    ----------
    settings : ViewSettings
    say : callable
        Called with a short message as slow steps start.
    """

    def __init__(self, settings: ViewSettings, say):
        self.settings = s = settings
        self._sizes: dict = {}      # an RGB-D photograph at each render size
        if s.rgbd is not None:
            self._photograph(s, say)
            return
        if s.mesh is None:
            self.scene, start = builtin_scene(s.depth_m, width=s.width, height=s.height)
        else:
            say(f"loading {s.mesh} ...")
            self.scene = place_in_front(load_mesh(s.mesh, albedo=s.albedo), depth_m=s.depth_m,
                                        width=s.width, height=s.height)
            start = self.scene.camera
            if s.seabed is not None:
                # Out to 0.9 of the far plane: no water the panel offers shows its edge.
                radius = plane_radius_m([0.0], below_camera_m=s.seabed[0] - s.depth_m,
                                        far_m=start.far)
                self.scene = with_seabed_plane(self.scene, Seabed(*s.seabed), start, radius)
        self.seabed = self.scene.seabed
        self.flight = FlightController(
            start, seabed_depth_m=None if self.seabed is None else self.seabed.depth_m,
            floor=FloorMap.from_scene(self.scene))

    def _photograph(self, s: ViewSettings, say) -> None:
        say(f"reading the RGB-D photograph {s.rgbd[0]} ...")
        photo = gbuffer_from_rgbd(*load_rgbd(s.rgbd[0], s.rgbd[1]), s.rgbd[2],
                                  camera_depth_m=s.depth_m)
        w, h = photo.camera.width, photo.camera.height
        if abs(s.width / s.height - w / h) > 0.01 * w / h:
            raise AquaspecError(f"the photograph is {w}x{h}; a {s.width}x{s.height} view "
                                "would stretch it: accepted, a size of its aspect ratio")
        self.scene = photo = photo.resized(s.width, s.height)
        self.seabed = None if s.seabed is None else Seabed(*s.seabed)
        heights = photo.positions()[photo.hit][:, 1] - photo.camera.position[1]
        rise = max(0.0, float(np.max(heights, initial=-np.inf)))
        drop = max(0.0, -float(np.min(heights, initial=np.inf)))
        self.flight = FlightController(
            photo.camera, fixed_view=True, surface_margin_m=SURFACE_MARGIN_M + rise,
            seabed_depth_m=None if self.seabed is None else self.seabed.depth_m - drop)

    def at_size(self, width: int, height: int):
        """What a frame of ``width`` x ``height`` shows: the scene, or the
        photograph's G-buffer at that size (made once per size)."""
        if not isinstance(self.scene, GBuffer):
            return self.scene
        if (width, height) not in self._sizes:
            self._sizes[(width, height)] = self.scene.resized(width, height)
        return self._sizes[(width, height)]

    def describe(self) -> dict:
        """What the view shows, for a sidecar (as ``aquaspec render`` says it)."""
        s = self.settings
        if s.rgbd is not None:
            out = {"kind": "rgbd", "rgbd_image": s.rgbd[0], "rgbd_depth": s.rgbd[1],
                   "intrinsics": list(s.rgbd[2])}
        else:
            out = {"kind": "mesh", "mesh": s.mesh} if s.mesh else {"kind": "builtin"}
        if s.seabed is not None:
            out["seabed"] = {"depth_m": s.seabed[0], "albedo": s.seabed[1]}
        return out
