"""Lamps in the path-traced reference: Mitsuba's ``spot`` emitter in the water, no
daylight, paths of at most one scattering event (volpathmis ``max_depth = 2``:
camera - medium or surface - lamp), against aquaspec's single scattering
(:func:`aquaspec.transport.lamp_scattering.single_scattering`) and direct light
on a card (:func:`aquaspec.transport.lamp_scattering.lamp_irradiance`) with the
same c, b, phase function and lamp. Both sides are the same quantity, so only
Monte Carlo noise separates them: per band, 4 standard errors of the pixels'
mean plus 2 %."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.light.lamp import Lamp
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import load_water

pytestmark = pytest.mark.slow

#: Beyond Monte Carlo noise, the share by which the two may differ (the
#: equiangular rule with 512 samples, the fine wavelength grid).
RTOL = 0.02


def mitsuba():
    pytest.importorskip("mitsuba", reason="Mitsuba 3 is not installed (extra 'validation')")
    from aquaspec.validation.reference import require_mitsuba
    return require_mitsuba()


def fine_inputs(lamp, water, phase, g):
    """LampInputs on a 0.5 nm grid with the medium exactly as Mitsuba gets it."""
    from aquaspec.transport.lamp_scattering import LampInputs
    from aquaspec.validation.reference import medium_spectra, phase_function
    fine = np.arange(400.0, 700.001, 0.5)
    wl, c, albedo = medium_spectra(water)
    cf = np.interp(fine, wl, c)
    bf = cf * np.interp(fine, wl, albedo)
    s = np.interp(fine, lamp.spectrum.wavelength_nm, lamp.spectrum.values)
    ph = phase_function(phase, g)
    log_p = np.log(np.maximum(ph.value(np.cos(np.pi * (np.arange(512) / 511.0) ** 2)), 1e-30))
    inp = LampInputs(lamp, lamp.on_axis_w_sr * s, cf, cf, bf, np.tile(log_p, (fine.size, 1)))
    return fine, inp, ph


@pytest.mark.parametrize("phase, g", [("isotropic", 0.0), ("hg", 0.9)])
def test_single_scattering_of_a_spot_lamp(phase, g):
    mitsuba()
    from aquaspec.scene.camera import Camera
    from aquaspec.scene.mesh import Scene
    from aquaspec.transport.lamp_scattering import single_scattering
    from aquaspec.validation.reference import render_reference
    water = load_water("II")
    bands = Bands(5)
    o = np.array([0.0, -10.0, 0.0])
    lamp = Lamp(o + [0.3, 0.0, 0.0], direction=(-0.1, 0.0, -1.0), cone_deg=30.0,
                beam_deg=20.0, power_w=10.0, spectrum="led", frame="world")
    fine, inp, ph = fine_inputs(lamp, water, phase, g)
    for name, target in {"ahead": [0.0, 0.0, -1.0], "aside": [0.6, 0.0, -1.0]}.items():
        cam = Camera.look_at(o, o + np.asarray(target), width=6, height=6, fov_y_deg=4.0)
        img = render_reference(Scene(camera=cam), cam, water, surface_light("none"), spp=2048,
                               bands=bands, phase=phase, g=g, max_depth=2,
                               lamps=[lamp])["band_radiance"]
        dirs = cam.ray_directions().reshape(-1, 3)
        ss = single_scattering(inp, o, dirs, np.full(len(dirs), np.inf), n_samples=512,
                               phase=lambda cos: ph.value(cos)[..., None] * np.ones(fine.size))
        want = bands.average(fine, ss).mean(axis=0)
        px = img.reshape(-1, bands.n)
        got = px.mean(axis=0)
        se = px.std(axis=0, ddof=1) / np.sqrt(len(px))
        assert np.all(np.abs(got - want) < 4 * se + RTOL * want), (name, got / want, se / got)


def test_card_lit_by_a_spot_lamp():
    """A grey card 2 m ahead, the lamp 0.5 m to the camera's side and aimed at
    it, isotropic water: the pixels on the card, direct light plus the single
    scattering in front of it."""
    mitsuba()
    from aquaspec.colour.reflectance import Reflectance
    from aquaspec.scene.camera import Camera
    from aquaspec.scene.mesh import Mesh, Scene
    from aquaspec.transport.lamp_scattering import lamp_irradiance, single_scattering
    from aquaspec.validation.reference import render_reference
    water = load_water("II")
    bands = Bands(5)
    o = np.array([0.0, -10.0, 0.0])
    grey = Reflectance("grey", np.array([380.0, 720.0]), np.array([0.5, 0.5]))
    scene = Scene(materials=[grey])
    card = np.array([[-1, -11, -2], [1, -11, -2], [1, -9, -2], [-1, -9, -2]], float)
    scene.add(Mesh.flat(card, np.array([[0, 1, 2], [0, 2, 3]])))
    lamp = Lamp(o + [0.5, 0.0, 0.0], direction=(-0.5, 0.0, -2.0), cone_deg=40.0,
                power_w=10.0, spectrum="halogen", frame="world")
    cam = Camera.look_at(o, o + [0.0, 0.0, -1.0], width=6, height=6, fov_y_deg=6.0)
    img = render_reference(scene, cam, water, surface_light("none"), spp=1024, bands=bands,
                           phase="isotropic", max_depth=2, lamps=[lamp])["band_radiance"]
    fine, inp, ph = fine_inputs(lamp, water, "isotropic", 0.0)
    dirs = cam.ray_directions().reshape(-1, 3)
    s = 2.0 / -dirs[:, 2]
    pts = o + dirs * s[:, None]
    e = lamp_irradiance(inp, pts, np.tile([0.0, 0.0, 1.0], (len(dirs), 1)))
    direct = 0.5 / np.pi * e * np.exp(-inp.c_view * s[:, None])
    veil = single_scattering(inp, o, dirs, s, n_samples=512,
                             phase=lambda cos: ph.value(cos)[..., None] * np.ones(fine.size))
    want = bands.average(fine, direct + veil).mean(axis=0)
    px = img.reshape(-1, bands.n)
    got = px.mean(axis=0)
    se = px.std(axis=0, ddof=1) / np.sqrt(len(px))
    assert np.all(np.abs(got - want) < 4 * se + RTOL * want), (got / want, se / got)
