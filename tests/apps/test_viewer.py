"""The interactive viewer, driven headless."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from aquaspec.cli import main  # noqa: E402
from aquaspec.errors import AquaspecError  # noqa: E402
from aquaspec.apps.viewer import Viewer  # noqa: E402

pytestmark = pytest.mark.gpu


def test_controls_re_render():
    import matplotlib.pyplot as plt
    fig = plt.figure()
    v = Viewer(96, 54, water="IB", depth_m=5.0, bands=4).attach(fig)
    first = v.linear.copy()
    v.controls["depth"].set_val(20.0)
    assert v.state["depth_m"] == 20.0 and v.linear.mean() < first.mean()
    v.controls["bands"].set_val(8)
    assert v._renderer.deferred.n_bands == 8
    v.controls["water"].set_active(list(v.controls["water"].labels).index(
        next(t for t in v.controls["water"].labels if t.get_text() == "9C")))
    assert v.state["water"] == "9C"
    assert "9C" in v.title() and np.all(np.isfinite(v.linear))
    plt.close(fig)


def test_unknown_setting():
    with pytest.raises(AquaspecError, match="unknown viewer setting"):
        Viewer(32, 18).update(colour="red")


def test_no_display_is_a_clear_error(capsys):
    assert main(["view", "--size", "64x36"]) == 2
    assert "cannot open a window" in capsys.readouterr().err


def test_ms_model_switch_and_cached_setups(recwarn):
    import matplotlib.pyplot as plt
    fig = plt.figure()
    v = Viewer(96, 54, water="3C", depth_m=5.0, bands=4, ms_model="seeds",
               cone_spread=False).attach(fig)
    seeds = v.linear.copy()
    n_warn = len(recwarn)
    assert n_warn > 0          # 3C's filled red values are reported once ...
    v.controls["ms_model"].set_active(list(t.get_text() for t in
                                           v.controls["ms_model"].labels).index("lightfield"))
    assert v.state["ms_model"] == "lightfield" and "light field" in v.title()
    lf = v.linear.copy()
    assert np.all(np.isfinite(lf)) and not np.allclose(lf, seeds, rtol=1e-3)
    setup = v._setup("3C", "human", 4, "lightfield")
    v.update(depth_m=6.0)
    v.update(water="IB")
    v.update(water="3C")
    # ... not again when the water comes back, and its setup is the same object.
    assert not [w for w in recwarn.list[n_warn:] if "3C" in str(w.message)]
    assert v._setup("3C", "human", 4, "lightfield") is setup
    # The cone spread check box: another light-field image, and back.
    plain = v.linear.copy()
    v.controls["cone_spread"].set_active(0)
    assert v.state["cone_spread"] and "cone spread" in v.title()
    assert not np.allclose(v.linear, plain, rtol=1e-3)
    v.controls["cone_spread"].set_active(0)
    assert not v.state["cone_spread"]
    np.testing.assert_allclose(v.linear, plain, rtol=1e-6)
    plt.close(fig)


def test_default_is_the_light_field_with_the_spread():
    v = Viewer(64, 36, bands=4)
    v.update()
    assert v.state["ms_model"] == "lightfield" and v.state["cone_spread"]
    assert "light field + cone spread" in v.title()
    # The built-in scene's sand is the light field's lower boundary, per depth.
    (setup,) = v._setups.values()
    assert setup.seabed is v._scene.seabed and setup.seabed.depth_m > 5.0
    v.update(depth_m=8.0)
    assert len(v._setups) == 2 and max(x.seabed.depth_m for x in v._setups.values()) > 8.0


def test_shallower_raises_the_camera_in_the_same_scene():
    """Going up keeps the scene and its light field (no new setup, no new
    solve): the camera rises in it, and the frame is that camera's render."""
    from aquaspec.rendering.renderer import Renderer
    v = Viewer(64, 36, bands=4, depth_m=6.0)
    v.update()
    scene = v._scene
    v.update(depth_m=2.5)
    assert v._scene is scene and len(v._setups) == 1
    assert v._camera.depth_m == pytest.approx(2.5)
    np.testing.assert_allclose(v._camera.forward, scene.camera.forward)
    (setup,) = v._setups.values()
    ref = Renderer(64, 36, 4).render_scene(scene, v._camera, setup)
    np.testing.assert_allclose(v.linear, ref, rtol=1e-5, atol=1e-7 * np.abs(ref).max())
    v.update(depth_m=7.0)               # deeper than the scene was built for: a new one
    assert v._scene is not scene and v._camera.depth_m == pytest.approx(7.0)


