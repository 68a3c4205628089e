"""The view from above on the GPU (above.wgsl) against its NumPy reference."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor, radiance_to_rgb
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import load_water
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import camera_above
from aquaspec.scene.seabed import Seabed
from aquaspec.shading.above_water import sea_from_above

pytestmark = pytest.mark.gpu


@pytest.mark.parametrize("water,bed,look_down,n", [
    ("IB", None, 30.0, 8),            # the horizon in view: sky above it
    ("3C", Seabed(4.0, 0.3), 70.0, 5),
])
def test_above_pass_matches_numpy(device, water, bed, look_down, n):
    from aquaspec.gpu.passes.above import AbovePass
    setup = SpectralSetup(load_water(water), get_sensor("nikon-5100-npl"),
                          surface_light("overcast"), Bands(n), surface="flat", seabed=bed)
    med = setup.medium([])
    tables = setup.lightfield_tables()
    cam = camera_above(3.0, look_down, width=61, height=37, fov_y_deg=70.0)
    p = AbovePass(device, cam.width, cam.height)
    p.set_medium(tables, a=med["a"], b=med["b"], e0=med["e0"],
                 response_weights=med["response_weights"])
    gpu = p.render(cam)
    ref = radiance_to_rgb(sea_from_above(cam, tables, a=med["a"], b=med["b"], e0=med["e0"]),
                          med["response_weights"])
    np.testing.assert_allclose(gpu, ref, rtol=2e-4, atol=1e-6 * np.abs(ref).max())
    if look_down == 30.0:
        assert (cam.ray_directions()[..., 1] > 0).any()
    # The camera moves: the same medium, a new view, no new upload.
    cam2 = camera_above(8.0, 50.0, width=61, height=37)
    ref2 = radiance_to_rgb(sea_from_above(cam2, tables, a=med["a"], b=med["b"], e0=med["e0"]),
                           med["response_weights"])
    np.testing.assert_allclose(p.render(cam2), ref2, rtol=2e-4, atol=1e-6 * np.abs(ref2).max())


@pytest.mark.parametrize("water,bed,elevation,azimuth", [
    ("IB", None, 30.0, 0.0),          # the sun ahead: its glint in view
    ("3C", Seabed(3.0, 0.2), 60.0, 150.0),
])
def test_above_pass_with_the_sun_matches_numpy(device, water, bed, elevation, azimuth):
    """The beam's single scattering (bilinear table) and the glint on the GPU
    against the NumPy reference's direct evaluation."""
    from aquaspec.gpu.passes.above import AbovePass
    light = surface_light("sun-sky", sun_elevation_deg=elevation, sun_azimuth_deg=azimuth)
    setup = SpectralSetup(load_water(water), get_sensor("nikon-5100-npl"), light, Bands(6),
                          surface="flat", seabed=bed)
    med, sun = setup.medium([]), setup.sun_inputs()
    tables = setup.lightfield_tables()
    cam = camera_above(3.0, elevation, width=160, height=90, fov_y_deg=40.0)
    p = AbovePass(device, cam.width, cam.height)
    p.set_medium(tables, a=med["a"], b=med["b"], e0=med["e0"],
                 response_weights=med["response_weights"], sun=sun)
    gpu = p.render(cam)
    ref = radiance_to_rgb(sea_from_above(cam, tables, a=med["a"], b=med["b"], e0=med["e0"],
                                         sun=sun), med["response_weights"])
    glint = ref.max(axis=-1) > 100 * np.median(ref.max(axis=-1))
    assert glint.any() == (azimuth == 0.0)
    # Away from the glint's rim (where a float32 ray may fall either side of the disc's edge).
    rim = np.zeros_like(glint)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            rim |= np.roll(np.roll(glint, dy, 0), dx, 1)
    keep = ~rim | glint
    edge = rim & ~glint
    # The table (1024 cosines) is within 0.3 % of the direct evaluation of the
    # water term, under 0.3 % of the pixel.
    np.testing.assert_allclose(gpu[~rim], ref[~rim], rtol=3e-3, atol=1e-6 * np.abs(ref).max())
    if glint.any():
        inner = glint & ~(edge | np.roll(edge, 1, 0) | np.roll(edge, -1, 0)
                          | np.roll(edge, 1, 1) | np.roll(edge, -1, 1))
        np.testing.assert_allclose(gpu[inner], ref[inner], rtol=1e-3)
    assert keep.any()


def test_above_pass_with_waves_matches_numpy(device):
    """A wind sea of 6 m/s: each ray mirrored and refracted by its facet, the
    sun's glitter over the unresolved slopes, against NumPy."""
    from aquaspec.gpu.passes.above import AbovePass
    from aquaspec.light.wave_facets import surface_facets
    from aquaspec.light.waves import Waves
    light = surface_light("sun-sky", sun_elevation_deg=40.0, sun_azimuth_deg=10.0)
    setup = SpectralSetup(load_water("II"), get_sensor("nikon-5100-npl"), light, Bands(6),
                          surface="flat", seabed=Seabed(4.0, 0.2))
    med, sun = setup.medium([]), setup.sun_inputs()
    tables = setup.lightfield_tables()
    facets = surface_facets(Waves(6.0, grid=64))
    cam = camera_above(4.0, 35.0, width=96, height=64, fov_y_deg=50.0)
    p = AbovePass(device, cam.width, cam.height)
    p.set_medium(tables, a=med["a"], b=med["b"], e0=med["e0"],
                 response_weights=med["response_weights"], sun=sun, facets=facets)
    gpu = p.render(cam)
    ref = radiance_to_rgb(sea_from_above(cam, tables, a=med["a"], b=med["b"], e0=med["e0"],
                                         sun=sun, facets=facets), med["response_weights"])
    flat = radiance_to_rgb(sea_from_above(cam, tables, a=med["a"], b=med["b"], e0=med["e0"],
                                          sun=sun), med["response_weights"])
    assert np.abs(ref - flat).max() > 0.1 * np.abs(flat).max()     # the waves show
    np.testing.assert_allclose(gpu, ref, rtol=5e-3, atol=1e-4 * np.abs(ref).max())


def test_set_slopes_moves_the_sea_without_new_tables(device):
    """set_slopes with the same sea at another instant gives the frame a
    fresh set_medium at that instant gives; a tile of another size is refused."""
    from aquaspec.errors import AquaspecError
    from aquaspec.gpu.passes.above import AbovePass
    from aquaspec.light.wave_facets import surface_facets
    from aquaspec.light.waves import Waves
    setup = SpectralSetup(load_water("IB"), get_sensor("human"), surface_light("overcast"),
                          Bands(4), surface="flat")
    med, tables = setup.medium([]), setup.lightfield_tables()
    cam = camera_above(3.0, 45.0, width=48, height=32)
    kw = dict(a=med["a"], b=med["b"], e0=med["e0"], response_weights=med["response_weights"])
    early, late = (surface_facets(Waves(5.0, time_s=t)) for t in (0.0, 1.3))
    moved = AbovePass(device, cam.width, cam.height)
    moved.set_medium(tables, **kw, facets=early)
    first = moved.render(cam)
    moved.set_slopes(late)
    fresh = AbovePass(device, cam.width, cam.height)
    fresh.set_medium(tables, **kw, facets=late)
    np.testing.assert_array_equal(moved.render(cam), fresh.render(cam))
    assert np.abs(first - fresh.render(cam)).max() > 0
    with pytest.raises(AquaspecError, match="this pass has the sea of a"):
        moved.set_slopes(surface_facets(Waves(5.0, grid=64)))
