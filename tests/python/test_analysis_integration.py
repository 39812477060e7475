"""Monte Carlo integration study: exact integrals, unbiasedness, variance laws."""

import numpy as np
import pytest

from dpc import analysis, baselines
from dpc.analysis.integration import _halfspace_volume
from dpc.errors import InvalidArgumentError


def _midpoint_grid(g, n=2):
    a = (np.arange(g) + 0.5) / g
    return np.stack(np.meshgrid(*([a] * n), indexing="ij"), axis=-1).reshape(-1, n)


@pytest.mark.parametrize("family, rtol", [("gaussian", 1e-6), ("heaviside", 2e-3), ("disk", 2e-3)])
def test_exact_integrals_match_quadrature(family, rtol):
    fam = analysis.integrands(family, 8, dims=2, seed=5)
    grid = _midpoint_grid(1000)
    quad = np.array([fam.evaluate(grid, i).mean() for i in range(fam.count)])
    np.testing.assert_allclose(fam.exact(), quad, rtol=rtol)
    assert np.all((fam.exact() > 0.01) & (fam.exact() < 1.0))


def test_halfspace_volume_in_3d_and_degenerate_normals():
    rng = np.random.default_rng(0)
    x = rng.random((400_000, 3))
    for _ in range(4):
        w = rng.standard_normal(3)
        t = float(w @ rng.uniform(0.2, 0.8, 3))
        mc = np.mean(x @ w <= t)
        assert _halfspace_volume(w, t) == pytest.approx(mc, abs=4e-3)
    assert _halfspace_volume(np.array([1.0, 0.0]), 0.3) == pytest.approx(0.3)
    assert _halfspace_volume(np.array([-1.0, 0.0]), -0.3) == pytest.approx(0.7)
    assert _halfspace_volume(np.array([1.0, 1.0]), 1.0) == pytest.approx(0.5)


def test_estimates_are_unbiased_and_white_noise_variance_is_binomial():
    m, reps = 64, 600
    fam = analysis.integrands("disk", 10, dims=2, seed=1)
    sets = baselines.generate("white", m, count=reps, seed=2)
    est = analysis.estimates(sets, fam)
    exact = fam.exact()
    se = np.sqrt(exact * (1 - exact) / m / reps)
    assert np.all(np.abs(est.mean(axis=1) - exact) < 4.5 * se)
    # For an indicator, Var = I (1 - I) / m, so the relative variance is (1 - I) / (I m).
    rv = analysis.relative_variance(sets, fam)
    assert rv.mean() == pytest.approx(np.mean((1 - exact) / (exact * m)), rel=0.1)


def _slope(m, v):
    return np.polyfit(np.log(m), np.log(v), 1)[0]


def test_variance_convergence_rates():
    counts = [16, 64, 256, 1024]
    study = analysis.integration_study(
        {
            "white": lambda c, m, s: baselines.generate("white", m, count=c, seed=s),
            "jitter": lambda c, m, s: baselines.generate("jitter", m, count=c, seed=s),
        },
        counts,
        integrands_per_family=6,
        realisations=96,
        seed=3,
    )
    rv = study.rel_var
    assert study.points == {"white": counts, "jitter": counts}
    for fam in analysis.FAMILIES:
        assert _slope(counts, rv[fam]["white"]) == pytest.approx(-1.0, abs=0.2)
    # Jittered sampling: m^-1.5 for discontinuities (disk, half-plane), m^-2 for smooth ones.
    assert _slope(counts, rv["disk"]["jitter"]) == pytest.approx(-1.5, abs=0.25)
    assert _slope(counts, rv["heaviside"]["jitter"]) == pytest.approx(-1.5, abs=0.3)
    assert _slope(counts, rv["gaussian"]["jitter"]) == pytest.approx(-2.0, abs=0.25)
    doc = study.to_json()
    assert doc["relative_variance"]["disk"]["white"] == rv["disk"]["white"]


def test_study_records_the_actual_point_count_of_fixed_size_samplers():
    def fib(count, m, seed):
        return baselines.generate("fibonacci", baselines.nearest_fibonacci(m), count=count, seed=seed)

    study = analysis.integration_study(
        {"fibonacci": fib}, [100, 250], realisations=8, integrands_per_family=2, families=("disk",)
    )
    assert study.points["fibonacci"] == [89, 233]
    assert len(study.rel_var["disk"]["fibonacci"]) == 2


def test_bad_arguments():
    with pytest.raises(InvalidArgumentError):
        analysis.integrands("cosine", 3)
    with pytest.raises(InvalidArgumentError):
        analysis.relative_variance(np.random.default_rng(0).random((1, 10, 2)), analysis.integrands("disk", 2))
    with pytest.raises(InvalidArgumentError):
        analysis.estimates(np.zeros((3, 10, 3)), analysis.integrands("disk", 2, dims=2))
    with pytest.raises(InvalidArgumentError):
        analysis.integration_study({"w": lambda c, m, s: np.zeros((c - 1, m, 2))}, [8])
