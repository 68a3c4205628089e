"""The image-formation layers (aquaspec.rendering.layers): against closed forms for the
seeds' model, against the light field's own decomposition, the GPU against
the NumPy backend, the files, and the CLI."""

import json

import numpy as np
import pytest

from aquaspec.io.layers_file import LAYER_NAMES, read_layers
from aquaspec.rendering import layers as lay
from aquaspec.scene.camera import Camera
from aquaspec.cli import main
from aquaspec.errors import AquaspecError
from aquaspec.scene.gbuffer import PER_PIXEL, GBuffer
from aquaspec.shading.shade import shade_gbuffer
from support.five_bands import A, B, E0, KD, MATS, N, RESP, T_CENTRES, medium

# A camera with a negative lobe, as linear sRGB has.
RESP_NEG = RESP - np.array([0.0, 0.0, 0.3])


def small_gbuffer():
    """A 4x3 G-buffer from a camera at 5 m looking level: open water, surfaces
    of both materials at several distances and slopes, a per-pixel sigmoid."""
    cam = Camera((0.0, -5.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), 4, 3, 3.0, 3.0, 2.0, 1.5)
    dist = np.array([[np.inf, 2.0, 3.5, 7.0], [1.0, 2.5, np.inf, 12.0], [0.5, 4.0, 6.0, np.inf]])
    ny = np.array([[0.0, 0.0, 0.0, 1.0], [-0.6, 0.3, 0.0, 0.9], [0.8, -1.0, 0.0, 0.0]])
    normal = np.zeros((3, 4, 3))
    normal[..., 1] = ny
    normal[..., 2] = np.sqrt(1.0 - ny ** 2)
    material = np.array([[0, 0, 1, 1], [1, 0, 0, PER_PIXEL], [0, 1, 0, 0]], dtype=np.uint32)
    sigmoid = np.zeros((3, 4, 3))
    sigmoid[1, 3] = (0.3, -0.2, 0.4)
    return GBuffer(cam, dist, normal, material, sigmoid, materials=["grey", "ramp"])


def layers_of(gb, m, lightfield=None):
    """Every layer, shading in NumPy (the black G-buffer with one black material)."""
    linear = shade_gbuffer(gb, **m, lightfield=lightfield)["camera_rgb"]
    black = lay.black_gbuffer(gb)
    back = shade_gbuffer(black, **{**m, "material_bands": np.zeros((1, N))},
                         lightfield=lightfield)["camera_rgb"]
    return lay.image_layers(linear, back, gb, m, lightfield)


