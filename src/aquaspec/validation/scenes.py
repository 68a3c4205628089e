"""The validation scene: a ColorChecker board in open water.

As in the thesis's validation (chapter 6.1): the camera looks horizontally
at a board 3 m away; behind and around it is open water. The board is the
24 ColorChecker patches (measured spectra) on a black backing, each patch
0.2 m wide with 0.25 m pitch, facing the camera.
"""

from __future__ import annotations

import numpy as np

from ..camera import Camera
from ..reflectance import Reflectance, colorchecker
from ..scene.mesh import Mesh, Scene

BOARD_DISTANCE_M = 3.0
PATCH_SIZE_M = 0.2
PATCH_PITCH_M = 0.25
BACKING_REFLECTANCE = 0.03
#: Index of the 18 %-like grey patch ("neutral 5") in chart order.
GREY_PATCH = 21


def _quad(cx, cy, z, half_w, half_h):
    v = np.array([[cx - half_w, cy - half_h, z], [cx + half_w, cy - half_h, z],
                  [cx + half_w, cy + half_h, z], [cx - half_w, cy + half_h, z]])
    return v, np.array([[0, 1, 2], [0, 2, 3]])


def board_scene(depth_m: float, *, width: int = 96, height: int = 72,
                fov_y_deg: float = 40.0, distance_m: float = BOARD_DISTANCE_M,
                seabed_below_m: float | None = None, seabed_albedo: float = 0.2):
    """The validation scene at camera depth ``depth_m``; returns (Scene, Camera).

    Patch ``k`` of the chart uses material ``k``; the backing uses material 24.
    With ``seabed_below_m`` a flat grey Lambertian seabed (albedo
    ``seabed_albedo``, material 25, 1 km square) lies that far below the
    camera, and ``scene.seabed`` names it as the light field's lower boundary.
    """
    cam_pos = np.array([0.0, -float(depth_m), 0.0])
    camera = Camera.look_at(cam_pos, cam_pos + [0.0, 0.0, -1.0], width=width, height=height,
                            fov_y_deg=fov_y_deg)
    scene = Scene(camera=camera)
    normal = np.array([0.0, 0.0, 1.0])
    z = -distance_m
    for k, patch in enumerate(colorchecker()):
        scene.add_material(patch)
        row, col = divmod(k, 6)
        v, f = _quad((col - 2.5) * PATCH_PITCH_M, cam_pos[1] + (1.5 - row) * PATCH_PITCH_M,
                     z + 0.002, PATCH_SIZE_M / 2, PATCH_SIZE_M / 2)
        scene.add(Mesh(v, f, np.tile(normal, (4, 1)), k, name=f"patch {k:02d}"))
    back = scene.add_material(Reflectance.constant(BACKING_REFLECTANCE, "board backing"))
    v, f = _quad(0.0, cam_pos[1], z, 3 * PATCH_PITCH_M + 0.05, 2 * PATCH_PITCH_M + 0.05)
    scene.add(Mesh(v, f, np.tile(normal, (4, 1)), back, name="backing"))
    if seabed_below_m is not None:
        from ..errors import AquaspecError
        from ..lightfield import Seabed
        below = float(seabed_below_m)
        if not (np.isfinite(below) and below > 0):
            raise AquaspecError(f"seabed_below_m={seabed_below_m!r}; accepted: a distance "
                                "> 0 m below the camera")
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
    from scipy.ndimage import binary_erosion
    out = []
    for k in range(24):
        m = gbuffer.hit & (gbuffer.material == k)
        out.append(binary_erosion(m, iterations=erode) if erode else m)
    bg = ~gbuffer.hit
    bg = binary_erosion(bg, iterations=erode) if erode else bg
    patches = np.array(out)
    return {"patches": patches, "background": bg, "grey": patches[GREY_PATCH]}
