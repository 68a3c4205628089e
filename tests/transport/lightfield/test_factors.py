"""The irradiance factorisation by normal equations
(aquaspec.transport.lightfield.factors, used by compiled.irradiance_factors)
against the same alternating least squares solved with numpy.linalg.lstsq,
and the conditioning guard that falls back to lstsq."""

from __future__ import annotations

import types

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import load_water
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.seabed import Seabed
from aquaspec.transport.lightfield import compiled as lfc
from aquaspec.transport.lightfield import factors

#: Fitted irradiance against the lstsq version, relative to the table's largest
#: value (measured: 1e-13 or less).
FIT_TOLERANCE = 1e-6


def lstsq_factors(tables, rank: int, sweeps: int = lfc.ALS_SWEEPS) -> dict:
    """The factorisation as it was before the normal equations: every solve a
    numpy.linalg.lstsq, the start an SVD (the reference)."""
    e = np.asarray(tables.irradiance_per_e0, dtype=float)
    n, nd, nm = e.shape
    m = np.log(np.maximum(e, 1e-30)).reshape(n, -1)
    dd = np.repeat(np.asarray(tables.depth_m, dtype=float), nm)
    fixed = np.stack([np.ones_like(dd), dd])
    c_fixed = np.linalg.lstsq(fixed.T, m.T, rcond=None)[0].T
    _, sv, vt = np.linalg.svd(m - c_fixed @ fixed, full_matrices=False)
    basis = vt[:rank] * sv[:rank, None]
    for _ in range(sweeps):
        a = np.vstack([fixed, basis])
        coef = np.linalg.lstsq(a.T, m.T, rcond=None)[0].T
        basis = np.linalg.lstsq(coef[:, 2:], m - coef[:, :2] @ fixed, rcond=None)[0]
    coef = np.linalg.lstsq(np.vstack([fixed, basis]).T, m.T, rcond=None)[0].T
    rel = np.expm1(coef @ np.vstack([fixed, basis]) - m)[:, dd <= lfc.ERROR_DEPTH_M]
    return {"coef": coef, "basis": basis.reshape(rank, nd, nm),
            "max_error": float(np.abs(rel).max())}


def fitted_irradiance(fac, tables):
    """``E / E0`` on the nodes from the factors: (n, n_depth, n_mu)."""
    d = np.asarray(tables.depth_m, dtype=float)
    return np.exp(fac["coef"][:, :1, None] + fac["coef"][:, 1:2, None] * d[None, :, None]
                  + np.einsum("ir,rjk->ijk", fac["coef"][:, 2:], fac["basis"]))


def assert_same_fit(fac, ref, tables):
    """Same irradiance, and the same factors up to the sign of each function."""
    scale = np.asarray(tables.irradiance_per_e0, dtype=float).max()
    np.testing.assert_allclose(fitted_irradiance(fac, tables), fitted_irradiance(ref, tables),
                               rtol=0, atol=FIT_TOLERANCE * scale)
    sign = np.sign(np.einsum("rjk,rjk->r", fac["basis"], ref["basis"]))
    np.testing.assert_allclose(fac["basis"] * sign[:, None, None], ref["basis"], rtol=0,
                               atol=FIT_TOLERANCE * np.abs(ref["basis"]).max())
    np.testing.assert_allclose(fac["coef"][:, 2:] * sign, ref["coef"][:, 2:], rtol=0,
                               atol=FIT_TOLERANCE * np.abs(ref["coef"][:, 2:]).max())
    np.testing.assert_allclose(fac["coef"][:, :2], ref["coef"][:, :2], rtol=0,
                               atol=FIT_TOLERANCE * np.abs(ref["coef"][:, :2]).max())
    assert fac["max_error"] == pytest.approx(ref["max_error"], rel=1e-6)


def setup_tables(water: str, light: str, seabed: bool, n: int = 8):
    bed = Seabed(7.8, 0.3) if seabed else None
    return SpectralSetup(load_water(water), get_sensor("human"), surface_light(light), Bands(n),
                         ms_model="lightfield", seabed=bed).lightfield_tables()


@pytest.mark.filterwarnings("ignore::aquaspec.medium.water.WaterDataWarning")
@pytest.mark.parametrize("water, light, seabed", [
    ("IB", "overcast", False), ("IB", "sun-sky", True), ("II", "sun-sky", False),
    ("II", "overcast", True), ("3C", "overcast", False), ("3C", "sun-sky", True)])
def test_chosen_factors_are_the_lstsq_ones(water, light, seabed):
    """The rank chosen, its factors and errors, as with lstsq in every solve;
    the rank before it (if any) is over the tolerance with lstsq too."""
    t = setup_tables(water, light, seabed)
    chosen = lfc.choose_irradiance_factors(t)
    rank = chosen["coef"].shape[1] - 2
    assert rank < t.irradiance_per_e0.shape[0]          # the fitted case, not the exact one
    assert_same_fit(chosen, lstsq_factors(t, rank), t)
    assert chosen["max_error"] <= lfc.IRRADIANCE_TOLERANCE
    ranks = list(lfc.IRRADIANCE_RANKS)
    if ranks.index(rank) > 0:
        before = lstsq_factors(t, ranks[ranks.index(rank) - 1])
        assert before["max_error"] > lfc.IRRADIANCE_TOLERANCE


