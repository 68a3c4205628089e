"""render(camera_model=...): the port, lens and sensor around a real render.

Small NumPy-backend renders (the camera model's steps are the same on the
GPU path; one GPU render checks the G-buffer read-back), and the sensor
step on a flat grey frame through the pipeline's own radiometry.
"""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.optics.presets import get_camera_model
from aquaspec.optics.remap import Intrinsics, water_intrinsics
from aquaspec.rendering.api import render
from aquaspec.rendering.camera_model import _expose, camera_view, channel_wavelengths
from aquaspec.scene.builtin import builtin_scene

SIZE = (128, 72)
#: Standard errors allowed in the statistical checks (as tests/optics/test_sensor.py).
Z = 4.5


def _render(model, **kw):
    return render(size=SIZE, bands=6, sensor="nikon5100-npl", backend="numpy",
                  camera_model=model, **kw)


class TestRender:
    def test_flat_port_image_sidecar_and_raw(self):
        res = _render("dslr-flat-port")
        _, cam = builtin_scene(5.0, width=SIZE[0], height=SIZE[1])
        p = res.params
        assert p["camera"]["fx"] == pytest.approx(cam.fx)          # the sensor's camera
        model = get_camera_model("dslr-flat-port")
        water = water_intrinsics(Intrinsics.of(cam), model.port, Bands(6).centers_nm,
                                 model.min_distance_m)
        assert p["camera_model"]["pinhole_in_water"]["fx"] == pytest.approx(water.fx)
        # The field shrinks by n_w = 1.34, a little less for the margin of surfaces
        # 0.3 m away (the non-central shift, FlatPort.centre_ratio).
        assert 1.25 < water.fx / cam.fx < 1.34
        assert res.raw.dtype == np.uint16 and res.raw.shape == (SIZE[1], SIZE[0], 3)
        assert res.raw.max() <= 2 ** 14 - 1
        assert np.all(np.isfinite(res.linear_rgb)) and res.display.dtype == np.uint8
        assert p["camera_model"]["port"]["kind"] == "flat"
        assert p["camera_model"]["exposure_s_used"] <= 1 / 60

    def test_seeded(self):
        a = _render("machine-vision-dome:seed=3")
        b = _render("machine-vision-dome:seed=3")
        c = _render("machine-vision-dome:seed=4")
        np.testing.assert_array_equal(a.raw, b.raw)
        assert np.any(a.raw != c.raw)

    def test_per_band_port_with_radiance(self):
        # With the band radiance at hand the port resamples each band; the
        # radiance returned is the sensor's (resampled, before lens and noise).
        res = _render("dslr-flat-port:dof=off", return_radiance=True)
        assert res.radiance.shape == (SIZE[1], SIZE[0], 6)
        assert np.all(np.isfinite(res.radiance))
        plain = _render(None, return_radiance=True)
        assert np.abs(res.radiance - plain.radiance).max() > 0.05 * plain.radiance.max()

    def test_off_by_default(self):
        res = render(size=SIZE, bands=6, backend="numpy")
        assert res.raw is None and "camera_model" not in res.params

    def test_dome_keeps_the_view_and_vignettes(self):
        plain = _render(None)
        dome = _render("machine-vision-dome:dof=off,exposure=0.001,iso=100")
        assert dome.params["camera"]["fx"] == pytest.approx(plain.params["camera"]["fx"])
        # Without noise-free output, compare the corners with the centre over
        # many pixels: cos^4 at the corner of a 60 degree vertical field.
        ratio_dome = dome.linear_rgb[:8, :8].mean() / dome.linear_rgb[32:40, 60:68].mean()
        ratio_plain = plain.linear_rgb[:8, :8].mean() / plain.linear_rgb[32:40, 60:68].mean()
        tan2 = ((64 - 4) ** 2 + (36 - 4) ** 2) / dome.params["camera"]["fx"] ** 2
        assert ratio_dome / ratio_plain == pytest.approx(1 / (1 + tan2) ** 2, rel=0.1)

    def test_flat_port_refused_for_rgbd(self):
        # (camera_view directly: a photograph's G-buffer fit costs seconds on a fresh cache)
        _, cam = builtin_scene(5.0, width=16, height=16)
        view = SimpleNamespace(camera=cam, from_rgbd=True)
        setup = SimpleNamespace(bands=Bands(4))
        with pytest.raises(AquaspecError, match="flat port"):
            camera_view(view, "dslr-flat-port", setup)
        same, cp = camera_view(view, "machine-vision-dome", setup)
        assert same is view and cp.water_camera is cam

    @pytest.mark.gpu
    def test_gpu_path(self, device):
        res = render(size=SIZE, bands=6, sensor="nikon5100-npl",
                     camera_model="dslr-flat-port:dof=on")
        ref = _render("dslr-flat-port:dof=on")
        assert res.raw.shape == ref.raw.shape
        # The same scene and camera: mean signals within a few percent (GPU vs NumPy
        # shading), the noise independent of the backend.
        np.testing.assert_allclose(res.raw.reshape(-1, 3).mean(axis=0),
                                   ref.raw.reshape(-1, 3).mean(axis=0), rtol=0.05)


class TestFlatGreyThroughThePipeline:
    """Acceptance (b) through the pipeline's sensor step: a flat grey frame
    of camera RGB, its radiometry, three fixed exposure times."""

    def test_photon_transfer_at_three_exposures(self):
        setup = SimpleNamespace(sensor=get_sensor("nikon5100-npl"), bands=Bands(8),
                                outside="error")
        lam_c = channel_wavelengths(setup)
        side = 300
        grey = np.full((side, side, 3), 0.05)            # W m^-2 sr^-1 of camera RGB
        results = []
        for t in (0.0005, 0.004, 0.03):
            model = dataclasses.replace(get_camera_model("dslr-flat-port"), exposure_s=t,
                                        iso=100.0)
            raw, noisy, info = _expose(model, grey, lam_c, setup)
            s = model.sensor
            mu_e = np.asarray(info["mean_photoelectrons_rgb"])
            for c in range(3):
                frame = raw[..., c].astype(float)
                n = frame.size
                mu_y, var_y = s.mean_dn(mu_e[c], t, 100.0), s.variance_dn(mu_e[c], t, 100.0)
                assert abs(frame.mean() - mu_y) < Z * np.sqrt(var_y / n)
                assert abs(frame.var(ddof=1) - var_y) < Z * var_y * np.sqrt(2 / (n - 1))
                # The noisy linear frame is the input on average.
                se = np.sqrt(var_y / n) / (s.gain(100.0) * info["electrons_per_unit_rgb_per_s"][c]
                                           * t)
                assert abs(noisy[..., c].mean() - 0.05) < Z * se
            results.append(mu_e[1])
        # Exposure time scales the signal.
        np.testing.assert_allclose(np.array(results) / results[0], [1, 8, 60], rtol=1e-9)
