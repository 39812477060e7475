"""Discrepancies: scipy's four on the same sets, and the closed forms scipy lacks."""

import importlib
import itertools

import numpy as np
import pytest
from scipy.stats import qmc

from dpc import analysis, baselines
from dpc.errors import InvalidArgumentError


@pytest.fixture(scope="module")
def sets():
    return np.random.default_rng(11).random((4, 200, 2))


@pytest.mark.parametrize("method", ["CD", "WD", "MD"])
def test_squared_scipy_discrepancies_are_rooted(sets, method):
    ours = analysis.discrepancy_per_set(sets, method)
    want = [np.sqrt(qmc.discrepancy(s, method=method)) for s in sets]
    np.testing.assert_allclose(ours, want, rtol=1e-12)
    assert analysis.discrepancy(sets, method) == pytest.approx(np.mean(want), rel=1e-12)


def test_l2_star_is_scipys(sets):
    np.testing.assert_allclose(
        analysis.discrepancy_per_set(sets, "L2-star"), [qmc.discrepancy(s, method="L2-star") for s in sets], rtol=1e-12
    )


@pytest.mark.parametrize("n", [1, 2, 3])
def test_generalized_l2_is_the_sum_over_projections_of_scipys_l2_star(n):
    # Hickernell's modified L2: GL2^2 = sum over non-empty axis subsets u of L2-star(x_u)^2.
    x = np.random.default_rng(n).random((61, n))
    total = sum(
        qmc.discrepancy(x[:, list(u)], method="L2-star") ** 2
        for k in range(1, n + 1)
        for u in itertools.combinations(range(n), k)
    )
    assert analysis.generalized_l2(x) ** 2 == pytest.approx(total, rel=1e-10)


def test_generalized_l2_block_sum_is_independent_of_block_size(monkeypatch):
    d = importlib.import_module("dpc.analysis.discrepancy")  # the name is also a function
    x = np.random.default_rng(9).random((333, 3))
    full = d.generalized_l2(x), d.unanchored_l2(x)
    monkeypatch.setattr(d, "_BLOCK_ELEMS", 333 * 7)  # 7-row blocks, ragged last block
    assert (d.generalized_l2(x), d.unanchored_l2(x)) == pytest.approx(full, rel=1e-12)


def test_unanchored_l2_against_its_definition_1d():
    # UL2^2 = integral over a < b of (b - a - #{a <= x < b} / m)^2, midpoint rule on a fine grid.
    x = np.random.default_rng(3).random((5, 1))
    g = 3000
    a = (np.arange(g) + 0.5) / g
    lo, hi = np.meshgrid(a, a, indexing="ij")
    keep = lo < hi
    inside = ((x[:, 0] >= lo[..., None]) & (x[:, 0] < hi[..., None])).sum(-1) / 5.0
    want = (((hi - lo - inside) ** 2) * keep).sum() / g**2
    assert analysis.unanchored_l2(x) ** 2 == pytest.approx(want, rel=2e-3)


def test_unanchored_l2_against_its_definition_2d():
    # Monte Carlo over random boxes: each box [lo, hi) arises from 2^2 ordered corner pairs.
    rng = np.random.default_rng(4)
    x = rng.random((6, 2))
    a, b = rng.random((400_000, 2)), rng.random((400_000, 2))
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    count = sum(np.all((p >= lo) & (p < hi), axis=1) for p in x) / 6.0
    est = ((np.prod(hi - lo, axis=1) - count) ** 2).mean() / 4.0
    assert analysis.unanchored_l2(x) ** 2 == pytest.approx(est, rel=0.02)


def test_low_discrepancy_sets_score_lower_than_white_noise():
    white = baselines.generate("white", 256, count=8, seed=1)
    sobol = baselines.generate("sobol", 256, count=8, seed=1)
    for method in analysis.DISCREPANCY_METHODS:
        assert analysis.discrepancy(sobol, method) < 0.5 * analysis.discrepancy(white, method)


def test_unknown_method_is_a_typed_error(sets):
    with pytest.raises(InvalidArgumentError):
        analysis.discrepancy(sets, "nope")