@pytest.mark.parametrize("rank", [4, 7])
def test_every_rank_is_the_lstsq_one_with_many_bands(rank):
    from aquaspec.transport.lightfield.bake import lightfield_tables
    t = lightfield_tables(load_water("IB").on_bands(Bands(16)), phase="petzold")
    assert_same_fit(lfc.irradiance_factors(t, rank), lstsq_factors(t, rank), t)


def test_forced_fallback_is_lstsq(monkeypatch):
    """With the guard forced (every Gram matrix too ill-conditioned, every
    gap too small) each solve is numpy's lstsq and the start numpy's SVD."""
    t = setup_tables("IB", "overcast", False)
    calls = {"lstsq": 0, "svd": 0}

    def counted(name):
        real = getattr(np.linalg, name)

        def call(*args, **kw):
            calls[name] += 1
            return real(*args, **kw)
        return call
    monkeypatch.setattr(factors, "GRAM_CONDITION_LIMIT", 1.0)
    monkeypatch.setattr(factors, "SUBSPACE_GAP_LIMIT", np.inf)
    monkeypatch.setattr(factors.np, "linalg", types.SimpleNamespace(
        **{k: getattr(np.linalg, k) for k in ("eigh",)},
        lstsq=counted("lstsq"), svd=counted("svd")))
    fac = lfc.irradiance_factors(t, rank=5, sweeps=3)
    monkeypatch.undo()
    assert calls == {"lstsq": 1 + 2 * 3 + 1, "svd": 1}
    ref = lstsq_factors(t, rank=5, sweeps=3)
    assert_same_fit(fac, ref, t)
    # The fallback is numpy's own solve: the same to rounding.
    np.testing.assert_allclose(fitted_irradiance(fac, t), fitted_irradiance(ref, t), rtol=1e-12)


class TestNormalLstsq:
    def test_is_lstsq_on_a_well_conditioned_problem(self):
        rng = np.random.default_rng(5)
        a = rng.normal(size=(4000, 6)) * np.array([1.0, 30.0, 1e-3, 5.0, 1e2, 0.1])
        b = a @ rng.normal(size=(6, 8)) + rng.normal(size=(4000, 8))
        ref = np.linalg.lstsq(a, b, rcond=None)[0]
        np.testing.assert_allclose(factors.normal_lstsq(a, b), ref, rtol=0,
                                   atol=1e-10 * np.abs(ref).max())

    def test_an_ill_conditioned_gram_matrix_falls_back_to_lstsq(self):
        """Columns [1, 20 + 1e-10 k]: cond(A) ~ 1e10, its Gram matrix beyond
        double precision; the normal equations would lose every digit."""
        k = np.arange(4000.0)
        a = np.stack([np.ones_like(k), 20.0 + 1e-10 * k, np.cos(k / 300.0)], axis=1)
        b = np.stack([np.sin(k / 500.0), k / 4000.0], axis=1)
        gram = a.T @ a
        scaled = gram / np.sqrt(np.outer(np.diag(gram), np.diag(gram)))
        assert np.linalg.cond(scaled) > factors.GRAM_CONDITION_LIMIT
        np.testing.assert_array_equal(factors.normal_lstsq(a, b),
                                      np.linalg.lstsq(a, b, rcond=None)[0])

    def test_a_zero_column_falls_back_to_lstsq(self):
        a = np.stack([np.ones(50), np.zeros(50)], axis=1)
        b = np.arange(50.0)[:, None]
        np.testing.assert_array_equal(factors.normal_lstsq(a, b),
                                      np.linalg.lstsq(a, b, rcond=None)[0])


class TestLeadingRows:
    def test_are_the_svd_rows_up_to_sign(self):
        rng = np.random.default_rng(7)
        r = rng.normal(size=(8, 3000)) * np.array([50, 20, 9, 4, 1, 0.3, 0.1, 0.01])[:, None]
        _, sv, vt = np.linalg.svd(r, full_matrices=False)
        rows = factors.leading_rows(r, 5)
        sign = np.sign(np.sum(rows * vt[:5], axis=1))
        np.testing.assert_allclose(rows * sign[:, None], vt[:5] * sv[:5, None],
                                   rtol=0, atol=1e-10 * sv[0])

    def test_no_gap_falls_back_to_the_svd(self, monkeypatch):
        """Equal singular values at the cut: the eigenvectors of r r^T do not
        resolve the subspace, the SVD is taken."""
        q, _ = np.linalg.qr(np.random.default_rng(2).normal(size=(3000, 6)))
        r = (q * np.array([9.0, 5.0, 2.0, 2.0, 2.0, 1.0])).T
        called = []
        real = np.linalg.svd
        monkeypatch.setattr(np.linalg, "svd", lambda *a, **k: called.append(1) or real(*a, **k))
        rows = factors.leading_rows(r, 3)
        assert called
        assert rows.shape == (3, 3000)
        np.testing.assert_allclose(np.linalg.norm(rows, axis=1), [9.0, 5.0, 2.0], rtol=1e-12)