def test_multiple_scattering_spread():
    """spread_scattering="multiple" (aquaspec view --spread-scattering multiple):
    the setups use it with the spread (the built-in scene's seabed: the water
    table built on the CPU with its node layers), the title says so, and the
    image differs from the single-scattering spread's."""
    single = Viewer(64, 36, bands=4).update().copy()
    v = Viewer(64, 36, bands=4, spread_scattering="multiple")
    multi = v.update()
    assert "cone spread (multiple)" in v.title()
    (setup,) = v._setups.values()
    assert setup.spread_scattering == "multiple" and setup.seabed is not None
    assert np.abs(multi.astype(float) - single).max() > 0
    v.update(cone_spread=False)
    assert all(x.spread_scattering == "single" for x in v._setups.values() if not x.cone_spread)
    with pytest.raises(AquaspecError, match="spread_scattering='double'"):
        Viewer(32, 18, spread_scattering="double")


def test_cone_spread_leaves_the_seeds_model_alone():
    v = Viewer(64, 36, bands=4, ms_model="seeds")
    seeds = v.update().copy()
    assert "cone spread" not in v.title()
    np.testing.assert_array_equal(v.update(cone_spread=True), seeds)


def test_unknown_ms_model():
    with pytest.raises(AquaspecError, match="unknown multiple-scattering model 'mie'.*seeds"):
        Viewer(32, 18, ms_model="mie")
    with pytest.raises(AquaspecError, match="unknown multiple-scattering model 'mie'"):
        Viewer(32, 18).update(ms_model="mie")


def test_exposure_alone_reuses_the_linear_image():
    v = Viewer(64, 36, bands=4)
    v.update()
    lin = v.linear
    dark = v.update(exposure=-3.0).astype(float).mean()
    assert v.linear is lin                       # not rendered again
    assert v.update(exposure=1.0).astype(float).mean() > dark
    v.update(depth_m=8.0)
    assert v.linear is not lin


def test_sun_and_wind_controls():
    """The sun's sliders add the beam (an overcast sky at elevation 0), the
    wind's adds its caustics; bad values are named."""
    import matplotlib.pyplot as plt
    fig = plt.figure()
    v = Viewer(64, 36, water="IB", depth_m=3.0, bands=4, ms_model="seeds").attach(fig)
    overcast = v.linear.copy()
    assert "overcast" in v.title()
    v.controls["sun_elevation"].set_val(60.0)
    assert "sun 60/150 deg" in v.title()
    sunny = v.linear.copy()
    assert not np.allclose(sunny, overcast)
    v.controls["wind"].set_val(3.0)
    assert "wind 3 m/s" in v.title()
    assert np.abs(v.linear - sunny).max() > 0.02 * np.abs(sunny).max()
    assert np.all(np.isfinite(v.linear))
    v.controls["sun_elevation"].set_val(0.0)
    np.testing.assert_allclose(v.linear, overcast, rtol=1e-6, atol=1e-9)
    plt.close(fig)
    with pytest.raises(AquaspecError, match="wind 40"):
        Viewer(32, 18).update(wind=40.0)
    with pytest.raises(AquaspecError, match="sun elevation -5"):
        Viewer(32, 18, sun_elevation_deg=-5.0)


def test_a_renderer_per_band_count_is_kept():
    """Going back to a band count reuses its renderer (its compiled passes)."""
    v = Viewer(64, 36, bands=4, ms_model="seeds")
    v.update()
    four = v._renderer
    v.update(bands=6)
    assert v._renderer is not four and v._renderer.deferred.n_bands == 6
    v.update(bands=4)
    assert v._renderer is four
