"""shade_gbuffer, the NumPy reference of the deferred pass: against closed
forms, against per-ray model.pixel_radiance, and its input checks."""

import numpy as np
import pytest

from aquaspec.medium.interface import N_WATER
from aquaspec.transport import monzon2022 as model

from aquaspec.shading import shade as shading
from aquaspec.scene.camera import Camera
from aquaspec.errors import AquaspecError
from aquaspec.scene.gbuffer import PER_PIXEL, GBuffer
from aquaspec.colour.reflectance import sigmoid_at as sigmoid_reflectance
from aquaspec.shading.shade import shade_gbuffer
from support.five_bands import A, B, E0, KD, MATS, N, RESP, T_CENTRES, medium

#: Both sides are float64; only rounding separates them.
RTOL = 1e-12


def one_ray(position, forward, up=(0.0, 0.0, 1.0), *, distance=np.inf, normal=(0, 0, 0),
            material=0, sigmoid=(0, 0, 0)):
    """A 1x1 G-buffer whose single ray is exactly ``forward``."""
    cam = Camera(position, forward, up, 1, 1, 1.0, 1.0, 0.5, 0.5)
    return GBuffer(cam, [[distance]], [[normal]], [[material]], [[sigmoid]],
                   materials=["grey", "ramp"])


class TestSigmoidReflectance:
    def test_known_values(self):
        t = np.array([-1.0, 0.0, 2.0])
        # x = t^2 - t + 0.5 -> 2.5, 0.5, 2.5
        x = np.array([2.5, 0.5, 2.5])
        np.testing.assert_allclose(sigmoid_reflectance([1.0, -1.0, 0.5], t),
                                   0.5 + x / (2 * np.sqrt(1 + x * x)), rtol=RTOL)

    def test_limits_and_shape(self):
        c = np.array([[0, 0, 0], [0, 0, 1e30], [0, 0, -1e30]], dtype=float)
        r = sigmoid_reflectance(c, T_CENTRES)
        assert r.shape == (3, N)
        np.testing.assert_allclose(r[0], 0.5)
        np.testing.assert_allclose(r[1], 1.0, atol=1e-12)
        np.testing.assert_allclose(r[2], 0.0, atol=1e-12)


class TestClosedForms:
    def test_open_water_horizontal(self):
        """L = b E0 / (4 pi) e^{-Kd d} / c for a horizontal ray to infinity."""
        d = 7.0
        gb = one_ray((0.0, -d, 0.0), (1.0, 0.0, 0.0), up=(0.0, 1.0, 0.0))
        out = shade_gbuffer(gb, **medium(), return_radiance=True)
        expect = B * E0 / (4 * np.pi) * np.exp(-KD * d) / (A + B)
        np.testing.assert_allclose(out["radiance"][0, 0], expect, rtol=RTOL)
        np.testing.assert_allclose(out["camera_rgb"][0, 0], expect @ RESP, rtol=RTOL)

    @pytest.mark.parametrize("ambient, g", [("cosine", 1.0), ("uniform", 1.0)])
    def test_looking_down_at_seabed(self, ambient, g):
        d, h = 4.0, 3.0
        gb = one_ray((0.0, -d, 0.0), (0.0, -1.0, 0.0), distance=h, normal=(0, 1, 0),
                     material=1)
        out = shade_gbuffer(gb, **medium(ambient=ambient), return_radiance=True)
        c = A + B
        l_surf = MATS[1] * E0 * np.exp(-KD * (d + h)) * g / np.pi
        l_ms = B * E0 / (4 * np.pi) * np.exp(-KD * d) * (1 - np.exp(-(c + KD) * h)) / (c + KD)
        np.testing.assert_allclose(out["radiance"][0, 0], np.exp(-c * h) * l_surf + l_ms,
                                   rtol=RTOL)

    @pytest.mark.parametrize("kd_scale", [0.5, 2.0])   # k > 0 and k < 0
    def test_looking_up_into_snells_window(self, kd_scale):
        d = 5.0
        kd = (A + B) * kd_scale
        gb = one_ray((0.0, -d, 0.0), (0.0, 1.0, 0.0))
        out = shade_gbuffer(gb, **medium(kd=kd), return_radiance=True)
        c = A + B
        k = c - kd
        l_sky = E0 * N_WATER ** 2 / np.pi
        l_ms = B * E0 / (4 * np.pi) * np.exp(-kd * d) * (1 - np.exp(-k * d)) / k
        np.testing.assert_allclose(out["radiance"][0, 0], np.exp(-c * d) * l_sky + l_ms,
                                   rtol=1e-10)

    def test_down_facing_surface_is_dark_with_cosine_ambient(self):
        gb = one_ray((0.0, -6.0, 0.0), (0.0, 1.0, 0.0), distance=2.0, normal=(0, -1, 0),
                     material=0)
        out = shade_gbuffer(gb, **medium(), return_radiance=True)
        l_ms = model.l_ms_seeds(B, A + B, KD, E0, 6.0, 1.0, 2.0)
        np.testing.assert_allclose(out["radiance"][0, 0], l_ms, rtol=RTOL)

    def test_hit_beyond_the_surface_is_open_water(self):
        """An up ray cannot reach a hit above the water: it ends at the surface."""
        beyond = one_ray((0.0, -2.0, 0.0), (0.0, 1.0, 0.0), distance=3.0, normal=(0, -1, 0))
        open_water = one_ray((0.0, -2.0, 0.0), (0.0, 1.0, 0.0))
        np.testing.assert_allclose(shade_gbuffer(beyond, **medium())["camera_rgb"],
                                   shade_gbuffer(open_water, **medium())["camera_rgb"],
                                   rtol=RTOL)


