"""The validation scenes: a ColorChecker board in open water, and occluded.

As in the thesis's validation (chapter 6.1): the camera looks horizontally
at a board 3 m away; behind and around it is open water. The board is the
24 ColorChecker patches (measured spectra) on a black backing, each patch
0.2 m wide with 0.25 m pitch, facing the camera.

A second view (``view="down"``, :data:`VIEWS`) checks the models on other
directions: the camera looks down by :data:`DOWN_PITCH_DEG` at the board
lying flat (facing up, lit by the downwelling light) 3 m away along the
view; around it the camera sees the open water below.

**Occluded scenes** (:data:`SCENES`, level view only; issue 36): the same
board with a grey Lambertian seabed (albedo :data:`SEABED_ALBEDO`)
:data:`SEABED_BELOW_M` below the camera, 0.25 m below the board's lower
edge and seen in front of it and under it, and one occluder. Coordinates
relative to the camera (x right, y up, the camera looks along -z; the board
is the plane z = -3, |x| <= 0.8, -0.55 <= y <= 0.55):

- ``"open"``: no occluder (the board near the seabed);
- ``"ledge"``: a dark slab (albedo :data:`DARK_ALBEDO`) 0.2 m thick, its
  underside 0.3 m above the board's top edge (y = 0.85 to 1.05), 3 m wide
  (|x| <= 1.5), from 0.5 m behind the board to 1.5 m in front of it
  (-3.5 <= z <= -1.5); its front part is outside the view, which is the
  point (the occlusion must come from the geometry, not the screen). The
  seabed under it is seen in front of the board, beside it and through the
  gap under it;
- ``"wall"``: a dark wall (albedo :data:`DARK_ALBEDO`) 0.4 m behind the
  board (front face z = -3.4, 0.3 m thick), 6 m wide, from 1 cm into the
  seabed to y = 2.2 (1.65 m above the board's top edge, above the view):
  it fills the view behind the board;
- ``"box"``: a 1 m grey cube (albedo 0.2, a rock) standing on the seabed
  (sunk 1 cm into it) behind the board and to its right (0.4 <= x <= 1.4,
  -4.5 <= z <= -3.5): its right part is seen beside the board, with the
  seabed in front of it (seen under the board and beside it) and to its
  right.

Every piece is a closed mesh of quads with outward normals (the board's
quads face the camera), so Mitsuba (one-sided ``diffuse`` surfaces, normals
from the winding) and aquaspec see the same geometry. ``scene.seabed`` is
the light field's lower boundary (the seabed mesh is 1 km square).

Masks (:func:`masks`): ``patches``, ``grey``, ``background`` as before;
``seabed`` (every seabed pixel), ``occluder`` (the occluder's own pixels)
and ``shaded_seabed``: the seabed the occluder shades, by where its pixels
hit the seabed (:func:`shaded_footprint`): under the ledge's footprint
(``"open"`` uses the same footprint, so the same pixels can be compared
with and without the ledge), between the board's plane and the wall, or
within :data:`BOX_SHADE_M` of the box's foot. :data:`SHADED_REGIONS` names
what each occluder shades.
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
#: The scenes (module docstring): ``"board"`` is the thesis's board in open
#: water (a seabed only with ``seabed_below_m``); the others are the board
#: over a seabed, open or with an occluder (level view only).
SCENES = ("board", "open", "ledge", "wall", "box")
#: The scenes with a seabed and (but ``"open"``) an occluder.
OCCLUDED_SCENES = SCENES[1:]
#: Seabed of the occluded scenes: metres below the camera, and its albedo.
SEABED_BELOW_M = 0.8
SEABED_ALBEDO = 0.2
#: Albedo of the dark occluders (ledge, wall); the box is seabed-grey.
DARK_ALBEDO = 0.05
#: Material indices: patches 0-23, then these.
BACKING_MATERIAL = 24
SEABED_MATERIAL = 25
OCCLUDER_MATERIAL = 26
#: Each occluder: (lower corner, upper corner, albedo) of an axis-aligned box
#: in the board's frame (x across to the right, y up from the camera's
#: height, z from the board's plane towards the camera), metres. The wall and
#: the box reach 1 cm into the seabed (no crack at their foot).
OCCLUDERS = {
    "ledge": ((-1.5, 0.85, -0.5), (1.5, 1.05, 1.5), DARK_ALBEDO),
    "wall": ((-3.0, -SEABED_BELOW_M - 0.01, -0.7), (3.0, 2.2, -0.4), DARK_ALBEDO),
    "box": ((0.4, -SEABED_BELOW_M - 0.01, -1.5), (1.4, 0.2, -0.5), 0.2),
}
#: The box shades the seabed within this distance of its foot (``shaded_seabed``).
BOX_SHADE_M = 0.3
#: What each scene's occluder shades, as :func:`masks` names the regions
#: (``"open"`` has the ledge's ``shaded_seabed`` without the ledge).
SHADED_REGIONS = {"open": (), "ledge": ("patches", "grey", "shaded_seabed"),
                  "wall": ("patches", "grey", "shaded_seabed"), "box": ("shaded_seabed",)}


def cuboid(lo, hi, material: int, name: str) -> Mesh:
    """A closed axis-aligned box from corner ``lo`` to ``hi``: six quads (four
    vertices each, flat normals), wound counter-clockwise seen from outside."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo)):
        raise AquaspecError(f"box {name!r} from {lo.tolist()} to {hi.tolist()}; accepted: "
                            "finite corners with every upper coordinate above the lower")
    verts, faces, normals = [], [], []
    for axis in range(3):
        # (u, v, axis) is right-handed: u x v = axis, so the corners
        # (0,0) (1,0) (1,1) (0,1) in (u, v) wind counter-clockwise about +axis.
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for side, sign in ((lo, -1.0), (hi, 1.0)):
            quad = []
            for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
                p = np.empty(3)
                p[axis], p[u], p[v] = side[axis], (lo, hi)[a][u], (lo, hi)[b][v]
                quad.append(p)
            k = len(verts)
            verts += quad if sign > 0 else quad[::-1]
            normals += [np.eye(3)[axis] * sign] * 4
            faces += [[k, k + 1, k + 2], [k, k + 2, k + 3]]
    return Mesh(np.array(verts), np.array(faces), np.array(normals), material, name=name)


