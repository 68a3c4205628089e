"""The sun's terms of a G-buffer (aquaspec.shading.sun)."""

import numpy as np

from aquaspec.light.sun import refracted_to_sun
from aquaspec.scene.camera import Camera
from aquaspec.scene.mesh import Scene
from aquaspec.colour.reflectance import Reflectance
from aquaspec.scene.shadowmap import shadow_map_numpy, shadow_map_spec
from aquaspec.shading.sun import sun_radiance
from aquaspec.transport.sun_scattering import PHASE_TABLE_SIZE, SunInputs, single_scattering_open
from support.plates import plate


def test_surface_term_of_a_lit_plate():
    """Camera looking straight down on a grey plate: rho/pi E_b(d) mu0 exp(-c S)
    plus the veil's closed form."""
    scene = Scene()
    scene.add_material(Reflectance.constant(0.4))
    scene.add(plate(-5.0, -50, 50, -50, 50))
    cam = Camera.look_at([0.0, -2.0, 0.0], [0.0, -5.0, 0.0], width=3, height=3, fov_y_deg=2.0,
                         up=(0.0, 0.0, -1.0))
    from aquaspec.scene.raycast import raycast_gbuffer
    gb = raycast_gbuffer(scene, cam)
    to_sun = refracted_to_sun(70.0, 0.0)
    c = np.array([0.1, 0.4])
    b = np.array([0.05, 0.2])
    beam = np.array([2.0, 1.0])
    sun = SunInputs(beam0=beam, c_sun=c, c_view=c, b=b, to_sun=to_sun,
                      log_phase=np.log(np.full((2, PHASE_TABLE_SIZE), 1 / (4 * np.pi))))
    spec = shadow_map_spec(scene.bounds(), cam.position, to_sun, size=64, radius_m=10.0)
    out = sun_radiance(gb, sun, rho_of_hits=lambda m: np.full((m.sum(), 2), 0.4),
                         height_map=shadow_map_numpy(scene, spec), spec=spec)
    s = gb.distance[1, 1]
    surf = 0.4 / np.pi * beam * np.exp(-c * 5.0 / to_sun[1]) * to_sun[1] * np.exp(-c * s)
    veil = single_scattering_open(b=b, phase_value=np.full(2, 1 / (4 * np.pi)), beam0=beam,
                                    c_sun=c, c_view=c, depth_o=2.0, v_y=-1.0, s=s,
                                    mu0=to_sun[1])
    assert np.allclose(out[1, 1], surf + veil, rtol=1e-3)
