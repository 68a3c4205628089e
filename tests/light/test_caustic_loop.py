"""Caustics of a moving sea (aquaspec.light.caustics.CausticLoop): the loop's frames
are the instants' maps, it closes, it is continuous in time, and a sequence of
frames changes no faster than the waves move the caustics."""

import dataclasses
import threading
import time

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.light import caustics as cst
from aquaspec.light import waves as W

#: A small sea (2 m tile, 32 samples, 4 slices to 5 m): maps of tens of ms.
SEA = W.Waves(4.0, grid=32, tile_m=2.0, seed=1, period_s=1.0)
SUN = (55.0, 20.0)
MAP = dict(slices=4, max_depth_m=5.0, oversample=2)
FRAMES = 24


@pytest.fixture(scope="module")
def loop():
    return cst.caustic_loop(SEA, *SUN, frames=FRAMES, **MAP)


def _map(t, sea=SEA):
    return cst.caustic_map(dataclasses.replace(sea, time_s=t), *SUN, **MAP).levels


def _rms(a, b):
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


def test_frames_are_the_instants_maps_and_the_loop_closes(loop):
    assert loop.frames == FRAMES and loop.period_s == SEA.period_s
    dt = SEA.period_s / FRAMES
    for f in (0, 5, FRAMES - 1):
        for got, want in zip(loop.levels_at(f * dt), _map(f * dt)):
            np.testing.assert_array_equal(got, want)
    # One period later (and before), the same factor.
    for t in (0.13, 0.5 + 0.25 * dt):
        for a, b, c in zip(loop.levels_at(t), loop.levels_at(t + SEA.period_s),
                           loop.levels_at(t - 3 * SEA.period_s)):
            np.testing.assert_allclose(b, a, atol=1e-3)
            np.testing.assert_allclose(c, a, atol=1e-3)
    # The sea itself closes: the map one period on is the map now.
    np.testing.assert_allclose(_map(0.3 + SEA.period_s)[0], _map(0.3)[0], atol=2e-3)


def test_between_frames_the_factor_is_linear_in_time_and_keeps_the_flux(loop):
    dt = SEA.period_s / FRAMES
    f0, f1, a = loop.frame_weights(7.25 * dt)
    assert (f0, f1) == (7, 8) and a == pytest.approx(0.25)
    assert loop.frame_weights(SEA.period_s - 1e-9)[:2] == (FRAMES - 1, 0)
    p, q, mid = loop.frame_levels(7)[0], loop.frame_levels(8)[0], loop.levels_at(7.25 * dt)[0]
    # Half precision as the GPU's texture: one unit in the last place of the mix.
    np.testing.assert_allclose(mid, 0.75 * p + 0.25 * q, rtol=2 ** -10, atol=2 ** -24)
    for t in (0.0, 7.25 * dt, 0.77):
        for lv in loop.levels_at(t):
            np.testing.assert_allclose(lv.mean(axis=(1, 2)), loop.first.mean_weight, rtol=3e-3)
    assert abs(loop.first.mean_weight - 1) < 0.01
    m = loop.map_at(0.77)
    assert m.waves.time_s == 0.77 and m.geometry == loop.geometry
    with pytest.raises(AquaspecError, match="wave time"):
        loop.frame_weights(float("nan"))
    with pytest.raises(AquaspecError, match="loop frames"):
        cst.caustic_loop(SEA, *SUN, frames=1, **MAP)


def test_the_caustics_change_linearly_in_time():
    """The true map's change over dt shrinks in proportion to dt (no jumps):
    halving dt halves the change, for small dt."""
    t = 0.21
    base = _map(t)[0]
    steps = [_rms(_map(t + h)[0], base) for h in (1e-3, 2e-3, 4e-3)]
    assert steps[0] > 0
    np.testing.assert_allclose([steps[1] / steps[0], steps[2] / steps[1]], 2.0, rtol=0.25)


def test_a_frame_sequence_changes_no_faster_than_the_waves(loop):
    """Frames 1/60 s apart over a whole period: each step of the factor is at
    most what the waves' own rate of change allows over that time (the rate
    measured on the true maps at every loop frame, with a margin for its
    change within a frame interval), and the sequence closes."""
    h = 1e-3
    dt_loop = SEA.period_s / FRAMES
    rate = max(_rms(_map(f * dt_loop + h)[0], _map(f * dt_loop)[0]) / h
               for f in range(FRAMES))
    fps = 60.0
    times = np.arange(int(SEA.period_s * fps) + 1) / fps
    seq = [loop.levels_at(t)[0] for t in times]
    steps = np.array([_rms(b, a) for a, b in zip(seq, seq[1:])])
    assert steps.max() <= 1.5 * rate / fps, (steps.max(), rate / fps)
    assert steps.min() > 0                                    # it does move
    np.testing.assert_allclose(seq[-1], seq[0], atol=1e-3)    # t = T is t = 0


def test_quantised_frequencies_keep_the_caustics_statistics():
    """The looping sea is the true sea at t = 0 and, later, a sea of the same
    spectrum: each slice's mean and contrast stay those of the true sea's maps."""
    true_sea = dataclasses.replace(SEA, period_s=None)
    np.testing.assert_array_equal(_map(0.0)[0], _map(0.0, true_sea)[0])
    looped = np.stack([_map(t)[0] for t in (0.3, 0.6, 0.9)])
    true = np.stack([_map(t, true_sea)[0] for t in (0.3, 0.6, 0.9)])
    np.testing.assert_allclose(looped.mean(axis=(0, 2, 3)), true.mean(axis=(0, 2, 3)),
                               rtol=3e-3)
    np.testing.assert_allclose(looped[:, 1:].std(axis=(0, 2, 3)),
                               true[:, 1:].std(axis=(0, 2, 3)), rtol=0.3)
    assert _rms(looped[0], true[0]) > 0.01                   # but not the same sea later


