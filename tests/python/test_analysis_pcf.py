"""Pair correlation, minimum distance and the maximal packing distance."""

import itertools
import math

import numpy as np
import pytest

from dpc import analysis, baselines
from dpc.errors import InvalidArgumentError


def _brute_min_distance(x):
    d = x[:, None, :] - x[None, :, :]
    d -= np.rint(d)
    dist = np.sqrt((d**2).sum(-1))
    np.fill_diagonal(dist, np.inf)
    return dist.min()


def test_max_packing_distance_2d_formula_and_1d():
    for m in (16, 256, 1024, 4096):
        assert analysis.max_packing_distance(m, 2) == pytest.approx(math.sqrt(2.0 / (math.sqrt(3.0) * m)), rel=1e-12)
    assert analysis.max_packing_distance(100, 1) == pytest.approx(0.01)
    # 3-D: face-centred cubic with m = 4 k^3 points reaches it exactly (spacing sqrt(2)/(2k)).
    assert analysis.max_packing_distance(4 * 8**3, 3) == pytest.approx(math.sqrt(2) / 16)
    with pytest.raises(InvalidArgumentError):
        analysis.max_packing_distance(100, 11)


def test_white_noise_pcf_is_one():
    x = np.random.default_rng(0).random((60, 1024, 2))
    p = analysis.pcf(x, r_max=2.5, bins=50)
    assert p.d_max == pytest.approx(analysis.max_packing_distance(1024, 2))
    assert abs(np.average(p.g, weights=p.pairs + 1) - 1.0) < 0.01
    assert np.all(np.abs(p.g[5:] - 1.0) < 0.12)  # small first shells hold few pairs
    assert np.abs(p.g - 1.0).mean() < 0.05
    np.testing.assert_allclose(p.r_norm, p.r / p.d_max)


def test_white_noise_pcf_3d_is_one():
    x = np.random.default_rng(1).random((30, 512, 3))
    p = analysis.pcf(x, r_max=2.0, bins=20)
    assert np.abs(p.g[6:] - 1.0).max() < 0.15
    assert abs(np.average(p.g, weights=p.pairs + 1) - 1.0) < 0.03


def test_pcf_pair_counts_match_brute_force():
    x = np.random.default_rng(2).random((2, 300, 2))
    p = analysis.pcf(x, r_max=2.0, bins=10)
    count = np.zeros(10)
    for s in range(2):
        d = x[s][:, None] - x[s][None]
        d -= np.rint(d)
        dist = np.sqrt((d**2).sum(-1))[~np.eye(300, dtype=bool)]
        count += np.histogram(dist, bins=p.edges)[0]
    np.testing.assert_array_equal(p.pairs, count)


def test_blue_noise_pcf_is_empty_below_the_minimum_distance():
    sets = baselines.reference_sets("bnot", 1024, 2)
    p = analysis.pcf(sets, r_max=2.5, bins=100)
    md = analysis.min_distance(sets)
    assert np.all(p.g[p.edges[1:] < md.distances.min()] == 0)
    assert p.g.max() > 2.0  # the first-neighbour peak


def test_min_distance_matches_brute_force_and_design_value():
    x = np.random.default_rng(3).random((3, 200, 2))
    md = analysis.min_distance(x)
    for s in range(3):
        assert md.distances[s] == pytest.approx(_brute_min_distance(x[s]), rel=1e-12)
    # docs/architecture.md ("A quick study"): the authors' 20 BNOT sets at m = 256 have
    # delta_min = 0.74 (mean over sets).
    bnot = baselines.generate("ref-bnot", 256, dims=2, count=20)
    assert analysis.min_distance_ratio(bnot) == pytest.approx(0.74, abs=0.01)
    # The PCF pass finds the same minimum.
    _, md2 = analysis.pair_statistics(bnot)
    np.testing.assert_allclose(md2.distances, analysis.min_distance(bnot).distances)


def test_min_distance_of_a_hexagonal_like_lattice_is_near_one():
    # A rank-1 lattice with a good generator is nearly hexagonal: delta_min close to 1.
    x = baselines.generate("rank1", 1024, dims=2, count=2, seed=0)
    r = analysis.min_distance(x).ratios
    assert np.all((r > 0.85) & (r <= 1.0 + 1e-9))


def test_torus_wraps_distances():
    x = np.array([[[0.001, 0.5], [0.999, 0.5], [0.5, 0.25], [0.5, 0.75]]])
    assert analysis.min_distance(x).distances[0] == pytest.approx(0.002)


def test_pcf_rejects_radii_beyond_half_the_torus():
    x = np.random.default_rng(4).random((16, 2))
    with pytest.raises(InvalidArgumentError):
        analysis.pcf(x, r_max=5.0)
    with pytest.raises(InvalidArgumentError):
        analysis.pcf(np.random.default_rng(4).random((1, 2)))


@pytest.mark.parametrize("n", [1, 2, 4])
def test_pcf_shell_volumes(n):
    # Uniform points: expected pair count per shell = m (m-1) V_shell, any dimension.
    x = np.random.default_rng(5).random((20, 400, n))
    p = analysis.pcf(x, r_max=1.5, bins=5)
    assert np.all(np.abs(p.g[1:] - 1.0) < 0.2)
    assert list(itertools.accumulate(p.edges))[-1] > 0
