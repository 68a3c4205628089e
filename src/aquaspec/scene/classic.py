"""The classic built-in scene (``builtin_scene(..., variant="classic")``): a
seabed with rocks, man-made objects and a ColorChecker; its pieces are shared
by the detailed scene (:mod:`aquaspec.scene.detailed`).

Layout (metres, y up, water surface at y = 0, camera looking along -z):

- the camera at ``(0, -depth_m, 0)``, 1.5 m above the seabed, pitched
  10 degrees down with a 60 degree vertical field of view, so the upper part
  of the image is open water;
- a sandy seabed: a smooth random heightfield (a sum of plane waves of 2.5
  to 25 m wavelength) through ``y = -depth_m - 1.5`` under the camera,
  extending about 90 m ahead;
- a ColorChecker board of 24 patches (4 rows x 6 columns, 0.2 m patches on a
  0.25 m pitch, so about 1.5 m wide: larger than the real chart so each patch
  covers pixels at preview sizes) on a black backing, standing 3 m in front of
  the camera and turned to face it; grey patches in the bottom row as on the
  real chart;
- rocks (displaced spheres, grey and brown) and man-made objects at 2-15 m:
  a concrete block, a pipe lying on the seabed, a barrel and a crate.

Everything random comes from ``numpy.random.default_rng(seed)``, so the same
seed gives identical arrays.
"""

from __future__ import annotations

import numpy as np

from aquaspec.colour.reflectance import colorchecker
from aquaspec.errors import AquaspecError
from aquaspec.scene.camera import Camera
from aquaspec.scene.load import rgb_material
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.scene.seabed import Seabed

#: Height of the camera above the seabed directly below it, metres.
CAMERA_HEIGHT_M = 1.5
#: Distance from the camera to the ColorChecker board along the view axis, metres.
BOARD_DISTANCE_M = 3.0
#: ColorChecker patch side and pitch (centre to centre), metres.
PATCH_SIZE_M = 0.2
PATCH_PITCH_M = 0.25
#: Seabed grid: rows (along the view) x columns. 80 x 61 (9.5k triangles)
#: instead of 110 x 91 (19.6k) changed the 640x360 display image by 0.05 of
#: 255 on average (0.05 % of pixels by more than 10, at object silhouettes)
#: and saved about a tenth of the geometry pass on lavapipe, whose vertex
#: processing runs on one thread.
TERRAIN_GRID = (80, 61)
#: Icosphere subdivisions of the rocks (20 * 4**k triangles each): 2 (320,
#: smooth normals) rather than 3 (1280) changed the 640x360 display image by
#: 0.06 of 255 on average; the outlines stay round at 1280x720.
ROCK_SUBDIVISIONS = 2
#: Camera pitch below the horizontal, degrees.
CAMERA_PITCH_DEG = 10.0

# Linear RGB albedos of the non-chart materials (chosen by eye from sRGB
# swatches of the real materials, darkened for wet surfaces).
_ALBEDOS = {
    "sand": (0.42, 0.36, 0.22),
    "rock grey": (0.16, 0.16, 0.15),
    "rock brown": (0.20, 0.13, 0.08),
    "concrete": (0.36, 0.35, 0.32),
    "rusty pipe": (0.30, 0.12, 0.05),
    "yellow barrel": (0.60, 0.42, 0.03),
    "wooden crate": (0.28, 0.18, 0.09),
    "board black": (0.03, 0.03, 0.03),
    "metal stand": (0.25, 0.25, 0.26),
}


class _Waves:
    """A smooth random field: a sum of plane waves in 2-D or 3-D."""

    def __init__(self, rng, dim, n, wavelength_m, amplitude_per_m):
        d = rng.normal(size=(n, dim))
        self.dirs = d / np.linalg.norm(d, axis=1, keepdims=True)
        lam = np.exp(rng.uniform(np.log(wavelength_m[0]), np.log(wavelength_m[1]), n))
        self.k = 2 * np.pi / lam
        self.amp = amplitude_per_m * lam / np.sqrt(n)
        self.phase = rng.uniform(0, 2 * np.pi, n)

    def __call__(self, p):
        arg = (p @ self.dirs.T) * self.k + self.phase
        return np.sin(arg) @ self.amp