def random_gbuffer(rng, width=7, height=5):
    cam = Camera.look_at((0.3, -6.0, 0.0), (1.0, -4.0, 5.0), width=width, height=height,
                         fov_y_deg=120.0)
    shape = (height, width)
    dist = rng.uniform(0.5, 20.0, shape)
    dist[rng.random(shape) < 0.3] = np.inf
    nrm = rng.normal(size=shape + (3,))
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    mat = rng.integers(0, 2, shape).astype(np.uint32)
    mat[rng.random(shape) < 0.4] = PER_PIXEL
    sig = rng.normal(size=shape + (3,))
    return GBuffer(cam, dist, nrm, mat, sig, materials=["grey", "ramp"])


class TestAgainstPixelRadiance:
    """Each pixel, one call of model.pixel_radiance with scalars per ray."""

    @pytest.mark.parametrize("ambient", list(model.AMBIENT_MODELS))
    @pytest.mark.parametrize("seed", [0, 1])
    def test_per_pixel(self, seed, ambient):
        gb = random_gbuffer(np.random.default_rng(seed))
        out = shade_gbuffer(gb, **medium(ambient=ambient), return_radiance=True)
        cam = gb.camera
        dirs = cam.ray_directions()
        d_o = -cam.position[1]
        for i in range(cam.height):
            for j in range(cam.width):
                v = dirs[i, j]
                s = float(gb.distance[i, j])
                reaches = np.isfinite(s) and (v[1] <= 0 or s <= d_o / v[1])
                if reaches:
                    m = int(gb.material[i, j])
                    if m == PER_PIXEL:
                        c0, c1, c2 = gb.sigmoid[i, j].astype(float)
                        x = c0 * T_CENTRES ** 2 + c1 * T_CENTRES + c2
                        rho = 0.5 + x / (2 * np.sqrt(1 + x * x))
                    else:
                        rho = MATS[m]
                    expect = model.pixel_radiance(
                        a=A, b=B, kd=KD, e0=E0, depth_o=d_o, v_y=v[1], s=s, rho=rho,
                        surface_depth=-(cam.position[1] + s * v[1]),
                        n_y=float(gb.normal[i, j, 1]), ambient=ambient)
                else:
                    expect = model.pixel_radiance(a=A, b=B, kd=KD, e0=E0, depth_o=d_o,
                                                  v_y=v[1], s=np.inf)
                np.testing.assert_allclose(out["radiance"][i, j], expect, rtol=RTOL)
                np.testing.assert_allclose(out["camera_rgb"][i, j], expect @ RESP, rtol=RTOL)

    def test_chunking_does_not_change_the_result(self, monkeypatch):
        gb = random_gbuffer(np.random.default_rng(3), width=9, height=11)
        whole = shade_gbuffer(gb, **medium())["camera_rgb"]
        monkeypatch.setattr(shading, "_CHUNK_ELEMENTS", 2 * 9 * N)   # two rows per chunk
        np.testing.assert_array_equal(shade_gbuffer(gb, **medium())["camera_rgb"], whole)

    def test_output_is_finite_and_positive(self):
        out = shade_gbuffer(random_gbuffer(np.random.default_rng(4)), **medium())
        assert np.all(np.isfinite(out["camera_rgb"]))
        assert np.all(out["camera_rgb"] > 0)
        assert "radiance" not in out


