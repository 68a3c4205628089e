"""The validation scene: a ColorChecker board in open water.

As in the thesis's validation (chapter 6.1): the camera looks horizontally
at a board 3 m away; behind and around it is open water. The board is the
24 ColorChecker patches (measured spectra) on a black backing, each patch
0.2 m wide with 0.25 m pitch, facing the camera.

A second view (``view="down"``, :data:`VIEWS`) checks the models on other
directions: the camera looks down by :data:`DOWN_PITCH_DEG` at the board
lying flat (facing up, lit by the downwelling light) 3 m away along the
view; around it the camera sees the open water below.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import binary_erosion

from aquaspec.colour.reflectance import Reflectance, colorchecker
from aquaspec.errors import AquaspecError
from aquaspec.scene.camera import Camera
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.scene.seabed import Seabed

BOARD_DISTANCE_M = 3.0
PATCH_SIZE_M = 0.2
PATCH_PITCH_M = 0.25
BACKING_REFLECTANCE = 0.03
#: Index of the 18 %-like grey patch ("neutral 5") in chart order.
GREY_PATCH = 21
#: The views of the board: ``"level"`` (the thesis's, facing the camera) and
#: ``"down"`` (lying flat, seen from above at DOWN_PITCH_DEG).
VIEWS = ("level", "down")
DOWN_PITCH_DEG = 45.0


def board_scene(depth_m: float, *, width: int = 96, height: int = 72,
                fov_y_deg: float = 40.0, distance_m: float = BOARD_DISTANCE_M,
                seabed_below_m: float | None = None, seabed_albedo: float = 0.2,
                view: str = "level"):
    """The validation scene at camera depth ``depth_m``; returns (Scene, Camera).

    Patch ``k`` of the chart uses material ``k``; the backing uses material 24.
    With ``seabed_below_m`` a flat grey Lambertian seabed (albedo
    ``seabed_albedo``, material 25, 1 km square) lies that far below the
    camera, and ``scene.seabed`` names it as the light field's lower boundary
    (it must lie below the board: with ``view="down"`` the board is
    ``distance_m sin(DOWN_PITCH_DEG)`` below the camera). ``view``: one of
    :data:`VIEWS` (module docstring).
    """
    if view not in VIEWS:
        raise AquaspecError(f"view={view!r}; accepted: {', '.join(VIEWS)}")
    cam_pos = np.array([0.0, -float(depth_m), 0.0])
    pitch = np.radians(DOWN_PITCH_DEG) if view == "down" else 0.0
    forward = np.array([0.0, -np.sin(pitch), -np.cos(pitch)])
    camera = Camera.look_at(cam_pos, cam_pos + forward, width=width, height=height,
                            fov_y_deg=fov_y_deg)
    scene = Scene(camera=camera)
    # The board's frame: its centre, its normal (towards the camera, or up),
    # and its "up" in its own plane (the chart's first row that way).
    centre = cam_pos + distance_m * forward
    normal = -forward if view == "level" else np.array([0.0, 1.0, 0.0])
    across = np.array([1.0, 0.0, 0.0])
    up = np.cross(normal, across)

    def quad(cx, cy, lift, half_w, half_h):
        c = centre + cx * across + cy * up + lift * normal
        v = np.array([c - half_w * across - half_h * up, c + half_w * across - half_h * up,
                      c + half_w * across + half_h * up, c - half_w * across + half_h * up])
        return v, np.array([[0, 1, 2], [0, 2, 3]])

    for k, patch in enumerate(colorchecker()):
        scene.add_material(patch)
        row, col = divmod(k, 6)
        v, f = quad((col - 2.5) * PATCH_PITCH_M, (1.5 - row) * PATCH_PITCH_M, 0.002,
                    PATCH_SIZE_M / 2, PATCH_SIZE_M / 2)
        scene.add(Mesh(v, f, np.tile(normal, (4, 1)), k, name=f"patch {k:02d}"))
    back = scene.add_material(Reflectance.constant(BACKING_REFLECTANCE, "board backing"))
    v, f = quad(0.0, 0.0, 0.0, 3 * PATCH_PITCH_M + 0.05, 2 * PATCH_PITCH_M + 0.05)
    scene.add(Mesh(v, f, np.tile(normal, (4, 1)), back, name="backing"))
    if seabed_below_m is not None:
        below = float(seabed_below_m)
        lowest = float(cam_pos[1] - v[:, 1].min())
        if not (np.isfinite(below) and below > max(lowest, 0.0)):
            raise AquaspecError(f"seabed_below_m={seabed_below_m!r}; accepted: a distance "
                                f"> {max(lowest, 0.0):g} m below the camera (under the board)")
        sand = Reflectance.constant(float(seabed_albedo), "seabed")
        scene.seabed = Seabed(float(depth_m) + below, sand)
        y = cam_pos[1] - below
        half = 500.0
        v = np.array([[-half, y, -half], [half, y, -half], [half, y, half], [-half, y, half]])
        scene.add(Mesh(v, np.array([[0, 2, 1], [0, 3, 2]]), np.tile([0.0, 1.0, 0.0], (4, 1)),
                       scene.add_material(sand), name="seabed"))
    return scene, camera


def masks(gbuffer, erode: int = 1) -> dict:
    """Pixel masks: ``patches`` (24, H, W), ``background`` (open water), ``grey``."""
    out = []
    for k in range(24):
        m = gbuffer.hit & (gbuffer.material == k)
        out.append(binary_erosion(m, iterations=erode) if erode else m)
    bg = ~gbuffer.hit
    bg = binary_erosion(bg, iterations=erode) if erode else bg
    patches = np.array(out)
    return {"patches": patches, "background": bg, "grey": patches[GREY_PATCH]}