def _box(extents, name, material, rotation_y_deg=0.0, centre=(0, 0, 0)):
    ex, ey, ez = np.asarray(extents, float) / 2
    corners = np.array([[x, y, z] for x in (-ex, ex) for y in (-ey, ey) for z in (-ez, ez)])
    # Corner index = 4*ix + 2*iy + iz; two triangles per side, wound outwards.
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5],    # -x, +x
                      [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6],    # -y, +y
                      [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])   # -z, +z
    return Mesh.flat(_place(corners, rotation_y_deg, centre), faces, material=material,
                     name=name)


def _rot_y(deg):
    a = np.radians(deg)
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def _place(v, rotation_y_deg, centre, tilt=None):
    r = _rot_y(rotation_y_deg) if tilt is None else _rot_y(rotation_y_deg) @ tilt
    return v @ r.T + np.asarray(centre, float)


def _cylinder(radius, length, name, material, centre, rotation=np.eye(3), segments=32):
    """Closed cylinder along its local y; smooth sides, flat caps."""
    a = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    ring = np.stack([np.cos(a), np.zeros_like(a), np.sin(a)], axis=1)
    h = length / 2
    side_v = np.concatenate([ring * radius + [0, -h, 0], ring * radius + [0, h, 0]])
    side_n = np.concatenate([ring, ring])
    i = np.arange(segments)
    j = (i + 1) % segments
    side_f = np.concatenate([np.stack([i, segments + j, j], 1),
                             np.stack([i, segments + i, segments + j], 1)])
    verts, norms, faces = [side_v], [side_n], [side_f]
    base = len(side_v)
    for sign in (-1.0, 1.0):
        cap_v = np.concatenate([[[0, sign * h, 0]], ring * radius + [0, sign * h, 0]])
        cap_n = np.tile([0, sign, 0], (segments + 1, 1))
        f = np.stack([np.zeros(segments, int), 1 + i, 1 + j], 1)
        faces.append(base + (f if sign < 0 else f[:, ::-1]))
        verts.append(cap_v)
        norms.append(cap_n)
        base += segments + 1
    v = np.concatenate(verts) @ rotation.T + np.asarray(centre, float)
    n = np.concatenate(norms) @ rotation.T
    return Mesh(v, np.concatenate(faces), n, material=material, name=name)


def _icosphere(subdivisions):
    t = (1 + 5 ** 0.5) / 2
    v = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    v = np.array(v, float)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    f = np.array(f)
    for _ in range(subdivisions):
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        uniq, inv = np.unique(edges, axis=0, return_inverse=True)
        mid = v[uniq].mean(axis=1)
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = len(v) + inv.reshape(3, -1).T          # midpoint index of edges 01, 12, 20
        v = np.concatenate([v, mid])
        f = np.concatenate([np.stack([f[:, 0], m[:, 0], m[:, 2]], 1),
                            np.stack([f[:, 1], m[:, 1], m[:, 0]], 1),
                            np.stack([f[:, 2], m[:, 2], m[:, 1]], 1),
                            m])
    return v, f


def _rock(rng, name, material, size_m, centre):
    v, f = _icosphere(ROCK_SUBDIVISIONS)
    bumps = _Waves(rng, 3, 8, (0.8, 3.0), 0.12)
    v = v * (1 + bumps(v))[:, None]
    scale = size_m * np.array([rng.uniform(0.8, 1.2), rng.uniform(0.45, 0.7),
                               rng.uniform(0.7, 1.0)]) / 2
    v = _place(v * scale, rng.uniform(0, 360), centre)
    return Mesh(v, f, material=material, name=name)