class TestInputErrors:
    def gb(self):
        return random_gbuffer(np.random.default_rng(0))

    @pytest.mark.parametrize("over, match", [
        (dict(b=B[:3]), "b has shape \\(3,\\); expected \\(5,\\)"),
        (dict(b=-B), "negative"),
        (dict(e0=np.where(np.arange(N) == 2, np.nan, E0)), "NaN"),
        (dict(a=np.zeros(N), b=np.zeros(N)), "extinction"),
        (dict(response_weights=RESP[:, :2]), "response_weights"),
        (dict(material_bands=MATS[:1]), "2 materials"),
        (dict(material_bands=MATS[:, :3]), "material_bands"),
        (dict(ambient="hemisphere"), "unknown ambient model 'hemisphere'"),
        (dict(sigmoid_centers_t=T_CENTRES[:2]), "sigmoid_centers_t"),
    ])
    def test_bad_medium(self, over, match):
        with pytest.raises(AquaspecError, match=match):
            shade_gbuffer(self.gb(), **medium(**over))

    def test_camera_above_water(self):
        gb = one_ray((0.0, 0.5, 0.0), (1.0, 0.0, 0.0), up=(0.0, 1.0, 0.0))
        with pytest.raises(AquaspecError, match="above the water"):
            shade_gbuffer(gb, **medium())

    def test_non_finite_sigmoid(self):
        gb = one_ray((0.0, -3.0, 0.0), (0.0, -1.0, 0.0), distance=1.0, normal=(0, 1, 0),
                     material=PER_PIXEL, sigmoid=(np.nan, 0.0, 0.0))
        with pytest.raises(AquaspecError, match="sigmoid"):
            shade_gbuffer(gb, **medium())

    def test_not_a_gbuffer(self):
        with pytest.raises(AquaspecError, match="GBuffer"):
            shade_gbuffer({"distance": 1}, **medium())


def test_lightfield_shading_matches_pixel_radiance():
    """shade_gbuffer with light-field tables is LightfieldTables.pixel_radiance per pixel."""
    from aquaspec.colour.bands import Bands
    from aquaspec.scene.camera import Camera
    from aquaspec.scene.gbuffer import GBuffer
    from aquaspec.transport.lightfield.bake import lightfield_tables
    from aquaspec.colour.reflectance import Reflectance
    from aquaspec.medium.water import load_water
    bands = Bands(6)
    bw = load_water("IB").on_bands(bands)
    tables = lightfield_tables(bw, phase="petzold")
    cam = Camera.look_at([0, -4, 0], [0, -5, -6], width=8, height=6, fov_y_deg=90)
    dist = np.full((6, 8), np.inf)
    dist[3:] = 2.5
    normal = np.zeros((6, 8, 3))
    normal[..., 1] = 1.0
    grey = Reflectance.constant(0.3)
    gb = GBuffer(cam, dist, normal, np.zeros((6, 8), np.uint32), np.zeros((6, 8, 3)), [grey])
    e0 = np.full(6, 0.4)
    w = np.eye(6)[:, :3]
    out = shade_gbuffer(gb, a=bw.a, b=bw.b, kd=bw.kd, e0=e0, response_weights=w,
                        material_bands=grey.on_bands(bands)[None], sigmoid_centers_t=np.zeros(6),
                        return_radiance=True, lightfield=tables)
    dirs = cam.ray_directions()
    for i, j in [(0, 0), (2, 5), (4, 3), (5, 7)]:
        v_y = dirs[i, j, 1]
        hit = np.isfinite(dist[i, j])
        kw = dict(rho=grey.on_bands(bands), surface_depth=np.array([4 - dist[i, j] * v_y]),
                  n_y=np.array([1.0])) if hit else {}
        want = tables.pixel_radiance(a=bw.a, b=bw.b, e0=e0, depth_o=4.0,
                                     v_y=np.array([v_y]), s=np.array([dist[i, j]]), **kw)
        np.testing.assert_allclose(out["radiance"][i, j], np.ravel(want), rtol=1e-12)


def _spread_case(dist, fov_y_deg, cone_spread, cone_deg=30.0):
    """Light-field shading of a G-buffer: camera at 5 m looking along -z, a
    grey surface facing it where ``dist`` is finite."""
    from aquaspec.colour.bands import Bands
    from aquaspec.transport.lightfield.bake import lightfield_tables
    from aquaspec.colour.reflectance import Reflectance
    from aquaspec.medium.water import load_water
    h, w = dist.shape
    bands = Bands(4)
    bw = load_water("II").on_bands(bands)
    tables = lightfield_tables(bw, phase="ff", backscatter=0.0183, forward_cone_deg=cone_deg,
                               cone_spread=cone_spread)
    cam = Camera.look_at([0, -5, 0], [0, -5, -3], width=w, height=h, fov_y_deg=fov_y_deg)
    normal = np.zeros((h, w, 3))
    normal[..., 2] = 1.0
    grey = Reflectance.constant(0.3)
    gb = GBuffer(cam, dist, normal, np.zeros((h, w), np.uint32), np.zeros((h, w, 3)), [grey])
    return shade_gbuffer(gb, a=bw.a, b=bw.b, kd=bw.kd, e0=np.full(4, 0.4),
                         response_weights=np.eye(4)[:, :3],
                         material_bands=grey.on_bands(bands)[None], sigmoid_centers_t=np.zeros(4),
                         return_radiance=True, lightfield=tables)["radiance"]


