"""aquaspec's caustic photon map against Mitsuba 3's particle tracer.

A reduced version of :func:`aquaspec.validation.caustics_check.compare_caustics`
(the fuller run and its numbers: /work/exp/s20/caustics/RESULTS.md): a
64-sample tile (12.5 cm texels), a point sun at 60 deg elevation, the
irradiance on white plates at 1 and 4 m under the wavy surface over that
under a flat one, against the map read through ``caustics.sample``.
"""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.light import caustics
from aquaspec.errors import AquaspecError
from aquaspec.validation import caustics_check


@pytest.fixture(scope="module")
def mi():
    """Mitsuba in the check's variant; the variant before is restored after
    this module (the other reference tests choose theirs per call)."""
    pytest.importorskip("mitsuba", reason="Mitsuba 3 is not installed (extra 'validation')")
    mitsuba, previous = caustics_check.require_mitsuba()
    yield mitsuba
    if previous is not None:
        mitsuba.set_variant(previous)


WAVES = caustics.Waves(wind_speed=2.0, seed=1, grid=64)
SUN = (60.0, 30.0)
DEPTHS = (1.0, 4.0)


@pytest.fixture(scope="module")
def compared(mi):
    return caustics_check.compare_caustics(WAVES, *SUN, DEPTHS, spp=1024, oversample=4,
                                           mesh_oversample=8, blocks=(1, 2, 4), seed=0)


def _row(result, depth, block, kernel):
    (row,) = [r for r in result["metrics"] if r["depth_m"] == depth and r["block"] == block
              and r["kernel"] == kernel]
    return row


@pytest.mark.slow
def test_mitsuba_scene_is_the_intended_one(compared):
    """The flat surface passes cos z T(cos z) (Fresnel) of a unit sun to the
    plate (measured 0.9986 to 1.0018 over seeds 0, 10, 20), and the pixel
    centres are the map's texel centres in foot coordinates (measured
    7e-7 m)."""
    for d in DEPTHS:
        flat = compared["flat"][d]
        assert flat["mean_over_expected"] == pytest.approx(1.0, abs=0.01)
        assert flat["pixel_foot_error_m"] < 1e-4


@pytest.mark.slow
def test_caustic_pattern_matches_mitsuba(compared):
    """Same pattern, same place, same mean and contrast.

    Measured (spp 1024, 25 cm blocks, matched kernels; seeds 0, 10, 20):
    d = 1 m: corr 0.985-0.987, std ratio 0.978-0.987, mean ratio
    0.9998-1.0014, Mitsuba noise/std 0.13; d = 4 m: corr 0.9946-0.9947,
    std ratio 0.991-0.995, mean ratio 1.0002-1.0018, noise/std 0.05; the
    peak of the cross-correlation at (0, 0). The thresholds leave 2.5x and
    10x the seeds' spread of corr, over 2x the std ratio's deviation and 5x
    the mean ratio's. (Those were with the splat's two-texel tent; with the
    splat onto 2 x 2 finer texels summed, seed 0, 2026-11-28: d = 1 m corr
    0.989, std ratio 0.982; d = 4 m corr 0.998, std ratio 0.994; raw,
    one-texel blocks: std ratio 0.93 and 0.95 against 0.79 and 0.84.)
    """
    for d, min_corr in ((1.0, 0.96), (4.0, 0.985)):
        raw = _row(compared, d, 1, "raw")
        assert raw["shift"] == (0, 0)
        row = _row(compared, d, 2, "matched")
        assert row["corr"] > min_corr
        assert row["mean_ratio"] == pytest.approx(1.0, abs=0.01)
        assert row["std_ratio"] == pytest.approx(1.0, abs=0.05)
    # A caustic pattern (measured std 0.48), not a flat field.
    assert _row(compared, 4.0, 2, "matched")["std_mitsuba"] > 0.3


@pytest.mark.slow
def test_a_wrong_foot_convention_would_fail(compared):
    """The check discriminates: reading the map with the foot offset's sign
    flipped (``p - d s / mu0``) loses the correlation (measured -0.006 to
    -0.003)."""
    d = 4.0
    im = compared["images"][d]
    cmap = caustics.caustic_map(WAVES, *SUN, oversample=4, slices=2, max_depth_m=d,
                                sun_radius_deg=0.0, unresolved_slopes=False)
    to_sun = cmap.to_sun
    wrong = im["points"].copy()
    wrong[..., [0, 2]] -= 2.0 * d / to_sun[1] * to_sun[[0, 2]]
    c_wrong = caustics.sample(cmap, wrong, 0.0)
    m = caustics_check.pattern_metrics(caustics_check.block_mean(c_wrong, 2),
                                       caustics_check.block_mean(im["mitsuba"], 2),
                                       np.zeros((32, 32)))
    assert m["corr"] < 0.5


@pytest.mark.parametrize("kwargs, message", [
    (dict(depths=[0.0]), "depths"),
    (dict(depths=[2.0], blocks=(3,)), "blocks"),
    (dict(depths=[2.0], view_texels=100), "view"),
    (dict(depths=[2.0], spp=1), "spp"),
])
def test_bad_arguments_are_refused(kwargs, message):
    with pytest.raises(AquaspecError, match=message):
        caustics_check.compare_caustics(WAVES, *SUN, **kwargs)


def test_block_mean_and_metrics():
    a = np.arange(16.0).reshape(4, 4)
    np.testing.assert_allclose(caustics_check.block_mean(a, 2), [[2.5, 4.5], [10.5, 12.5]])
    m = caustics_check.pattern_metrics(2.0 * a, a, np.zeros_like(a))
    assert m["corr"] == pytest.approx(1.0)
    assert m["mean_ratio"] == pytest.approx(2.0) and m["std_ratio"] == pytest.approx(2.0)


def test_heightfield_mesh_faces_up(mi):
    h, hx, hz = caustics.surface(caustics.Waves(wind_speed=2.0, seed=1, grid=16))
    mesh = caustics_check.heightfield_mesh(mi, h, hx, hz, 8.0, (-2, 18), (3, 20),
                                           mi.load_dict({"type": "diffuse"}))
    pos = np.array(mi.traverse(mesh)["vertex_positions"]).reshape(-1, 3)
    faces = np.array(mi.traverse(mesh)["faces"]).reshape(-1, 3)
    e1 = pos[faces[:, 1]] - pos[faces[:, 0]]
    e2 = pos[faces[:, 2]] - pos[faces[:, 0]]
    assert np.all(np.cross(e1, e2)[:, 1] > 0)
    grid = pos.reshape(21, 18, 3)                    # rows -2..18 (z), columns 3..20 (x)
    step = 8.0 / 16
    # Periodic: row -2 is the tile's row 14 one tile back in z; column 17 is column 1.
    assert grid[0, 0] == pytest.approx([3 * step, h[14, 3], -2 * step], abs=1e-5)
    assert grid[5, 14] == pytest.approx([17 * step, h[3, 1], 3 * step], abs=1e-5)
    nrm = np.array(mi.traverse(mesh)["vertex_normals"]).reshape(21, 18, 3)
    expect = np.array([-hx[3, 1], 1.0, -hz[3, 1]])
    assert nrm[5, 14] == pytest.approx(expect / np.linalg.norm(expect), abs=1e-5)
