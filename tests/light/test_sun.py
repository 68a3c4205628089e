"""The direct sun (aquaspec.light.sun): geometry, closed forms, the march, the shadow map, GPU twin."""

import numpy as np
import pytest

from aquaspec.transport import monzon2022 as model
from aquaspec.colour.bands import Bands
from aquaspec.scene.camera import Camera
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import surface_light
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.colour.reflectance import Reflectance
from aquaspec.light import sun as S
from support.plates import plate


# ---- geometry and the light -------------------------------------------------------

@pytest.mark.parametrize("elev,az", [(60.0, 150.0), (10.0, 0.0), (90.0, 33.0), (1.0, 270.0)])
def test_refraction_follows_snell(elev, az):
    air = S.air_to_sun(elev, az)
    wat = S.refracted_to_sun(elev, az)
    assert np.isclose(np.linalg.norm(wat), 1.0)
    sin_air = np.hypot(air[0], air[2])
    sin_w = np.hypot(wat[0], wat[2])
    assert np.isclose(sin_air, model.N_WATER * sin_w)
    if sin_air > 1e-9:      # same vertical plane, same side
        assert np.allclose(air[[0, 2]] / sin_air, wat[[0, 2]] / sin_w)
    # Never flatter than the edge of Snell's window.
    assert wat[1] >= np.sqrt(1 - 1 / model.N_WATER ** 2) - 1e-12


def test_azimuth_convention():
    # 0: towards -z (ahead of the built-in camera); 90: towards +x.
    assert S.air_to_sun(0.0 + 1e-9, 0.0)[2] < -0.99
    assert S.air_to_sun(1e-9, 90.0)[0] > 0.99


def test_sun_sky_splits_e0_into_sky_and_sun():
    bands = Bands(10)
    light = surface_light("sun-sky", sun_elevation_deg=40.0, sun_azimuth_deg=10.0)
    e0, sky, sun = light.on_bands(bands), light.sky_on(bands), light.sun_horizontal_on(bands)
    assert np.allclose(sky + sun, e0)
    assert np.all(sun > sky)             # a clear day: the sun brings most of E0
    scaled = surface_light("sun-sky", sun_elevation_deg=40.0, total_w_m2=50.0)
    assert np.isclose(scaled.total_w_m2(), 50.0)
    # The sun is scaled with the light: its share of E0 is unchanged.
    assert np.allclose(scaled.sun_horizontal_on(bands) / scaled.on_bands(bands), sun / e0)
    assert light.describe()["sun"]["azimuth_deg"] == 10.0
    assert light.without_sun().sun is None
    assert surface_light("overcast").sun is None


@pytest.mark.parametrize("kw,what", [({"sun_azimuth_deg": float("nan")}, "azimuth"),
                                     ({"sun_elevation_deg": 0.5}, "elevation")])
def test_bad_sun_angles_are_named(kw, what):
    with pytest.raises(AquaspecError, match=what):
        surface_light("sun-sky", **kw)


# ---- closed forms and the march ----------------------------------------------------

B = np.array([0.05, 0.2, 0.4])
C = np.array([0.08, 0.3, 0.9])
BEAM = np.array([1.0, 2.0, 0.5])
MU0 = 0.8


def _quad_ss(phase_value, d_o, v_y, s, c_sun=C, c_view=C, n=200001):
    """``b p int_0^S E_b(d(t)) exp(-c t) dt`` by the trapezoid rule."""
    s_end = model.ray_length(s, d_o, v_y)
    s_end = min(float(s_end), 400.0)
    t = np.linspace(0.0, s_end, n)[:, None]
    d = d_o - t * v_y
    f = BEAM * np.exp(-c_sun * d / MU0) * np.exp(-c_view * t)
    return B * phase_value * np.trapezoid(f, t[:, 0], axis=0)


@pytest.mark.parametrize("v_y,s", [(-0.5, 7.0), (0.0, np.inf), (-0.9, np.inf), (0.6, np.inf),
                                   (0.95, 2.0), (0.3, 0.0)])