def test_render_takes_the_waves_time():
    from aquaspec.rendering.api import as_waves
    assert as_waves(3.0, 0.5) == W.Waves(3.0, time_s=0.5)
    assert as_waves(SEA, 2.25).time_s == 2.25 and as_waves(SEA, 2.25).period_s == 1.0
    assert as_waves(SEA) is SEA
    with pytest.raises(AquaspecError, match="needs waves"):
        as_waves(None, 1.0)
    with pytest.raises(AquaspecError, match="wave time"):
        as_waves(3.0, float("inf"))
    with pytest.raises(AquaspecError, match="wave_time="):
        as_waves(3.0, "soon")


# ---- a loop built in the background -------------------------------------------------


def test_build_order_spreads_the_frames_over_the_period():
    order = cst.build_order(48)
    assert sorted(order) == list(range(48))
    assert order[:8] == [0, 24, 12, 36, 6, 18, 30, 42]
    for done in (2, 4, 8, 16):         # the largest gap halves as the frames double
        have = np.sort(order[:done])
        gaps = np.diff(np.append(have, have[0] + 48))
        assert gaps.max() == 48 // done
    assert sorted(cst.build_order(5)) == list(range(5)) and cst.build_order(2) == [0, 1]


def _partial(loop, frames):
    ready = np.zeros(loop.frames, bool)
    ready[list(frames)] = True
    return ready


def test_a_partial_loop_reads_between_its_ready_frames(loop):
    """With some frames missing the factor is linear in time between the ready
    ones around the loop: each ready frame exactly at its instant, continuous
    in between (no jump at a missing frame), one frame alone held still."""
    dt = SEA.period_s / FRAMES
    ready = _partial(loop, (0, 6, 12))
    assert loop.frame_weights(3 * dt, ready) == (0, 6, 0.5)
    assert loop.frame_weights(15 * dt, ready) == (12, 0, 0.25)         # wraps to frame 0
    assert loop.frame_weights(-1 * dt, ready) == (12, 0, 11 / 12)
    for f in (0, 6, 12):
        for got, want in zip(loop.levels_at(f * dt, ready), loop.frame_levels(f)):
            np.testing.assert_array_equal(got, want)
    times = np.linspace(0.0, SEA.period_s, 241)
    seq = np.stack([loop.levels_at(t, ready)[0] for t in times])
    steps = np.sqrt(np.mean(np.diff(seq, axis=0) ** 2, axis=(1, 2, 3)))
    # The largest step: the mix over 12 frames' span of the two most different
    # ready frames, spread over its 48 steps of 1/240 s (and half-float rounding).
    span = max(_rms(loop.level0[f].astype(float), loop.level0[g].astype(float))
               for f, g in ((0, 6), (6, 12), (12, 0)))
    assert steps.max() <= span / 48 * 1.05 + 1e-3
    only = _partial(loop, (0,))
    for t in (0.0, 0.4, 0.93):
        assert loop.frame_weights(t, only) == (0, 0, 0.0)
        np.testing.assert_array_equal(loop.levels_at(t, only)[0], loop.frame_levels(0)[0])
    with pytest.raises(AquaspecError, match="no frame yet"):
        loop.frame_weights(0.1, np.zeros(loop.frames, bool))


def test_a_loop_built_in_the_background_is_the_same_loop(tmp_path, monkeypatch):
    """``background=True`` returns with frame 0 (the still map of t = 0) and
    fills the rest in a thread, calling progress(done, total) after each
    frame; the frames are the instants' maps, as the blocking build's; a new
    sea or sun stops the last loop's build; asked for again, the rest is built."""
    monkeypatch.setenv("AQUASPEC_CACHE", str(tmp_path))
    sea = dataclasses.replace(SEA, seed=5)
    frames = 8
    calls, gate = [], threading.Event()

    def progress(done, total):
        calls.append((done, total))
        if done == 3:
            gate.wait(30)       # hold the build here until the test has looked

    lp = cst.caustic_loop(sea, *SUN, frames=frames, background=True, progress=progress, **MAP)
    assert lp.ready[0] and calls[0] == (1, frames)
    np.testing.assert_array_equal(lp.frame_levels(0)[0],
                                  cst.cached_caustic_map(dataclasses.replace(sea, period_s=None),
                                                         *SUN, **MAP).levels[0])
    while len(calls) < 3:
        time.sleep(0.01)
    assert lp.ready.sum() == 3 and not lp.complete
    # Another sun: this loop's build stops after the frame under way.
    other = cst.caustic_loop(sea, SUN[0] + 5.0, SUN[1], frames=2, **MAP)
    assert other.complete
    gate.set()
    lp.wait()
    assert lp.ready.sum() == 3 and calls[-1] == (3, frames)
    # Asked for again (blocking): the missing frames are built, in order, and
    # they are the instants' maps.
    calls.clear()
    again = cst.caustic_loop(sea, *SUN, frames=frames, progress=progress, **MAP)
    assert again is not lp and again.complete
    assert [c[0] for c in calls] == list(range(1, frames + 1))
    dt = sea.period_s / frames
    for f in range(frames):
        np.testing.assert_array_equal(again.frame_levels(f)[0],
                                      _map(f * dt, sea)[0])
        if lp.ready[f]:
            np.testing.assert_array_equal(lp.level0[f], again.level0[f])
    # A background request for a loop that is there returns it at once.
    assert cst.caustic_loop(sea, *SUN, frames=frames, background=True, **MAP) is again
