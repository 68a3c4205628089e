"""The caustic loop pass (aquaspec.gpu.passes.caustics) against its NumPy twin
(aquaspec.light.caustics.CausticLoop.levels_at), and the renderer's moving waves."""

import dataclasses

import numpy as np
import pytest

from aquaspec.gpu.passes import caustics as caustics_pass
from aquaspec.gpu.passes.caustics import CausticLoopPass, level_layout, pack_frame
from aquaspec.light import caustics as cst
from aquaspec.light import waves as W

pytestmark = pytest.mark.gpu

SEA = W.Waves(4.0, grid=32, tile_m=2.0, seed=1, period_s=1.0)
SUN = (55.0, 20.0)
MAP = dict(slices=4, max_depth_m=5.0, oversample=2)
#: The mix is rounded to half floats on both sides; WGSL leaves pack2x16float's
#: rounding to the implementation (and mix may be fused): one unit in the last place.
HALF_ULP = 2.0 ** -10


@pytest.fixture(scope="module")
def loop():
    return cst.caustic_loop(SEA, *SUN, frames=8, **MAP)


def _sun_setup(n, ms_model, sea):
    """A new setup of Jerlov IB under the sun SUN over ``sea``, ``n`` bands."""
    from aquaspec.colour.bands import Bands
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.light.sky import surface_light
    from aquaspec.medium.water import load_water
    from aquaspec.rendering.setup import SpectralSetup
    return SpectralSetup(load_water("IB"), get_sensor("human"),
                         surface_light("sun-sky", sun_elevation_deg=SUN[0],
                                       sun_azimuth_deg=SUN[1]),
                         Bands(n), ms_model=ms_model, waves=sea)


def _with_caustics(setup, cmap):
    """``setup`` whose sun reads the still caustic map ``cmap``."""
    setup.cache.sun_inputs = dataclasses.replace(setup.sun_inputs(), caustics=cmap)
    return setup


def _renderer(w, h, n):
    """A renderer with a small (256-texel) shadow map."""
    from aquaspec.rendering.renderer import Renderer
    r = Renderer(w, h, n)
    r.sun_map_size = 256
    return r


def _run(device, p, t):
    enc = device.create_command_encoder()
    p.encode(enc, t)
    device.queue.submit([enc.finish()])
    return p.read_levels()


def test_layout_pads_rows_for_the_texture_copy():
    layout = level_layout(256, 3, 9)
    assert [row for _, row, _ in layout] == [512, 256] + [256] * 7
    assert layout[1][0] == 512 * 256 * 3
    levels = cst.mip_levels(np.random.default_rng(0).random((3, 8, 8)))
    packed = pack_frame(levels)
    assert packed.dtype == np.float16 and packed.size % 8 == 0
    np.testing.assert_array_equal(packed[:8], levels[0][0, 0])


def test_gpu_mix_matches_numpy(device, loop, monkeypatch):
    p = CausticLoopPass(device, loop)
    dt = SEA.period_s / loop.frames
    for t in (0.0, 2.4 * dt, 7.6 * dt, 3.0 + 0.5 * dt, -0.3):
        got, want = _run(device, p, t), loop.levels_at(t)
        assert len(got) == loop.geometry.levels
        for g, w in zip(got, want):
            np.testing.assert_allclose(g, w, rtol=HALF_ULP, atol=2.0 ** -24)
    assert np.std(got[0]) > 0.1                                   # a real pattern
    # At a frame's instant: that instant's caustic map, exactly.
    t = 3 * dt
    want = cst.caustic_map(dataclasses.replace(SEA, time_s=t), *SUN, **MAP).levels
    for g, w in zip(_run(device, p, t), want):
        np.testing.assert_array_equal(g, w)
    # The same time again records nothing (the texture holds it already).
    def no_dispatch(*args, **kwargs):
        raise AssertionError("recorded a dispatch for the time the texture holds")

    monkeypatch.setattr(caustics_pass, "record_dispatch", no_dispatch)
    enc = device.create_command_encoder()
    p.encode(enc, t)
    device.queue.submit([enc.finish()])
    # Without the mix: the nearest frame, exactly.
    p.smooth = False
    for t, f in ((2.4 * dt, 2), (7.6 * dt, 0)):
        for g, w in zip(_run(device, p, t), loop.frame_levels(f)):
            np.testing.assert_array_equal(g, w)



