"""The detailed built-in scene (``builtin_scene(..., variant="detailed")``).

The classic scene's layout (:mod:`aquaspec.scene.classic`: camera 1.5 m above
the seabed, pitched 10 degrees down; the ColorChecker board 3 m ahead; rocks
at 2-15 m) with detail, all procedural and seeded (nothing downloaded):

- the sand: the same smooth heightfield with a normal map over 1.6 m tiles
  of ripples 0.16 m apart and 12 mm high plus grain
  (:func:`aquaspec.scene.procedural.sand_maps`), one spectral material (a
  colour texture on the sand made the frame 1.5x the classic one's on
  lavapipe; the ripples' shading carries the detail);
- rocks with crevices (ridged noise carved into displaced icospheres of
  1280 triangles) whose colour varies per vertex, darker in the crevices;
- clumps of seagrass blades (thin double-sided ribbons bent by a current);
- a man-made structure: a fouled pipe (rust under encrusting growth,
  texture and normal map) with coral lumps and blades on it, and a leaning
  hull plate of a wreck with fouling;
- the ColorChecker board, a concrete block and a barrel as in the classic scene.

Reflectances come from :mod:`aquaspec.colour.benthic` (which says which are
measured and which are upsampled from RGB); ``Scene.info`` names them.
"""

from __future__ import annotations

import numpy as np

from aquaspec.colour.benthic import RGB_ALBEDOS, benthic_reflectance, provenance
from aquaspec.scene import classic
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.scene.procedural import (blade_strips, crevice_rock, fouling_maps, pipe_mesh,
                                       rock_face_labels, sand_maps, split_by_face)
from aquaspec.scene.texture import bilinear_repeat
from aquaspec.scene.seabed import Seabed

#: Icosphere subdivisions of the detailed rocks (1280 triangles each).
ROCK_SUBDIVISIONS = 3
#: Side of the sand texture's tile, metres, and its texels a side.
SAND_TILE_M = 1.6
SAND_TEXELS = 256
#: Seagrass clumps: (x, z, blades) centres, metres (jittered per seed).
SEAGRASS_CLUMPS = [(-1.6, -2.6, 30), (1.9, -3.4, 24), (-3.8, -5.0, 40), (0.6, -6.5, 30),
                   (3.6, -7.8, 36), (-1.2, -9.5, 40), (4.8, -5.6, 20), (-5.0, -11.0, 40),
                   (1.5, -11.5, 30), (-2.6, -4.0, 16)]


#: Beyond this distance ahead (metres) the seabed has no normal map: its
#: ripples are far below a pixel there (the mip chain has averaged them flat)
#: and the plain pipeline is cheaper.
SAND_NORMAL_MAP_RANGE_M = 25.0


def _seabed(scene, rng, height, y0, material):
    """The sand: the classic heightfield, its near part with the ripple normal
    map (:func:`aquaspec.scene.procedural.sand_maps`), one spectral material."""
    _, normal, _ = sand_maps(rng, RGB_ALBEDOS["sand"], n=SAND_TEXELS, tile_m=SAND_TILE_M)
    mesh = classic._terrain(height, y0, material, *classic.TERRAIN_GRID)
    uv = mesh.vertices[:, [0, 2]] / SAND_TILE_M * [1.0, -1.0]
    z = mesh.vertices[mesh.faces, 2].mean(axis=1)
    near = z > -SAND_NORMAL_MAP_RANGE_M
    scene.add(Mesh(mesh.vertices, mesh.faces[near], mesh.normals, material, uv=uv,
                   normal_map=normal, name="seabed (rippled sand)"))
    scene.add(Mesh(mesh.vertices, mesh.faces[~near], mesh.normals, material,
                   name="seabed (far sand)"))
    scene.seabed = Seabed(float(-mesh.vertices[:, 1].min()), scene.materials[material])


def _seagrass(scene, rng, ground, material):
    roots = []
    for x, z, count in SEAGRASS_CLUMPS:
        x += rng.uniform(-0.3, 0.3)
        z += rng.uniform(-0.3, 0.3)
        r = 0.35 * np.sqrt(rng.uniform(size=count))
        a = rng.uniform(0, 2 * np.pi, count)
        for xi, zi in zip(x + r * np.cos(a), z + r * np.sin(a)):
            roots.append((xi, ground(xi, zi) - 0.02, zi))
    v, f = blade_strips(rng, np.array(roots))
    scene.add(Mesh(v, f, material=material, name="seagrass"))


def _fouled(mesh: Mesh, growth, mats, name):
    """Faces of a uv-mapped ``mesh`` as rust or fouling by the growth field at
    their uv centroids."""
    centre_uv = mesh.uv[mesh.faces].mean(axis=1)
    covered = bilinear_repeat(growth[..., None], centre_uv)[:, 0] > 0.5
    return split_by_face(mesh, covered.astype(int), [mats["rust"], mats["fouling"]],
                         [f"{name} (rust)", f"{name} (fouling)"])