def test_open_single_scattering_against_quadrature(v_y, s):
    p = np.array([0.1, 0.05, 0.02])
    got = S.single_scattering_open(b=B, phase_value=p, beam0=BEAM, c_sun=C, c_view=C,
                                   depth_o=4.0, v_y=v_y, s=s, mu0=MU0)
    want = _quad_ss(p, 4.0, v_y, s)
    assert np.allclose(got, want, rtol=1e-5, atol=1e-12)


def test_open_single_scattering_k_negative():
    # Clear water looking up steeply: k = c_view - c_sun v_y / mu0 < 0.
    c_sun, c_view = np.array([0.5, 0.5, 0.5]), np.array([0.1, 0.2, 0.3])
    p = np.ones(3)
    got = S.single_scattering_open(b=B, phase_value=p, beam0=BEAM, c_sun=c_sun, c_view=c_view,
                                   depth_o=10.0, v_y=0.99, s=np.inf, mu0=MU0)
    assert np.all(c_view - c_sun * 0.99 / MU0 < 0)
    assert np.allclose(got, _quad_ss(p, 10.0, 0.99, np.inf, c_sun, c_view), rtol=1e-6)


@pytest.mark.parametrize("k", [-0.3, -1e-12, 0.0, 1e-9, 0.7, 40.0])
def test_march_weights_sum_to_the_integral(k):
    w = S.march_weights(np.array([k]), np.array(5.0), 48)
    exact = 5.0 if k == 0 else -np.expm1(-k * 5.0) / k
    assert np.isclose(w.sum(), exact, rtol=1e-9)
    assert np.all(w > 0)


@pytest.mark.parametrize("v_y,s", [(-0.5, 7.0), (0.0, np.inf), (0.6, np.inf), (-0.2, np.inf)])
def test_march_without_shadow_is_the_closed_form(v_y, s):
    p = np.array([0.1, 0.05, 0.02])
    kw = dict(b=B, phase_value=p, beam0=BEAM, c_sun=C, c_view=C, depth_o=4.0, v_y=np.array(v_y),
              s=np.array(s), mu0=MU0)
    open_ = S.single_scattering_open(**kw)
    marched = S.single_scattering_marched(**kw, visibility=np.ones_like)
    # Exact up to the tail left out (at most TAIL of the slowest band).
    assert np.all(marched <= open_ * (1 + 1e-12))
    assert np.allclose(marched, open_, rtol=S.TAIL * 1.01)


def test_march_with_half_the_ray_shadowed():
    # V = 0 beyond t = 3 m: the integral stops there, in closed form.
    p = np.ones(3)
    kw = dict(b=B, phase_value=p, beam0=BEAM, c_sun=C, c_view=C, depth_o=4.0,
              v_y=np.array(0.0), s=np.array(6.0), mu0=MU0)
    got = S.single_scattering_marched(**kw, visibility=lambda t: (t < 3.0).astype(float),
                                      n_steps=60)
    want = S.single_scattering_open(**{**kw, "s": np.array(3.0)})
    assert np.allclose(got, want, rtol=1e-9)


def test_phase_table_interpolates_the_band_phase():
    wl = np.array([450.0, 550.0, 650.0])
    b = np.array([0.1, 0.2, 0.3])
    tab = S.phase_table("petzold", b=b, wavelength_nm=wl)
    cos = np.cos(np.radians([0.05, 0.5, 3.0, 20.0, 90.0, 170.0]))
    exact = S.band_phase("petzold", cos, b=b, wavelength_nm=wl)
    assert np.allclose(S.phase_from_table(tab, cos), exact, rtol=0.02)
    # Normalised: 2 pi int p dmu = 1 per band (on the table's own grid).
    theta = np.pi * np.linspace(0, 1, 20001) ** 2
    dens = S.phase_from_table(tab, np.cos(theta)) * np.sin(theta)[:, None] * 2 * np.pi
    assert np.allclose(np.trapezoid(dens, theta, axis=0), 1.0, rtol=0.02)


# ---- the shadow map ------------------------------------------------------------------