def test_gpu_mix_keeps_the_sign_of_negative_factors(device, loop):
    """Carried into the scattered light the factor can dip below 0
    (aquaspec.light.caustic_scatter): the hand-made half conversion keeps the
    sign, subnormals and zeros as NumPy's float16 does."""
    signed = np.asarray((loop.level0.astype(np.float32) - 1.0) * 3.0, np.float16)
    signed[0, 0, 0, :4] = np.array([-0.0, -3e-6, 3e-6, -6.1e-5], np.float16)
    neg = cst.CausticLoop(first=loop.first, level0=signed)
    p = CausticLoopPass(device, neg)
    dt = SEA.period_s / neg.frames
    for t in (2.4 * dt, 5.5 * dt):
        got, want = _run(device, p, t), neg.levels_at(t)
        assert np.min(want[0]) < -1.0
        for g, w in zip(got, want):
            np.testing.assert_allclose(g, w, rtol=HALF_ULP, atol=2.0 ** -24)
    for g, w in zip(_run(device, p, 3 * dt), neg.frame_levels(3)):
        np.testing.assert_array_equal(g, w)

@pytest.mark.parametrize("ms_model", ["seeds", "lightfield"])
def test_renderer_moves_the_waves_as_the_loop_says(device, ms_model):
    """A renderer told the waves' time samples the loop's factor at that time:
    its image equals one rendered with that factor uploaded as a still map."""
    from aquaspec.scene.builtin import builtin_scene

    w, h = 96, 54
    scene, cam = builtin_scene(2.0, width=w, height=h)

    def setup():
        return _sun_setup(6, ms_model, SEA)

    moving = _renderer(w, h, 6)
    s = setup()
    moving.set_wave_time(0.37, frames=8)
    images = {0.37: moving.render_scene(scene, cam, s)}
    moving.set_wave_time(0.61, frames=8)
    images[0.61] = moving.render_scene(scene, cam, s)
    moving.set_wave_time(None)
    still = moving.render_scene(scene, cam, s)
    for t, img in images.items():
        # (the loop read through the setup's transfer into the scattered light)
        loop = cst.caustic_loop(SEA, *SUN, frames=8, n_water=1.33,
                                scatter=s.sun_inputs().caustics.scatter)
        ref_setup = _with_caustics(setup(), loop.map_at(t))
        want = _renderer(w, h, 6).render_scene(scene, cam, ref_setup)
        scale = np.abs(want).max()
        # Texels may differ by one half-float unit (HALF_ULP) of the factor.
        np.testing.assert_allclose(img, want, atol=HALF_ULP * scale)
        assert np.abs(img - want).mean() < 1e-6 * scale
    scale = np.abs(still).max()
    assert np.abs(images[0.37] - images[0.61]).max() > 0.02 * scale     # the waves moved
    # Back to the setup's still map (its sea at time 0) once the time is None.
    np.testing.assert_allclose(still, _renderer(w, h, 6).render_scene(scene, cam, setup()),
                               atol=1e-6 * scale)


