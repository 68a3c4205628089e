"""The scene the shadow's tests share: a grey board 1.6 x 1.1 m, 3 m in front of
a level camera 5 m deep (96x72), Jerlov II, Petzold's phase function."""

import numpy as np

from aquaspec.transport.lightfield import shadow
from aquaspec.colour.bands import Bands
from aquaspec.scene.camera import Camera
from aquaspec.scene.raycast import raycast_gbuffer
from aquaspec.transport.lightfield.bake import lightfield_tables
from aquaspec.colour.reflectance import Reflectance
from aquaspec.scene import Mesh, Scene
from aquaspec.medium.water import load_water

DEPTH = 5.0
BOARD = 3.0                 # distance of the board, m
HALF_W, HALF_H = 0.8, 0.55  # the board's half sizes, m
RHO = 0.3


def board(n_bands: int = 4, e0_scale: float = 1.0) -> dict:
    """The scene's tables, camera, G-buffer, b, e0, the surfaces' radiance
    ``l_s`` and the shadow's distances (``inf`` off the board)."""
    bands = Bands(n_bands)
    water = load_water("II", "solonenko2015").on_bands(bands)
    tables = lightfield_tables(water, phase="petzold", forward_cone_deg=40.0, cone_spread=True,
                               ambient_shadow=True)
    cam_pos = np.array([0.0, -DEPTH, 0.0])
    cam = Camera.look_at(cam_pos, cam_pos + [0.0, 0.0, -1.0], width=96, height=72,
                         fov_y_deg=40.0)
    scene = Scene(camera=cam)
    m = scene.add_material(Reflectance.constant(RHO, "board"))
    v = np.array([[-HALF_W, -DEPTH - HALF_H, -BOARD], [HALF_W, -DEPTH - HALF_H, -BOARD],
                  [HALF_W, -DEPTH + HALF_H, -BOARD], [-HALF_W, -DEPTH + HALF_H, -BOARD]])
    scene.add(Mesh(v, np.array([[0, 1, 2], [0, 2, 3]]), np.tile([0.0, 0.0, 1.0], (4, 1)), m))
    gb = raycast_gbuffer(scene, cam)
    e0 = np.full(bands.n, e0_scale)
    d_hit = np.where(gb.hit, -(cam.position[1] + gb.distance * cam.ray_directions()[..., 1]),
                     0.0)
    l_s = np.where(gb.hit[..., None],
                   tables.surface_radiance(np.full(bands.n, RHO), d_hit, gb.normal[..., 1], e0),
                   0.0)
    return dict(tables=tables, cam=cam, gb=gb, b=np.asarray(water.b), e0=e0, l_s=l_s,
                dist=np.where(gb.hit, gb.distance, np.inf))


def board_context(n_bands: int = 4, e0_scale: float = 1.0):
    """``(shadow.ShadowContext, G-buffer)`` of :func:`board`."""
    s = board(n_bands, e0_scale)
    gb = s["gb"]
    return shadow.ShadowContext(s["tables"], s["cam"], s["dist"], gb.normal, s["l_s"],
                                gb.hit, s["b"], s["e0"]), gb