def _pipe(scene, rng, ground, mats):
    x, z, radius, length = -3.2, -8.0, 0.25, 5.0
    turn = classic._rot_y(rng.uniform(-20, -5))
    lie = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]], float)      # local y -> world x
    rot = turn @ lie
    centre = np.array([x, ground(x, z) + radius - 0.06, z])
    _, normal, growth = fouling_maps(rng, RGB_ALBEDOS["rust"], RGB_ALBEDOS["fouling"],
                                     cover=0.5)
    pipe = pipe_mesh(radius, length, centre, rot, segments=40, rings=30, uv_scale=(1.0, 6.0),
                     normal_map=normal, material=mats["rust"], name="pipe")
    for part in _fouled(pipe, growth, mats, "pipe"):
        scene.add(part)
    sphere = classic._icosphere(2)
    axis = rot @ np.array([0.0, 1.0, 0.0])
    for k in range(7):
        along = rng.uniform(-0.45, 0.45) * length
        p = centre + axis * along + np.array([0.0, radius * 0.9, 0.0])
        lump = crevice_rock(rng, *sphere, rng.uniform(0.12, 0.3), p,
                            classic._rot_y(rng.uniform(0, 360)), RGB_ALBEDOS["coral"])
        scene.add(Mesh(lump.vertices, lump.faces, lump.normals, mats["coral"],
                       name=f"coral on pipe {k}"))
    tops = [centre + axis * rng.uniform(-0.45, 0.45) * length + [0, radius * 0.95, 0]
            for _ in range(14)]
    v, f = blade_strips(rng, np.array(tops), length_m=(0.1, 0.3))
    scene.add(Mesh(v, f, material=mats["seagrass"], name="algae on pipe"))


def _hull_plate(scene, rng, ground, mats):
    """A leaning, partly buried plate of a wreck's hull (2.4 x 1.4 m) with fouling."""
    x, z = 4.2, -12.0
    w, h, nx, ny = 2.4, 1.4, 24, 14
    gx, gy = np.meshgrid(np.linspace(0, 1, nx + 1), np.linspace(0, 1, ny + 1))
    local = np.stack([(gx - 0.5) * w, gy * h, np.zeros_like(gx)], -1).reshape(-1, 3)
    lean = np.radians(35.0)
    tilt = np.array([[1, 0, 0], [0, np.cos(lean), -np.sin(lean)],
                     [0, np.sin(lean), np.cos(lean)]])
    rot = classic._rot_y(rng.uniform(-30, -10)) @ tilt
    v = local @ rot.T + [x, ground(x, z) - 0.15, z]
    idx = np.arange(len(v)).reshape(ny + 1, nx + 1)
    p, q = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    r, t = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.stack([p, q, t], 1), np.stack([p, t, r], 1)])
    uv = np.stack([gx.ravel() * 2.0, gy.ravel() * 1.2], 1)
    _, normal, growth = fouling_maps(rng, RGB_ALBEDOS["rust"], RGB_ALBEDOS["coral"], cover=0.35)
    plate = Mesh(v, faces, np.tile(rot @ [0, 0, 1.0], (len(v), 1)), mats["rust"], uv=uv,
                 normal_map=normal, name="wreck hull plate")
    for part in _fouled(plate, growth, mats, "wreck hull plate"):
        scene.add(part)


def detailed_scene(depth_m: float, *, seed: int = 0, width: int = 1280, height: int = 720,
                   fov_y_deg: float = 60.0):
    """The detailed built-in scene and its camera (see the module docstring);
    arguments as :func:`aquaspec.scene.builtin.builtin_scene`."""
    depth_m = classic.check_depth(depth_m)
    rng = np.random.default_rng(seed)
    cam_pos = np.array([0.0, -depth_m, 0.0])
    camera = classic.default_camera(depth_m, width, height, fov_y_deg)
    waves = classic._Waves(rng, 2, 14, (2.5, 25.0), 0.05)
    y0 = -depth_m - classic.CAMERA_HEIGHT_M

    def height_at(xz):
        return waves(np.atleast_2d(xz)) - waves(np.zeros((1, 2)))[0]

    def ground(x, z):
        return y0 + float(height_at([[x, z]])[0])

    scene = Scene(camera=camera)
    mats = {name: scene.add_material(benthic_reflectance(name))
            for name in ("sand", "seagrass", "concrete", "rock", "rock crevice", "coral",
                         "fouling", "rust")}
    mats["barrel"] = scene.add_material(classic.rgb_material(
        classic._ALBEDOS["yellow barrel"], "yellow barrel"))
    _seabed(scene, rng, height_at, y0, mats["sand"])
    classic._colorchecker_board(scene, cam_pos, ground(0.0, -classic.BOARD_DISTANCE_M))
    sphere = classic._icosphere(ROCK_SUBDIVISIONS)
    for i, (x, z, size) in enumerate(classic.ROCK_LAYOUT):
        x += rng.uniform(-0.3, 0.3)
        z += rng.uniform(-0.3, 0.3)
        rock = crevice_rock(rng, *sphere, size, (x, ground(x, z) + 0.08 * size, z),
                            classic._rot_y(rng.uniform(0, 360)), RGB_ALBEDOS["rock"])
        for part in split_by_face(rock, rock_face_labels(rock, rng),
                                  [mats["rock"], mats["rock crevice"], mats["fouling"]],
                                  [f"rock {i}", f"rock {i} crevices", f"rock {i} growth"]):
            scene.add(part)
    _seagrass(scene, rng, ground, mats["seagrass"])
    _pipe(scene, rng, ground, mats)
    _hull_plate(scene, rng, ground, mats)

    def on_ground(x, z, half_height, sink=0.08):
        return (x, ground(x, z) + half_height - sink, z)

    scene.add(classic._box((1.0, 0.6, 0.8), "concrete block", mats["concrete"],
                           rng.uniform(10, 30), on_ground(2.3, -6.0, 0.3)))
    scene.add(classic._cylinder(0.3, 0.9, "barrel", mats["barrel"],
                                on_ground(-2.6, -5.6, 0.45, 0.05)))
    scene.info = {"builtin": "detailed", "seed": int(seed),
                  "reflectances": provenance(),
                  "textures": {"sand": f"{SAND_TEXELS}x{SAND_TEXELS} normal map per "
                                       f"{SAND_TILE_M} m tile, mip-mapped",
                               "pipe, hull plate": "128x128 normal map of fouling; "
                                                   "rust / fouling materials per face"}}
    return scene.validate(), camera