def test_half_floats_round_to_nearest_even_down_to_subnormals(device):
    """The shader converts halves by hand: zeros, subnormals, ties and the
    largest factors come back as NumPy's float16 rounding of the same mix."""
    rng = np.random.default_rng(3)
    special = np.array([0.0, 2.0 ** -24, 3 * 2.0 ** -24, 2.0 ** -15, 6.1e-5, 6.104e-5,
                        1.0, 1.0 + 2.0 ** -10, 2047.0, 2049.0, 60000.0, 65504.0])
    frames = np.stack([rng.permutation(np.resize(special, 2 * 16 * 16)).reshape(2, 16, 16),
                       10.0 ** rng.uniform(-8, 4.5, (2, 16, 16))]).astype(np.float16)
    first = cst.CausticMap(waves=SEA, to_sun=np.array([0.0, 1.0, 0.0]),
                           depths=cst.slice_depths(1.0, 2), levels=cst.mip_levels(frames[0]),
                           mean_weight=1.0)
    loop = cst.CausticLoop(first=first, level0=frames)
    p = CausticLoopPass(device, loop)
    for t in (0.0, 0.1, 0.25, 0.5 + 1e-9, 0.73):
        got, want = _run(device, p, t), loop.levels_at(t)
        for g, w in zip(got, want):
            np.testing.assert_allclose(g, w, rtol=HALF_ULP, atol=2.0 ** -24)
        equal = np.mean(np.concatenate([(g == w).ravel() for g, w in zip(got, want)]))
        assert equal > 0.99, equal


def test_a_loop_still_being_built_is_uploaded_frame_by_frame(device, loop):
    """A partial loop (frames 0 and 4 of 8 ready): the pass mixes between what
    it has uploaded, as the NumPy twin with that set says, and takes one
    newly built frame per encode; one frame alone is copied (no dispatch)."""
    part = cst.CausticLoop(first=loop.first, level0=loop.level0.copy(),
                           ready=np.zeros(loop.frames, bool))
    part.ready[0] = True
    p = CausticLoopPass(device, part)
    dt = SEA.period_s / loop.frames
    for g, w in zip(_run(device, p, 2.5 * dt), loop.frame_levels(0)):
        np.testing.assert_array_equal(g, w)                    # t = 0's map, held
    part.ready[[4, 6]] = True                                  # (as a background build does)
    got = _run(device, p, 2.5 * dt)
    assert p.uploaded.tolist() == [True, False, False, False, True, False, False, False]
    want = part.levels_at(2.5 * dt, p.uploaded)
    assert part.frame_weights(2.5 * dt, p.uploaded) == (0, 4, 2.5 / 4)
    for g, w in zip(got, want):
        np.testing.assert_allclose(g, w, rtol=HALF_ULP, atol=2.0 ** -24)
    got = _run(device, p, 2.5 * dt)                            # the same time, one more frame
    assert p.uploaded.sum() == 3
    for g, w in zip(got, part.levels_at(2.5 * dt, p.uploaded)):
        np.testing.assert_allclose(g, w, rtol=HALF_ULP, atol=2.0 ** -24)
    for g, w in zip(_run(device, p, 5.0 * dt), part.levels_at(5.0 * dt)):
        np.testing.assert_allclose(g, w, rtol=HALF_ULP, atol=2.0 ** -24)


def test_a_progressive_renderer_draws_the_frames_it_has(device):
    """``set_wave_time(progressive=True)`` does not wait for the loop: the
    frame shows the loop read between the frames uploaded so far (the
    renderer's pass says which), equal to that factor as a still map."""
    from aquaspec.scene.builtin import builtin_scene

    sea = dataclasses.replace(SEA, seed=7)
    w, h = 64, 36
    scene, cam = builtin_scene(2.0, width=w, height=h)

    def setup():
        return _sun_setup(4, "seeds", sea)

    r = _renderer(w, h, 4)
    r.set_wave_time(0.3, frames=8, progressive=True)
    s = setup()
    img = r.render_scene(scene, cam, s)
    lp, uploaded = r._wave_loop.loop, r._wave_loop.uploaded.copy()
    assert uploaded[0]
    ref_setup = _with_caustics(setup(), dataclasses.replace(
        lp.map_at(0.3), levels=lp.levels_at(0.3, uploaded)))
    want = _renderer(w, h, 4).render_scene(scene, cam, ref_setup)
    np.testing.assert_allclose(img, want, atol=HALF_ULP * np.abs(want).max())
    lp.wait()
    assert lp.complete