class TestSeedsClosedForm:
    """The seeds' model: L = exp(-c S) rho E0 exp(-Kd d) (1 + n_y) / 2 / pi + L_MS."""

    def test_every_layer(self):
        gb = small_gbuffer()
        m = medium()
        got = layers_of(gb, m)
        assert list(got) == list(LAYER_NAMES)
        c = A + B
        dirs = gb.camera.ray_directions()
        for (i, j), s in np.ndenumerate(gb.distance.astype(float)):
            v = dirs[i, j]
            if not np.isfinite(s):
                for k in ("direct", "surface", "albedo", "transmission"):
                    np.testing.assert_array_equal(got[k][i, j], 0.0)
                assert got["range_m"][i, j] == 0.0
                continue
            mat = gb.material[i, j]
            if mat == PER_PIXEL:
                from aquaspec.colour.reflectance import sigmoid_at as sigmoid_reflectance
                rho = sigmoid_reflectance(gb.sigmoid[i, j][None], T_CENTRES)[0]
            else:
                rho = MATS[mat]
            depth = 5.0 - s * v[1]
            l_surf = rho * E0 * np.exp(-KD * depth) * (1 + float(gb.normal[i, j, 1])) / 2 / np.pi
            tr = np.exp(-c * s)
            k = c - KD * v[1]
            l_ms = B * E0 / (4 * np.pi) * np.exp(-KD * 5.0) * (1 - np.exp(-k * s)) / k
            np.testing.assert_allclose(got["surface"][i, j], l_surf @ RESP, rtol=1e-12)
            np.testing.assert_allclose(got["albedo"][i, j], (rho * E0 / np.pi) @ RESP, rtol=1e-12)
            np.testing.assert_allclose(got["direct"][i, j], (tr * l_surf) @ RESP, rtol=1e-9)
            np.testing.assert_allclose(got["backscatter"][i, j], l_ms @ RESP, rtol=1e-9)
            j_rgb = l_surf @ RESP
            # (A face looking straight down gets no light in this model: t is
            # 0 where the surface sends nothing.)
            want_t = np.divide((tr * l_surf) @ RESP, j_rgb, out=np.zeros(3), where=j_rgb > 0)
            np.testing.assert_allclose(got["transmission"][i, j], want_t, rtol=1e-12)
            assert got["range_m"][i, j] == pytest.approx(s)

    def test_negative_lobes_keep_transmission_a_transmittance(self):
        """With a negative lobe, the channel's ratio takes the weights by
        magnitude: t between the bands' smallest and largest exp(-c S)."""
        gb = small_gbuffer()
        got = layers_of(gb, medium(response_weights=RESP_NEG))
        # (Lit surfaces: the face looking straight down gets no light, t = 0.)
        hit = np.isfinite(gb.distance) & (gb.normal[..., 1] > -1)
        s = gb.distance[hit].astype(float)[:, None]
        lo, hi = np.exp(-(A + B).max() * s), np.exp(-(A + B).min() * s)
        t = got["transmission"][hit]
        assert np.all(t >= lo * (1 - 1e-12)) and np.all(t <= hi * (1 + 1e-12))
        # (and the surface layer itself goes negative in that channel: it is
        # camera RGB like the image)
        assert got["surface"][..., 2].min() < 0


@pytest.fixture(scope="module")
def tables():
    """Jerlov II on N bands and its light-field tables (Petzold, cone 15 degrees)."""
    from aquaspec.colour.bands import Bands
    from aquaspec.transport.lightfield.bake import lightfield_tables
    from aquaspec.medium.water import get_water
    w = get_water("II").on_bands(Bands(N))
    return w, lightfield_tables(w, phase="petzold", forward_cone_deg=15.0, n_depth=24, n_mu=33)


class TestLightField:
    def test_direct_is_transmission_times_surface(self, tables):
        """Without the spread the light field's target term is T' L_surf
        (T' = exp(-(c - f b) S)), so D = t J for a sensor without negative
        lobes, and D + B is the image."""
        w, tab = tables
        gb = small_gbuffer()
        m = medium(a=w.a, b=w.b, kd=w.kd)
        got = layers_of(gb, m, tab)
        np.testing.assert_allclose(got["direct"], got["transmission"] * got["surface"],
                                   rtol=1e-9, atol=1e-12 * np.abs(got["direct"]).max())
        linear = shade_gbuffer(gb, **m, lightfield=tab)["camera_rgb"]
        np.testing.assert_allclose(got["direct"] + got["backscatter"], linear, rtol=1e-12)
        # The forward cone counts as unscattered: t above exp(-c S) in every channel.
        hit = np.isfinite(gb.distance)
        s = gb.distance[hit].astype(float)[:, None]
        assert np.all(got["transmission"][hit] > np.exp(-(w.a + w.b).max() * s))
        assert np.all(got["direct"][~hit] == 0) and np.all(got["surface"][hit].sum(-1) > 0)


