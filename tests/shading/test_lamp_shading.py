"""The lamps' terms of a G-buffer (aquaspec.shading.lamp.lamp_radiance): a lit wall
against the inverse-square law carried to the camera, the veil ending at the wall,
and open-water rays going up ending at the water surface."""

import numpy as np

from aquaspec.light.lamp import Lamp
from aquaspec.scene.camera import Camera
from aquaspec.scene.gbuffer import GBuffer
from aquaspec.shading.lamp import lamp_radiance
from aquaspec.transport import lamp_scattering as ls
from aquaspec.transport.sun_scattering import log_phase_table

WL = np.array([450.0, 600.0])


def inputs(lamp, b):
    b = np.asarray(b, float)
    return ls.LampInputs(lamp, np.array([2.0, 1.0]), np.array([0.2, 0.5]),
                         np.array([0.15, 0.45]), b, log_phase_table("isotropic", b=b,
                                                                    wavelength_nm=WL),
                         halo=False)


def wall_gbuffer(distance_to_wall=3.0):
    cam = Camera((0.0, -8.0, 0.0), (0, 0, -1), (0, 1, 0), 16, 12, 10.0, 10.0, 8.0, 6.0)
    dirs = cam.ray_directions()
    s = distance_to_wall / -dirs[..., 2]
    normal = np.broadcast_to([0.0, 0.0, 1.0], s.shape + (3,))
    return GBuffer(cam, s, normal, np.zeros(s.shape, np.uint32), np.zeros(s.shape + (3,)),
                   [object()])


def test_wall_lit_by_a_lamp_at_the_camera():
    g = wall_gbuffer()
    lamp = Lamp((0.0, -8.0, 0.0), cone_deg=180.0, intensity_w_sr=1.0, frame="world")
    rho = np.array([0.5, 0.3])
    out = lamp_radiance(g, [inputs(lamp, (0.0, 0.0))], rho_of_hits=lambda m: np.tile(
        rho, (int(m.sum()), 1)))
    dirs = g.camera.ray_directions()
    s = g.distance.astype(float)
    cos = -dirs[..., 2]
    inp = inputs(lamp, (0.0, 0.0))
    e = inp.intensity * cos[..., None] * np.exp(-inp.c_lamp * s[..., None]) / s[..., None] ** 2
    expected = rho / np.pi * e * np.exp(-inp.c_view * s[..., None])
    np.testing.assert_allclose(out, expected, rtol=1e-5)


def test_veil_ends_at_the_wall():
    lamp = Lamp((0.3, -8.0, 0.0), cone_deg=180.0, intensity_w_sr=1.0, frame="world")
    inp = inputs(lamp, (0.2, 0.1))
    black = lambda m: np.zeros((int(m.sum()), 2))
    near = lamp_radiance(wall_gbuffer(1.0), [inp], rho_of_hits=black, n_samples=256)
    far = lamp_radiance(wall_gbuffer(4.0), [inp], rho_of_hits=black, n_samples=256)
    assert np.all(far > near) and np.all(near > 0)


def test_up_rays_end_at_the_water_surface():
    cam = Camera((0.0, -1.0, 0.0), (0, 1, 0), (0, 0, -1), 8, 8, 8.0, 8.0, 4.0, 4.0)
    g = GBuffer(cam, np.full((8, 8), np.inf), np.zeros((8, 8, 3)), np.zeros((8, 8), np.uint32),
                np.zeros((8, 8, 3)), [])
    lamp = Lamp((0.0, -1.5, 0.0), cone_deg=180.0, intensity_w_sr=1.0, frame="world")
    inp = inputs(lamp, (0.2, 0.1))
    out = lamp_radiance(g, [inp], rho_of_hits=None, n_samples=512, veil="march")
    dirs = cam.ray_directions().reshape(-1, 3)
    to_surface = 1.0 / dirs[:, 1]
    ref = ls.single_scattering(inp, cam.position, dirs, to_surface, n_samples=512)
    np.testing.assert_allclose(out.reshape(-1, 2), ref, rtol=1e-12)
    longer = ls.single_scattering(inp, cam.position, dirs, 3 * to_surface, n_samples=512)
    assert np.all(longer > 1.01 * ref)


def test_shade_gbuffer_adds_the_lamps_and_setup_places_them():
    """shade_gbuffer(lamps=) is the image without lamps plus their radiance in
    camera RGB; SpectralSetup.lamp_inputs places camera-fixed lamps and gives
    the surfaces' extinction towards the camera to both paths."""
    from aquaspec.colour.bands import Bands
    from aquaspec.colour.sensors import get_sensor, radiance_to_rgb
    from aquaspec.light.lamp import parse_lamps
    from aquaspec.light.sky import surface_light
    from aquaspec.medium.water import get_water
    from aquaspec.rendering.setup import SpectralSetup
    from aquaspec.shading.shade import shade_gbuffer
    g = wall_gbuffer()
    setup = SpectralSetup(get_water("II"), get_sensor("human"), surface_light("none"),
                          Bands(4), ms_model="seeds", lamps=parse_lamps(["rov-pair"]))
    lamps = setup.lamp_inputs(g.camera)
    np.testing.assert_allclose(lamps[1].lamp.position, g.camera.position + [0.5, 0, 0])
    bw = setup.water.on_bands(setup.bands)
    np.testing.assert_allclose(lamps[0].c_view, bw.a + bw.b)
    np.testing.assert_allclose(lamps[0].c_lamp, bw.a + bw.b)
    medium = setup.medium([])
    medium["material_bands"] = np.full((1, 4), 0.4)
    dark = shade_gbuffer(g, **medium)["camera_rgb"]
    lit = shade_gbuffer(g, **medium, lamps=lamps)["camera_rgb"]
    extra = lamp_radiance(g, lamps, rho_of_hits=lambda m: np.full((int(m.sum()), 4), 0.4))
    np.testing.assert_allclose(lit, dark + radiance_to_rgb(extra.reshape(-1, 4),
                                                           medium["response_weights"])
                               .reshape(dark.shape), rtol=1e-12)
    assert np.all(dark == 0) and extra.min() > 0


def test_light_field_carries_the_lamps_with_the_forward_cone():
    """With the light field the lamps' light has the surfaces' c - f b (the forward
    cone counted as unscattered) from the lamp and towards the camera, below c."""
    from aquaspec.colour.bands import Bands
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.light.lamp import parse_lamps
    from aquaspec.light.sky import surface_light
    from aquaspec.medium.water import get_water
    from aquaspec.rendering.setup import SpectralSetup
    setup = SpectralSetup(get_water("II"), get_sensor("human"), surface_light("none"),
                          Bands(4), lamps=parse_lamps(["torch"]))
    (inp,) = setup.lamp_inputs(wall_gbuffer().camera)
    tables = setup.lightfield_tables()
    bw = setup.water.on_bands(setup.bands)
    np.testing.assert_allclose(inp.c_view, tables.ray_extinction(bw.a, bw.b))
    np.testing.assert_allclose(inp.c_lamp, inp.c_view)
    assert np.all(inp.c_view < bw.a + bw.b)
    assert setup.describe()["lamps"][0]["name"] == "torch"
