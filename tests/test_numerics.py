"""The shared numerical building blocks against closed forms and quadrature."""

import numpy as np
import pytest
from numpy.polynomial import legendre
from scipy.integrate import quad
from scipy.interpolate import RegularGridInterpolator

from aquaspec.numerics import (bilinear, bilinear_blend, bilinear_grid, clamped_cell,
                               decay_integral, legendre_table, log_exprel, repeat_cell)


@pytest.mark.parametrize("k", [-3.0, -1e-3, -1e-12, 0.0, 1e-12, 1e-6, 0.7, 40.0])
@pytest.mark.parametrize("length", [0.0, 1e-3, 2.5, 30.0])
def test_decay_integral_is_the_integral(k, length):
    exact = quad(lambda t: np.exp(-k * t), 0.0, length, epsabs=0, epsrel=1e-13)[0]
    # Below |k L| = DECAY_SMALL the integral is taken as L: relative error |k L| / 2.
    assert decay_integral(k, length) == pytest.approx(exact, rel=1e-12 + 0.51 * abs(k * length),
                                                      abs=1e-300)


def test_decay_integral_broadcasts_and_is_finite_at_infinity():
    out = decay_integral(np.array([[0.5], [2.0]]), np.array([1.0, np.inf]))
    assert out.shape == (2, 2)
    np.testing.assert_allclose(out[:, 1], [2.0, 0.5])                     # 1/k


@pytest.mark.parametrize("y", [0.0, 1e-10, 1e-4, 0.5, 1.0, 3.0, 50.0, 800.0])
def test_log_exprel_is_log_of_the_growing_integral(y):
    if y < 700:
        exact = np.log(np.expm1(y) / y) if y > 0 else 0.0
        assert log_exprel(y) == pytest.approx(exact, rel=1e-12, abs=1e-15)
    else:                                               # e^y overflows: y - log y
        assert log_exprel(y) == pytest.approx(y - np.log(y), rel=1e-15)


def test_bilinear_matches_a_linear_grid_interpolator():
    rng = np.random.default_rng(3)
    table = rng.random((7, 5, 3))
    x, y = rng.uniform(0, 6, 200), rng.uniform(0, 4, 200)
    ref = RegularGridInterpolator((np.arange(7), np.arange(5)), table)(np.column_stack([x, y]))
    np.testing.assert_allclose(bilinear(table, x, y), ref, rtol=1e-13)


def test_bilinear_is_exact_on_a_plane_and_clamps_at_edges():
    xs, ys = np.meshgrid(np.arange(6.0), np.arange(4.0), indexing="ij")
    plane = 2.0 * xs - 3.0 * ys + 1.0
    np.testing.assert_allclose(bilinear(plane, 2.25, 1.5), 2 * 2.25 - 3 * 1.5 + 1)
    assert bilinear(plane, -4.0, 9.0) == pytest.approx(plane[0, 3])
    i, f = clamped_cell(np.array([-1.0, 0.0, 4.5, 9.0]), 6)
    assert list(i) == [0, 0, 4, 4] and list(f) == [0.0, 0.0, 0.5, 1.0]


def test_bilinear_grid_equals_bilinear_to_rounding():
    rng = np.random.default_rng(4)
    image = rng.random((9, 11))
    rows, cols = np.linspace(-1, 9, 13), np.linspace(0.3, 12, 7)
    r, c = np.meshgrid(rows, cols, indexing="ij")
    np.testing.assert_allclose(bilinear_grid(image, rows, cols), bilinear(image, r, c),
                               rtol=1e-13, atol=1e-15)


def test_repeat_cell_wraps():
    i0, i1, f = repeat_cell(np.array([-0.25, 3.5, 7.75]), 4)
    assert list(i0) == [3, 3, 3] and list(i1) == [0, 0, 0]
    np.testing.assert_allclose(f, [0.75, 0.5, 0.75])
    assert bilinear_blend(1.0, 2.0, 3.0, 4.0, 0.5, 0.25) == pytest.approx(
        0.5 * (0.75 * 1 + 0.25 * 2) + 0.5 * (0.75 * 3 + 0.25 * 4))


def test_legendre_table_matches_numpy():
    x = np.linspace(-1, 1, 41)
    table = legendre_table(12, x)
    for l in range(13):
        np.testing.assert_allclose(table[l], legendre.legval(x, [0] * l + [1]), atol=1e-13)


def test_decay_integral_without_the_small_cut_is_exact_near_zero():
    """``small=0`` (the monzon2022 path integral) keeps ``-expm1(-x)/k`` for tiny ``k L``."""
    for k, length in ((0.5, 1e-8), (1e-12, 2.5), (3e-9, 1.0)):
        exact = length * (1 - k * length / 2 + (k * length) ** 2 / 6)
        assert decay_integral(k, length, small=0.0) == pytest.approx(exact, rel=1e-15)
