"""The water table built on the GPU (aquaspec.gpu.passes.watertable,
watertable.wgsl) against its NumPy twin, lightfield_compiled.water_table."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from support.lightfield_passes import gpu_pass, setup_of

pytestmark = pytest.mark.gpu


@pytest.mark.parametrize("water,n,phase,depth,cone,spread", [
    ("IB", 8, "petzold", 5.0, 15.0, False),
    ("I", 5, "hg", 0.3, 15.0, False),       # just below the surface: fast change at the horizon
    ("7C", 16, "isotropic", 12.0, 0.0, False),
    ("II", 6, "ff", 4.0, 40.0, True),
])
def test_water_table_built_on_the_gpu_matches_numpy(water, n, phase, depth, cone, spread,
                                                    lightfield_gbuffer):
    """watertable.wgsl against lightfield_compiled.water_table (float64), both
    layers, and the table is rebuilt when the camera's depth changes."""
    from aquaspec.transport.lightfield.conespread import pyramid_weights
    from aquaspec.transport.lightfield.compiled import water_table
    from aquaspec.transport.lightfield.spreadplan import spread_plan
    gb = lightfield_gbuffer("up", depth)
    params = (("backscatter", 0.0183),) if phase == "ff" else ()
    setup = dataclasses.replace(setup_of(water, n, phase, cone=cone), phase_params=params,
                                cone_spread=spread)
    lp = gpu_pass(gb, setup)
    lp.run()
    got = lp.water.read()
    med = setup.medium(gb.materials)
    ref = water_table(setup.lightfield_tables(), a=med["a"], b=med["b"], e0=med["e0"],
                      response_weights=med["response_weights"], depth_o=depth, split=spread)
    if spread:
        alpha = lp.spread_plan[1]
        cam = gb.camera
        weights = pyramid_weights(setup.lightfield_tables().cone, cam.fy, cam.height, cam.width)
        assert alpha == spread_plan(weights, cam.fy)[1]
        ref = np.stack([ref[0] + alpha * ref[1], ref[1]])
    assert got.shape == ref.shape
    scale = np.abs(ref).max()
    np.testing.assert_allclose(got, ref, rtol=2e-4, atol=2e-6 * scale)
    # A new depth, a new table.
    key = lp.water.key
    gb2 = lightfield_gbuffer("up", depth + 1.0)
    lp.gbuffer.upload(gb2)
    lp.run()
    assert lp.water.key != key
    assert np.abs(lp.water.read() - got).max() > 1e-3 * scale


SEABED_M = 7.8        # the built-in scene's seabed


@pytest.mark.parametrize("light", ["overcast", "sun-sky"])
@pytest.mark.parametrize("spread", [False, "single", "multiple"])
def test_water_table_with_a_seabed_built_on_the_gpu_matches_numpy(light, spread,
                                                                  lightfield_gbuffer):
    """With a Lambertian seabed (the line of sight going down ends on it) the
    GPU table follows lightfield_compiled.water_table at camera depths from
    just below the surface to 0.2 m above the seabed: no spread, the
    single-scattering spread (layer 0 with alpha times the cone's layer) and
    the multiple-scattering spread (a layer per lambda node). Float32 against
    float64: within 2e-4 relative or 2e-6 of the table's largest value, as in
    deep water."""
    from aquaspec.colour.bands import Bands
    from aquaspec.light.sky import surface_light
    from aquaspec.scene.seabed import Seabed
    from aquaspec.transport.lightfield.compiled import water_table
    gb = lightfield_gbuffer("builtin", 5.0)
    how = {"spread_scattering": "multiple"} if spread == "multiple" else {}
    setup = dataclasses.replace(setup_of("IB", 8, "petzold", cone=40.0 if spread else 15.0),
                                light=surface_light(light), bands=Bands(8),
                                seabed=Seabed(SEABED_M, 0.3), cone_spread=bool(spread), **how)
    tables = setup.lightfield_tables()
    assert tables.has_seabed and tables.has_sun == (light == "sun-sky")
    lp = gpu_pass(gb, setup)
    lp.run()
    alpha = lp.water.key[1]
    med = setup.medium(gb.materials)
    tables_kw = dict(a=med["a"], b=med["b"], e0=med["e0"],
                     response_weights=med["response_weights"], split=bool(spread),
                     alpha_nodes=np.array(alpha) if spread == "multiple" else None)
    previous = None
    for depth in (0.3, 3.9, SEABED_M - 1.0, SEABED_M - 0.2):
        encoder = lp.device.create_command_encoder()
        lp.water.encode(encoder, depth, alpha)
        lp.device.queue.submit([encoder.finish()])
        got = lp.water.read()
        ref = water_table(tables, depth_o=depth, **tables_kw)
        if spread == "single":
            ref = np.stack([ref[0] + alpha * ref[1], ref[1]])
        assert got.shape == ref.shape
        scale = np.abs(ref).max()
        err = np.abs(got - ref) / np.maximum(np.abs(ref), 1e-2 * scale)
        print(f"{light} {spread} {depth} m: largest error {err.max():.1e} (relative, "
              "floor 1e-2 of the largest value)")
        np.testing.assert_allclose(got, ref, rtol=2e-4, atol=2e-6 * scale)
        assert previous is None or np.abs(got - previous).max() > 1e-3 * scale
        previous = got


@pytest.mark.parametrize("depth", [0.4, 6.0])
def test_the_flat_surface_in_the_water_table_on_the_gpu(depth, lightfield_gbuffer):
    """The real flat surface (SpectralSetup surface="flat", the light field's
    "fresnel" top): looking up, the GPU table's open water follows the NumPy
    twin, which sees the sky through Snell's window and, outside it, the water
    below mirrored."""
    from aquaspec.transport.lightfield.compiled import direction_nodes, water_table
    gb = lightfield_gbuffer("up", depth)
    setup = dataclasses.replace(setup_of("IB", 8, "petzold", cone=15.0), surface="flat")
    lp = gpu_pass(gb, setup)
    lp.run()
    got = lp.water.read()
    med = setup.medium(gb.materials)
    tables = setup.lightfield_tables()
    assert tables.surface == "fresnel"
    ref = water_table(tables, a=med["a"], b=med["b"], e0=med["e0"],
                      response_weights=med["response_weights"], depth_o=depth, split=False)
    np.testing.assert_allclose(got, ref, rtol=2e-4, atol=2e-6 * np.abs(ref).max())
    v, _ = direction_nodes(tables.window_cos)
    matched = dataclasses.replace(setup_of("IB", 8, "petzold", cone=15.0))
    plain = water_table(matched.lightfield_tables(), a=med["a"], b=med["b"], e0=med["e0"],
                        response_weights=med["response_weights"], depth_o=depth, split=False)
    # Outside the window: the mirrored water, dimmer than the index-matched
    # surface's sky there but not black.
    outside = (v > 0.2) & (v < 0.6)
    mirrored = ref[0, outside, -1].sum(axis=-1)
    assert np.all(mirrored > 0) and np.all(mirrored < plain[0, outside, -1].sum(axis=-1))