def test_cone_spread_is_the_per_pixel_cone_convolved():
    """The split keeps the per-pixel sum (radiance without the cone + cone term
    = the per-pixel cone model); the convolution leaves a uniform cone term
    alone and turns a single pixel's into the kernel."""
    from aquaspec.colour.bands import Bands
    from aquaspec.transport.lightfield.bake import lightfield_tables
    from aquaspec.transport.lightfield.cone import cone_spread_kernel, spread_cone_light
    from aquaspec.medium.water import load_water
    bw = load_water("II").on_bands(Bands(3))
    t = lightfield_tables(bw, phase="ff", backscatter=0.0183, forward_cone_deg=20.0,
                          cone_spread=True)
    v = np.array([[-0.5], [0.0], [0.3], [0.9]])
    s_ = np.array([[2.0], [3.0], [3.0], [np.inf]])
    kw = dict(a=bw.a, b=bw.b, e0=np.full(3, 0.3), depth_o=5.0, v_y=v, s=s_,
              rho=np.full(3, 0.2), surface_depth=5.0 - np.where(np.isfinite(s_), s_, 0) * v,
              n_y=np.zeros((4, 1)))
    base, cone = t.pixel_radiance(split_cone=True, **kw)
    np.testing.assert_allclose(base + cone, t.pixel_radiance(**kw), rtol=1e-12)
    assert np.all(cone[:3] != 0)
    fy = 30.0
    uniform = np.broadcast_to(cone[1], (20, 30, 3)).copy()
    np.testing.assert_allclose(spread_cone_light(uniform, t.cone, fy), uniform, rtol=1e-10)
    k = cone_spread_kernel(t.cone.offset_rad, t.cone.offset_cdf[0], fy)
    r = k.shape[0] // 2
    delta = np.zeros((2 * r + 9, 2 * r + 9, 3))
    delta[r + 4, r + 4] = 1.0
    out = spread_cone_light(delta, t.cone, fy)
    np.testing.assert_allclose(out[4:-4, 4:-4, 0], k, atol=1e-12)


def test_cone_spread_moves_light_without_losing_it():
    """A small target in open water: its cone light goes partly to the water
    around it (brighter there), the target keeps less, and the image's sum
    (the total light, open water at the border) is the same."""
    dist = np.full((80, 80), np.inf)
    dist[36:44, 36:44] = 3.0
    # A 10 degree cone is 20 pixels here: all of it stays inside the frame.
    spread = _spread_case(dist, 40.0, True, cone_deg=10.0)
    plain = _spread_case(dist, 40.0, False, cone_deg=10.0)
    np.testing.assert_allclose(spread.sum(axis=(0, 1)), plain.sum(axis=(0, 1)), rtol=1e-6)
    ring = np.zeros((80, 80), bool)
    ring[34:46, 34:46] = True
    ring[36:44, 36:44] = False
    moved = np.abs(spread - plain)
    assert np.all(moved[ring].max(axis=0) > 1e-3 * np.abs(plain[ring]).max(axis=0))
    # The target's cone term leaves its centre and arrives around it.
    centre = (spread - plain)[39:41, 39:41]
    around = (spread - plain)[ring]
    assert np.all(np.sign(centre.sum(axis=(0, 1))) == -np.sign(around.sum(axis=0)))
    # Far from the target (three kernel radii) next to nothing arrives (the
    # pyramid's widest level reaches a little past the kernel).
    np.testing.assert_allclose(spread[:10], plain[:10], rtol=1e-4)


def test_cone_spread_with_row_chunks(monkeypatch):
    """The cone terms of all row chunks reach the convolution (NumPy shades in chunks)."""
    dist = np.full((24, 24), np.inf)
    dist[8:16, 8:16] = 3.0
    whole = _spread_case(dist, 40.0, True, cone_deg=10.0)
    monkeypatch.setattr(shading, "_CHUNK_ELEMENTS", 24 * 4 * 5)    # five rows per chunk
    np.testing.assert_allclose(_spread_case(dist, 40.0, True, cone_deg=10.0), whole, rtol=1e-12)