class TestGPU:
    @pytest.mark.parametrize("spread", [False, True])
    def test_gpu_matches_numpy(self, device, spread):
        """The GPU's layers against the NumPy backend's (the backscatter and
        direct signal within the compiled model's interpolation, measured
        4e-4 of the largest value; the rest from the same NumPy code on the
        read-back G-buffer)."""
        import aquaspec.rendering.api as ar
        kw = dict(water="II", depth_m=4, bands=6, size=(64, 36), sensor="nikon-5100-npl",
                  cone_spread=spread, layers=True)
        g = ar.render(**kw)
        n = ar.render(backend="numpy", **kw)
        for k in LAYER_NAMES:
            scale = np.abs(n.layers[k]).max()
            tol = 2e-3 if k in ("backscatter", "direct") else 1e-5
            np.testing.assert_allclose(g.layers[k], n.layers[k], rtol=0, atol=tol * scale,
                                       err_msg=k)
        np.testing.assert_allclose(g.layers["direct"] + g.layers["backscatter"], g.linear_rgb,
                                   atol=1e-6 * np.abs(g.linear_rgb).max())
        assert g.params["layers"]["names"] == list(LAYER_NAMES)
        if spread:
            # The spread moves some of a target's light onto open water beside it.
            hit = g.layers["range_m"] > 0
            assert np.abs(g.layers["direct"][~hit]).max() > 0
        else:
            d, tj = g.layers["direct"], g.layers["transmission"] * g.layers["surface"]
            np.testing.assert_allclose(d, tj, rtol=0, atol=2e-3 * np.abs(d).max())

    def test_rgbd(self, device):
        """An RGB-D photograph: the range is the distance along each ray (the
        depth map is z), and the albedo follows the photograph's colours."""
        import aquaspec.rendering.api as ar
        rng = np.random.default_rng(3)
        img = rng.random((12, 16, 3))
        dep = np.full((12, 16), 2.0)
        res = ar.render(rgbd=(img, dep, (10.0, 10.0, 8.0, 6.0)), water="IB", depth_m=3,
                        bands=8, layers=True)
        r = res.layers["range_m"]
        x = (np.arange(16) + 0.5 - 8.0) / 10.0
        y = (np.arange(12) + 0.5 - 6.0) / 10.0
        want = 2.0 * np.sqrt(1 + x[None, :] ** 2 + y[:, None] ** 2)
        np.testing.assert_allclose(r, want, rtol=1e-5)
        alb = res.layers["albedo"].reshape(-1, 3)
        corr = np.corrcoef(alb[:, 0], img.reshape(-1, 3)[:, 0])[0, 1]
        assert corr > 0.95


class TestBlackGbuffer:
    def test_same_geometry_no_reflectance(self):
        gb = small_gbuffer()
        black = lay.black_gbuffer(gb)
        np.testing.assert_array_equal(black.distance, gb.distance)
        np.testing.assert_array_equal(black.normal, gb.normal)
        assert len(black.materials) == 1 and np.all(black.material == 0)
        assert not np.any(black.materials[0].values)
        with pytest.raises(AquaspecError, match="must be an aquaspec.scene.gbuffer.GBuffer"):
            lay.black_gbuffer("x")


class TestCommand:
    def test_render_layers(self, tmp_path, device):
        out, layers = tmp_path / "x.png", tmp_path / "x_layers.exr"
        lin = tmp_path / "x.npy"
        assert main(["render", "--water", "3C", "--size", "48x27", "--bands", "4", "-o",
                     str(out), "--linear", str(lin), "--layers", str(layers)]) == 0
        side = json.loads((tmp_path / "x.png.json").read_text())
        assert side["files"]["layers"] == "x_layers.exr"
        assert side["layers"]["names"] == list(LAYER_NAMES)
        got, meta = read_layers(layers)
        assert meta["water"]["name"] == "3C" and meta["files"]["layers"] == "x_layers.exr"
        np.testing.assert_allclose(got["direct"] + got["backscatter"], np.load(lin),
                                   atol=1e-6 * np.abs(np.load(lin)).max())

    def test_bad_layers_path_fails_before_rendering(self, tmp_path, capsys):
        assert main(["render", "--size", "48x27", "--bands", "4", "-o", str(tmp_path / "x.png"),
                     "--layers", str(tmp_path / "x.tif")]) == 2
        err = capsys.readouterr().err
        assert "x.tif" in err and ".npz" in err
        assert list(tmp_path.iterdir()) == []