def _plate_scene():
    scene = Scene()
    scene.add_material(Reflectance.constant(0.5))
    scene.add(plate(-1.0, -3.0, 0.0, -20.0, 2.0))       # x < 0 under 1 m of water
    scene.add(plate(-6.0, -30.0, 30.0, -40.0, 10.0))    # the seabed at 6 m
    return scene


def _exact_visibility(points, to_sun, plate=(-1.0, -3.0, 0.0, -20.0, 2.0)):
    """Lit unless the line towards the sun crosses the small plate (the seabed
    is below every point asked about)."""
    y0, x0, x1, z0, z1 = plate
    p = np.asarray(points, float)
    t = (y0 - p[..., 1]) / to_sun[1]
    q = p + t[..., None] * to_sun
    under = (t > 0) & (q[..., 0] > x0) & (q[..., 0] < x1) & (q[..., 2] > z0) & (q[..., 2] < z1)
    return (~under).astype(float)


def test_shadow_map_heights_and_visibility():
    scene = _plate_scene()
    to_sun = S.refracted_to_sun(50.0, 120.0)
    spec = S.shadow_map_spec(scene.bounds(), np.array([0.0, -3.0, 0.0]), to_sun, size=256,
                             radius_m=25.0)
    hmap = S.shadow_map_numpy(scene, spec)
    # The square map over the tilted projection of the scene's box: most
    # texels see a plate, its corners see nothing.
    assert 0.5 < np.isfinite(hmap).mean() < 1.0
    rng = np.random.default_rng(1)
    pts = np.column_stack([rng.uniform(-8, 8, 4000), rng.uniform(-5.5, -1.2, 4000),
                           rng.uniform(-15, 5, 4000)])
    vis = S.map_visibility(hmap, spec, pts)
    exact = _exact_visibility(pts, to_sun)
    # Away from the shadow's edges (two texels) the map is exact.
    x, y, _ = spec.texel_coords(pts)
    near = np.zeros(len(pts), bool)
    for dx in (-2.5, 0, 2.5):
        for dy in (-2.5, 0, 2.5):
            shifted = pts + (dx * spec.e1 + dy * spec.e2) * spec.texel
            near |= _exact_visibility(shifted, to_sun) != exact
    assert (~near).sum() > 3000
    assert np.allclose(vis[~near], exact[~near], atol=1e-9)
    assert 0.2 < exact.mean() < 0.95        # both cases occur


def test_shadowed_veil_against_direct_integration():
    """A camera looking through the plate's shadow: marched against the map
    vs the integral with the exact visibility on a fine grid."""
    scene = _plate_scene()
    to_sun = S.refracted_to_sun(50.0, 120.0)
    spec = S.shadow_map_spec(scene.bounds(), np.array([0.0, -3.0, 0.0]), to_sun, size=512,
                             radius_m=25.0)
    hmap = S.shadow_map_numpy(scene, spec)
    o = np.array([0.0, -3.0, 0.0])
    rays = np.array([[-0.5, 0.0, -1.0], [-1.0, -0.2, -0.3], [0.3, -0.1, -1.0]])
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    c = np.array([0.1, 0.3])
    b = np.array([0.05, 0.2])
    beam = np.array([1.0, 1.0])
    mu0 = to_sun[1]
    for v in rays:
        s_end = (6.0 - 3.0) / -v[1] if v[1] < 0 else np.inf
        got = S.single_scattering_marched(
            b=b, phase_value=np.ones(2), beam0=beam, c_sun=c, c_view=c, depth_o=3.0,
            v_y=np.array(v[1]), s=np.array(s_end), mu0=mu0, n_steps=96,
            visibility=lambda t, v=v: S.map_visibility(hmap, spec, o + t[..., None] * v))
        t = np.linspace(0.0, min(s_end, 80.0), 400001)
        pts = o + t[:, None] * v
        f = _exact_visibility(pts, to_sun)[:, None] * np.exp(
            -c * (-pts[:, 1:2]) / mu0 - c * t[:, None])
        want = b * beam * np.trapezoid(f, t, axis=0)
        assert np.allclose(got, want, rtol=0.02), (v, got, want)