def _terrain(height, y0, material, rows=110, columns=91):
    t = np.linspace(0, 1, rows)
    z = 4.0 - 90.0 * t ** 1.8                        # finer spacing near the camera
    u = np.linspace(-1, 1, columns)
    x = u[None, :] * (1.2 * np.maximum(-z, 0) + 6.0)[:, None]
    zz = np.broadcast_to(z[:, None], x.shape)
    y = y0 + height(np.stack([x, zz], -1).reshape(-1, 2))
    v = np.stack([x.reshape(-1), y, zz.reshape(-1)], 1)
    nr, nc = x.shape
    idx = np.arange(nr * nc).reshape(nr, nc)
    a, b = idx[:-1, :-1].reshape(-1), idx[:-1, 1:].reshape(-1)
    c, d = idx[1:, :-1].reshape(-1), idx[1:, 1:].reshape(-1)
    faces = np.concatenate([np.stack([a, c, b], 1), np.stack([b, c, d], 1)])
    return Mesh(v, faces, material=material, name="seabed")


def _colorchecker_board(scene, camera_pos, ground_y):
    patches = list(colorchecker())   # measured spectra of the 24 patches
    if len(patches) != 24:
        raise AquaspecError(f"colorchecker() returned {len(patches)} patches; expected 24")
    w = 6 * PATCH_PITCH_M + (PATCH_PITCH_M - PATCH_SIZE_M)
    h = 4 * PATCH_PITCH_M + (PATCH_PITCH_M - PATCH_SIZE_M)
    bottom_clearance = 0.3
    centre = np.array([0.0, ground_y + bottom_clearance + h / 2, -BOARD_DISTANCE_M])
    n = camera_pos - centre
    n /= np.linalg.norm(n)
    right = np.cross([0.0, 1.0, 0.0], n)
    right /= np.linalg.norm(right)
    up = np.cross(n, right)
    frame = np.stack([right, up, n], 1)               # local x, y, z -> world
    thickness = 0.03
    black = scene.add_material(rgb_material(_ALBEDOS["board black"], "board black"))
    backing = _box((w, h, thickness), "colorchecker backing", black)
    backing = Mesh(backing.vertices @ frame.T + centre - n * thickness / 2, backing.faces,
                   backing.normals @ frame.T, black, name=backing.name)
    scene.add(backing)
    s = PATCH_SIZE_M / 2
    quad = np.array([[-s, -s, 0], [s, -s, 0], [s, s, 0], [-s, s, 0]])
    for k, patch in enumerate(patches):
        row, col = divmod(k, 6)
        local = np.array([(col - 2.5) * PATCH_PITCH_M, (1.5 - row) * PATCH_PITCH_M, 0.005])
        v = (quad + local) @ frame.T + centre
        mat = scene.add_material(patch)
        scene.add(Mesh(v, [[0, 1, 2], [0, 2, 3]], np.tile(n, (4, 1)), mat,
                       name=f"colorchecker patch {k + 1:02d} {getattr(patch, 'name', '')}"))
    metal = scene.add_material(rgb_material(_ALBEDOS["metal stand"], "metal stand"))
    board_bottom = centre - up * h / 2
    for side in (-1, 1):
        foot = board_bottom + right * side * (w / 2 - 0.1) - n * 0.05
        top = foot[1] + 0.05
        leg_h = top - ground_y + 0.1
        scene.add(_box((0.05, leg_h, 0.05), f"board leg {side:+d}", metal, 0.0,
                       (foot[0], top - leg_h / 2, foot[2])))


#: Rocks of the classic layout: (x, z, size) in metres, jittered per seed.
ROCK_LAYOUT = [(-2.2, -3.5, 0.9), (2.6, -4.5, 1.2), (-6.5, -8.0, 1.6), (5.5, -10.5, 2.0),
               (-1.5, -13.5, 1.8), (1.6, -2.0, 0.5), (-6.0, -14.0, 2.4)]


def default_camera(depth_m: float, width: int, height: int, fov_y_deg: float) -> Camera:
    """The built-in scenes' camera: at ``(0, -depth_m, 0)``, looking along -z,
    pitched :data:`CAMERA_PITCH_DEG` down."""
    cam_pos = np.array([0.0, -float(depth_m), 0.0])
    pitch = np.radians(CAMERA_PITCH_DEG)
    return Camera.look_at(cam_pos, cam_pos + [0.0, -np.sin(pitch), -np.cos(pitch)],
                          width=width, height=height, fov_y_deg=fov_y_deg)