def board_scene(depth_m: float, *, width: int = 96, height: int = 72,
                fov_y_deg: float = 40.0, distance_m: float = BOARD_DISTANCE_M,
                seabed_below_m: float | None = None, seabed_albedo: float = SEABED_ALBEDO,
                view: str = "level", scene: str = "board"):
    """The validation scene at camera depth ``depth_m``; returns (Scene, Camera).

    Patch ``k`` of the chart uses material ``k``; the backing uses material 24.
    With ``seabed_below_m`` a flat grey Lambertian seabed (albedo
    ``seabed_albedo``, material 25, 1 km square) lies that far below the
    camera, and ``scene.seabed`` names it as the light field's lower boundary
    (it must lie below the board: with ``view="down"`` the board is
    ``distance_m sin(DOWN_PITCH_DEG)`` below the camera). ``view``: one of
    :data:`VIEWS` (module docstring). ``scene``: one of :data:`SCENES`; the
    occluded ones have their own seabed (:data:`SEABED_BELOW_M`,
    :data:`SEABED_ALBEDO`) and the occluder is material 26.
    """
    if view not in VIEWS:
        raise AquaspecError(f"view={view!r}; accepted: {', '.join(VIEWS)}")
    if scene not in SCENES:
        raise AquaspecError(f"scene={scene!r}; accepted: {', '.join(SCENES)}")
    if scene != "board":
        if view != "level":
            raise AquaspecError(f"scene={scene!r} with view={view!r}; accepted: the "
                                "occluded scenes in the level view only")
        if seabed_below_m is not None:
            raise AquaspecError(f"seabed_below_m={seabed_below_m!r} with scene={scene!r}; "
                                f"accepted: none (the scene's seabed is {SEABED_BELOW_M:g} m "
                                "below the camera)")
        seabed_below_m, seabed_albedo = SEABED_BELOW_M, SEABED_ALBEDO
    cam_pos = np.array([0.0, -float(depth_m), 0.0])
    pitch = np.radians(DOWN_PITCH_DEG) if view == "down" else 0.0
    forward = np.array([0.0, -np.sin(pitch), -np.cos(pitch)])
    camera = Camera.look_at(cam_pos, cam_pos + forward, width=width, height=height,
                            fov_y_deg=fov_y_deg)
    out = Scene(camera=camera)
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
        out.add_material(patch)
        row, col = divmod(k, 6)
        v, f = quad((col - 2.5) * PATCH_PITCH_M, (1.5 - row) * PATCH_PITCH_M, 0.002,
                    PATCH_SIZE_M / 2, PATCH_SIZE_M / 2)
        out.add(Mesh(v, f, np.tile(normal, (4, 1)), k, name=f"patch {k:02d}"))
    back = out.add_material(Reflectance.constant(BACKING_REFLECTANCE, "board backing"))
    v, f = quad(0.0, 0.0, 0.0, 3 * PATCH_PITCH_M + 0.05, 2 * PATCH_PITCH_M + 0.05)
    out.add(Mesh(v, f, np.tile(normal, (4, 1)), back, name="backing"))
    if seabed_below_m is not None:
        below = float(seabed_below_m)
        lowest = float(cam_pos[1] - v[:, 1].min())
        if not (np.isfinite(below) and below > max(lowest, 0.0)):
            raise AquaspecError(f"seabed_below_m={seabed_below_m!r}; accepted: a distance "
                                f"> {max(lowest, 0.0):g} m below the camera (under the board)")
        sand = Reflectance.constant(float(seabed_albedo), "seabed")
        out.seabed = Seabed(float(depth_m) + below, sand)
        y = cam_pos[1] - below
        half = 500.0
        v = np.array([[-half, y, -half], [half, y, -half], [half, y, half], [-half, y, half]])
        out.add(Mesh(v, np.array([[0, 2, 1], [0, 3, 2]]), np.tile([0.0, 1.0, 0.0], (4, 1)),
                     out.add_material(sand), name="seabed"))
    if scene in OCCLUDERS:
        lo, hi, albedo = OCCLUDERS[scene]
        rock = out.add_material(Reflectance.constant(albedo, scene))
        out.add(cuboid(centre + np.array(lo), centre + np.array(hi), rock, scene))
    return out, camera


