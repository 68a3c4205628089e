"""render() with the direct sun: NumPy and GPU, layers, the sidecar, the white card."""

import numpy as np
import pytest

from aquaspec.light.sky import surface_light


def _render(backend, **kw):
    from aquaspec.rendering.api import render
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
    from aquaspec.rendering.setup import SpectralSetup
    from aquaspec.rendering.api import white_card
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
                          seabed=scene.seabed, surface="flat")        # render's default
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
    # (2.3e-4 measured under the flat surface, the default; under 2e-4 with the index-matched)
    assert np.percentile(err, 99) < 3e-4, np.percentile(err, [50, 99, 100])
    # The scene mirrored in the surface from below: on a silhouette the raster
    # and the ray cast of the mirrored camera may see different surfaces (two
    # pixels of 5184, 5.8e-2 and 1.6e-2, where the raster meets a terrain
    # fold's far side 1-2 m nearer than the ray cast; 2026-11-28).
    assert np.sum(err > 2e-3) <= 2 and err.max() < 0.1


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