def check_depth(depth_m) -> float:
    """``depth_m`` as a float, or an AquaspecError naming it."""
    if isinstance(depth_m, bool) or not isinstance(depth_m, (int, float, np.number)) \
            or not np.isfinite(depth_m) or depth_m < 0:
        raise AquaspecError(f"camera depth_m={depth_m!r} is not accepted; give a finite "
                            "depth in metres >= 0 (the water surface is at 0)")
    return float(depth_m)


def classic_scene(depth_m: float, *, seed: int = 0, width: int = 1280, height: int = 720,
                  fov_y_deg: float = 60.0) -> tuple[Scene, Camera]:
    """The classic built-in seabed scene and its camera (see the module docstring).

    Parameters
    ----------
    depth_m : float
        Camera depth below the surface, metres (>= 0); the seabed under the
        camera is 1.5 m deeper.
    seed : int
        Seed of the terrain, rock shapes and placements.
    width, height : int
        Image size of the returned camera, pixels.
    fov_y_deg : float
        Vertical field of view, degrees.

    Returns
    -------
    (Scene, Camera)
        The scene (its ``camera`` is the returned camera) and the camera.

    Raises
    ------
    AquaspecError
        ``depth_m`` negative or not finite; bad image size.
    """
    depth_m = check_depth(depth_m)
    rng = np.random.default_rng(seed)
    depth_m = float(depth_m)
    cam_pos = np.array([0.0, -depth_m, 0.0])
    camera = default_camera(depth_m, width, height, fov_y_deg)

    waves = _Waves(rng, 2, 14, (2.5, 25.0), 0.05)
    y0 = -depth_m - CAMERA_HEIGHT_M

    def height(xz):
        return waves(np.atleast_2d(xz)) - waves(np.zeros((1, 2)))[0]

    def ground(x, z):
        return y0 + float(height([[x, z]])[0])

    scene = Scene(camera=camera)
    mat = {name: scene.add_material(rgb_material(rgb, name))
           for name, rgb in _ALBEDOS.items() if name not in ("board black", "metal stand")}
    terrain = scene.add(_terrain(height, y0, mat["sand"], *TERRAIN_GRID))
    # The light field's lower boundary: the sand, flat at the terrain's
    # deepest point (no surface lies below the boundary).
    scene.seabed = Seabed(float(-terrain.vertices[:, 1].min()), scene.materials[mat["sand"]])
    _colorchecker_board(scene, cam_pos, ground(0.0, -BOARD_DISTANCE_M))

    # Rocks: fixed layout (clear of the chart), jittered per seed.
    for i, (x, z, size) in enumerate(ROCK_LAYOUT):
        x += rng.uniform(-0.3, 0.3)
        z += rng.uniform(-0.3, 0.3)
        kind = "rock grey" if i % 2 == 0 else "rock brown"
        centre = (x, ground(x, z) + 0.15 * size, z)
        scene.add(_rock(rng, f"rock {i}", mat[kind], size, centre))

    def on_ground(x, z, half_height, sink=0.08):
        return (x, ground(x, z) + half_height - sink, z)

    scene.add(_box((1.0, 0.6, 0.8), "concrete block", mat["concrete"],
                   rng.uniform(10, 30), on_ground(2.3, -6.0, 0.3)))
    scene.add(_cylinder(0.25, 4.0, "pipe", mat["rusty pipe"], on_ground(-3.5, -9.0, 0.25),
                        rotation=_rot_y(rng.uniform(-15, 15)) @ np.array(
                            [[0, -1, 0], [1, 0, 0], [0, 0, 1]], float)))
    scene.add(_cylinder(0.3, 0.9, "barrel", mat["yellow barrel"],
                        on_ground(-3.0, -6.0, 0.45, 0.05)))
    scene.add(_box((0.8, 0.8, 0.8), "crate", mat["wooden crate"], rng.uniform(20, 60),
                   on_ground(3.8, -13.0, 0.4)))
    scene.info = {"builtin": "classic", "seed": int(seed)}
    return scene.validate(), camera