def shaded_footprint(scene: str, x, z) -> np.ndarray:
    """Where ``scene``'s occluder shades the seabed: bool of points at ``x``
    (across) and ``z`` (from the board's plane towards the camera) in the
    board's frame (:data:`OCCLUDERS`). ``"open"``: the ledge's footprint;
    ``"board"``: nowhere."""
    x, z = np.asarray(x, dtype=float), np.asarray(z, dtype=float)
    if scene in ("open", "ledge"):
        (x0, _, z0), (x1, _, z1), _ = OCCLUDERS["ledge"]
        return (x >= x0) & (x <= x1) & (z >= z0) & (z <= z1)
    if scene == "wall":
        # Between the board's plane and the wall's face.
        (x0, _, _), (x1, _, face), _ = OCCLUDERS["wall"]
        return (x >= x0) & (x <= x1) & (z >= face) & (z <= 0.0)
    if scene == "box":
        (x0, _, z0), (x1, _, z1), _ = OCCLUDERS["box"]
        dx = np.maximum(np.maximum(x0 - x, x - x1), 0.0)
        dz = np.maximum(np.maximum(z0 - z, z - z1), 0.0)
        d = np.hypot(dx, dz)
        return (d > 0.0) & (d <= BOX_SHADE_M)
    return np.zeros(np.broadcast(x, z).shape, dtype=bool)


def masks(gbuffer, erode: int = 1, *, scene: str = "board",
          distance_m: float = BOARD_DISTANCE_M) -> dict:
    """Pixel masks of the level or downward view's regions.

    ``patches`` (24, H, W), ``grey``, ``background`` (open water),
    ``seabed`` (material 25), ``occluder`` (material 26) and
    ``shaded_seabed``: the seabed pixels whose hits lie in
    :func:`shaded_footprint` of ``scene`` (the board's frame from the
    G-buffer's camera and ``distance_m``). Each eroded by ``erode`` pixels.
    """
    def shrink(m):
        return binary_erosion(m, iterations=erode) if erode else m

    hit = gbuffer.hit
    patches = np.array([shrink(hit & (gbuffer.material == k)) for k in range(24)])
    seabed = shrink(hit & (gbuffer.material == SEABED_MATERIAL))
    cam = gbuffer.camera
    centre = cam.position + distance_m * cam.forward
    rel = np.where(seabed[..., None], gbuffer.positions() - centre, 0.0)
    shaded = seabed & shaded_footprint(scene, rel[..., 0], rel[..., 2])
    return {"patches": patches, "background": shrink(~hit), "grey": patches[GREY_PATCH],
            "seabed": seabed, "occluder": shrink(hit & (gbuffer.material == OCCLUDER_MATERIAL)),
            "shaded_seabed": shaded}