def test_surface_term_of_a_lit_plate():
    """Camera looking straight down on a grey plate: rho/pi E_b(d) mu0 exp(-c S)
    plus the veil's closed form."""
    scene = Scene()
    scene.add_material(Reflectance.constant(0.4))
    scene.add(plate(-5.0, -50, 50, -50, 50))
    cam = Camera.look_at([0.0, -2.0, 0.0], [0.0, -5.0, 0.0], width=3, height=3, fov_y_deg=2.0,
                         up=(0.0, 0.0, -1.0))
    from aquaspec.gpu.passes.raster import raycast_gbuffer
    gb = raycast_gbuffer(scene, cam)
    to_sun = S.refracted_to_sun(70.0, 0.0)
    c = np.array([0.1, 0.4])
    b = np.array([0.05, 0.2])
    beam = np.array([2.0, 1.0])
    sun = S.SunInputs(beam0=beam, c_sun=c, c_view=c, b=b, to_sun=to_sun,
                      log_phase=np.log(np.full((2, S.PHASE_TABLE_SIZE), 1 / (4 * np.pi))))
    spec = S.shadow_map_spec(scene.bounds(), cam.position, to_sun, size=64, radius_m=10.0)
    out = S.sun_radiance(gb, sun, rho_of_hits=lambda m: np.full((m.sum(), 2), 0.4),
                         height_map=S.shadow_map_numpy(scene, spec), spec=spec)
    s = gb.distance[1, 1]
    surf = 0.4 / np.pi * beam * np.exp(-c * 5.0 / to_sun[1]) * to_sun[1] * np.exp(-c * s)
    veil = S.single_scattering_open(b=b, phase_value=np.full(2, 1 / (4 * np.pi)), beam0=beam,
                                    c_sun=c, c_view=c, depth_o=2.0, v_y=-1.0, s=s,
                                    mu0=to_sun[1])
    assert np.allclose(out[1, 1], surf + veil, rtol=1e-3)


# ---- through render() and the GPU -----------------------------------------------------

def _render(backend, **kw):
    from aquaspec.rendering.renderer import render
    base = dict(water="IB", depth_m=4.0, size=(96, 54), bands=6, light="sun-sky",
                sun_elevation_deg=50.0, sun_azimuth_deg=30.0, sun_shadow_map=256,
                exposure=0.0)
    return render(backend=backend, **{**base, **kw})


def test_numpy_render_adds_the_sun_and_records_it():
    with_sun = _render("numpy", ms_model="seeds")
    light = surface_light("sun-sky", sun_elevation_deg=50.0, sun_azimuth_deg=30.0)
    without = _render("numpy", ms_model="seeds", light=light.without_sun())
    diff = with_sun.linear_rgb - without.linear_rgb
    # The sun only adds light (the camera's RGB of the human sensor may have
    # a negative lobe, so compare the green channel, which has none).
    assert np.all(diff[..., 1] >= -1e-9)
    assert diff[..., 1].mean() > 0.05 * without.linear_rgb[..., 1].mean()
    assert with_sun.params["light"]["sun"]["azimuth_deg"] == 30.0


def test_white_patch_card_is_lit_by_the_sun(device):
    """The diver's grey card 1 m along the view gets the beam and the beam's
    scattering, as the renderer's own pixels do; its colour is made neutral."""
    from aquaspec.rendering.appearance import colour_of_setup
    from aquaspec.colour.bands import Bands
    from aquaspec.rendering.renderer import SpectralSetup, white_card
    from aquaspec.scene.builtin import builtin_scene
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.medium.water import get_water
    res = _render("gpu", sensor="nikon-5100-npl", sun_azimuth_deg=180.0,
                  white_balance="white-patch")
    card = res.params["white_card"]
    scene, cam = builtin_scene(4.0, width=96, height=54)
    np.testing.assert_allclose(card["view_direction"], cam.forward)
    ref = np.array(card["camera_rgb"])
    gains = np.array(res.params["display"]["white_balance_gains"])
    np.testing.assert_allclose(gains * ref, (gains * ref).mean(), rtol=1e-9)
    light = surface_light("sun-sky", sun_elevation_deg=50.0, sun_azimuth_deg=180.0)
    setup = SpectralSetup(get_water("IB"), get_sensor("nikon-5100-npl"), light, Bands(6),
                          seabed=scene.seabed)
    beam = colour_of_setup(setup, **white_card(cam))
    np.testing.assert_allclose(ref, beam["grey_card_rgb"], rtol=1e-9)
    # The sun behind the diver lights the card: more than a third of its light.
    assert np.all(np.array(beam["sun_part"]["grey_card_rgb"]) > ref / 3)


@pytest.mark.parametrize("ms_model,az", [("seeds", 30.0), ("seeds", 200.0),
                                         ("lightfield", 120.0)])
def test_gpu_sun_matches_numpy(device, ms_model, az):
    g = _render("gpu", ms_model=ms_model, sun_azimuth_deg=az).linear_rgb
    n = _render("numpy", ms_model=ms_model, sun_azimuth_deg=az).linear_rgb
    scale = np.abs(n).max()
    err = np.abs(g - n).max(axis=-1) / scale
    assert np.percentile(err, 99) < 2e-4, np.percentile(err, [50, 99, 100])
    assert err.max() < 2e-3


def _shadow_pass(device, width, height, to_sun, map_size):
    """A three-band sun pass with unit inputs, ready to draw a shadow map."""
    from aquaspec.gpu.passes.sun import SunPass
    sp = SunPass(device, width, height, 3, map_size=map_size)
    sp.set_inputs(S.SunInputs(beam0=np.ones(3), c_sun=np.ones(3), c_view=np.ones(3),
                              b=np.ones(3), to_sun=to_sun,
                              log_phase=np.zeros((3, S.PHASE_TABLE_SIZE))),
                  response_weights=np.ones((3, 3)), material_bands=np.ones((1, 3)),
                  sigmoid_centers_t=np.zeros(3))
    return sp


def test_gpu_shadow_map_matches_numpy(device):
    from aquaspec.gpu.passes.raster import RasterPass
    from aquaspec.scene.builtin import builtin_scene
    scene, cam = builtin_scene(4.0, width=64, height=36)
    to_sun = S.refracted_to_sun(45.0, 60.0)
    dev = device
    sp = _shadow_pass(dev, 64, 36, to_sun, 512)
    enc = dev.create_command_encoder()
    spec = sp.encode_shadow_map(enc, RasterPass(dev), scene, cam)
    dev.queue.submit([enc.finish()])
    gpu = sp.read_shadow_map()
    ref = S.shadow_map_numpy(scene, spec)
    both = np.isfinite(gpu) & np.isfinite(ref)
    assert np.array_equal(np.isfinite(gpu), np.isfinite(ref)) or \
        np.mean(np.isfinite(gpu) != np.isfinite(ref)) < 2e-3
    close = np.abs(gpu[both] - ref[both]) < 1e-3
    assert close.mean() > 0.995


def test_froxels_against_each_pixels_own_march():
    """The renderer's froxels (columns of 8x8 pixels, 64 slices) against each
    pixel's own ray marched in 48 steps, single scattering only, built-in
    scene with the sun ahead (shadows of the board and rocks in the veil)."""
    from aquaspec.gpu.passes.raster import raycast_gbuffer
    from aquaspec.rendering.renderer import SpectralSetup
    from aquaspec.scene.builtin import builtin_scene
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.medium.water import get_water
    scene, cam = builtin_scene(4.0, width=160, height=90)
    light = surface_light("sun-sky", sun_elevation_deg=50.0, sun_azimuth_deg=30.0)
    setup = SpectralSetup(get_water("IB"), get_sensor("human"), light, Bands(6),
                          ms_model="seeds")
    gb = raycast_gbuffer(scene, cam)
    sun = setup.sun_inputs()
    hmap, spec = S.numpy_shadow_map(scene, cam, sun.to_sun, size=512)
    black = dict(rho_of_hits=lambda m: np.zeros((m.sum(), 6)), height_map=hmap, spec=spec)
    frox = S.sun_radiance(gb, sun, **black)
    march = S.sun_radiance(gb, sun, method="march", **black)
    rel = np.abs(frox / march - 1.0)
    assert np.median(rel) < 0.005
    assert np.percentile(rel, 99) < 0.06
    assert abs(frox.sum() / march.sum() - 1.0) < 0.01
    with pytest.raises(AquaspecError, match="froxel"):
        S.sun_radiance(gb, sun, method="exact", **black)


@pytest.mark.parametrize("backend", ["numpy", "gpu"])
def test_layers_carry_the_sun(backend, request):
    """D = I - B is t J with the sun's beam in J (a sensor without negative
    lobes); the sun's single scattering is all in the backscatter."""
    if backend == "gpu":
        request.getfixturevalue("device")
    kw = dict(ms_model="seeds", sensor="nikon-5100-npl", sun_azimuth_deg=150.0, layers=True)
    res = _render(backend, **kw)
    lay = res.layers
    hit = lay["range_m"] > 0
    assert np.allclose(res.linear_rgb, lay["direct"] + lay["backscatter"], atol=1e-6)
    tj = lay["transmission"] * lay["surface"]
    assert np.abs(lay["direct"] - tj)[hit].mean() < 1e-5 * np.abs(lay["direct"][hit]).mean()
    light = surface_light("sun-sky", sun_elevation_deg=50.0, sun_azimuth_deg=150.0)
    sky = _render(backend, **{**kw, "light": light.without_sun()}).layers
    # Sun-lit surfaces: brighter J; open water: the beam's scattering in B.
    assert np.mean(lay["surface"][hit][:, 1] > sky["surface"][hit][:, 1] * 1.05) > 0.5
    assert np.all(lay["backscatter"][~hit][:, 1] > sky["backscatter"][~hit][:, 1])


def test_sidecar_names_the_sun_rendering():
    res = _render("numpy", ms_model="seeds")
    assert res.params["sun_rendering"]["shadow_map_texels"] == 256
    assert "froxels" in res.params["sun_rendering"]["single_scattering"]
    overcast = _render("numpy", ms_model="seeds", light="overcast")
    assert "sun_rendering" not in overcast.params


def test_gpu_shadow_map_with_several_mesh_modes(device):
    """Meshes of different vertex layouts (a material, vertex colours) draw
    into one shadow map through pipelines that share their bind group."""
    from aquaspec.gpu.passes.raster import RasterPass
    scene = _plate_scene()
    v = np.array([[2.0, -2.0, -6.0], [5.0, -2.0, -6.0], [5.0, -2.0, -2.0], [2.0, -2.0, -2.0]])
    scene.add(Mesh.flat(v, np.array([[0, 1, 2], [0, 2, 3]]), name="coloured",
                        vertex_rgb=np.full((4, 3), 0.5)))
    cam = Camera.look_at([0.0, -3.0, 0.0], [0.0, -3.0, -1.0], width=32, height=18)
    to_sun = S.refracted_to_sun(50.0, 120.0)
    sp = _shadow_pass(device, 32, 18, to_sun, 256)
    enc = device.create_command_encoder()
    spec = sp.encode_shadow_map(enc, RasterPass(device), scene, cam)
    device.queue.submit([enc.finish()])
    gpu, ref = sp.read_shadow_map(), S.shadow_map_numpy(scene, spec)
    both = np.isfinite(gpu) & np.isfinite(ref)
    assert np.mean(np.isfinite(gpu) != np.isfinite(ref)) < 2e-3
    assert np.mean(np.abs(gpu[both] - ref[both]) < 1e-3) > 0.995
    # The coloured plate is in both maps (its height there, not the seabed's).
    x, y, h = spec.texel_coords(np.array([3.5, -2.0, -4.0]))
    i, j = int(round(y)), int(round(x))
    assert np.isclose(gpu[i, j], ref[i, j], atol=1e-3)
    assert abs(gpu[i, j] - h) < 2 * spec.texel
