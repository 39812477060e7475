"""Baseline samplers: one interface, seeded, each with its defining property checked."""

import math
from importlib import resources

import numpy as np
import pytest
from scipy.stats import qmc

from dpc import baselines
from dpc.errors import InvalidArgumentError

SYNTHETIC = ["white", "jitter", "sobol", "halton", "lhs", "poisson-disk", "dart-throwing", "rank1"]


def _size(name):
    return {"fibonacci": 89}.get(name, 64)


@pytest.mark.parametrize("name", SYNTHETIC + ["fibonacci", "pmj02", "pmj02bn"])
def test_shape_range_and_seeding(name):
    m = _size(name)
    batch = baselines.generate(name, m, dims=2, count=3, seed=5)
    assert batch.shape == (3, m, 2) and batch.dtype == np.float64
    assert batch.min() >= 0.0 and batch.max() < 1.0
    # Set c is a pure function of seed + c (as for dpc models).
    again = baselines.get(name).generate_batch(2, m, 2, seed=6)
    np.testing.assert_array_equal(again, batch[1:])
    assert not np.array_equal(batch[0], batch[1])


@pytest.mark.parametrize("name", ["white", "jitter", "sobol", "halton", "lhs", "dart-throwing", "rank1"])
def test_higher_dimensions(name):
    x = baselines.generate(name, 64, dims=3, count=2, seed=0)
    assert x.shape == (2, 64, 3) and 0 <= x.min() and x.max() < 1


@pytest.mark.parametrize("name", ["pmj02", "pmj02bn"])
def test_pmj02_prefixes_are_02_nets(name):
    """Christensen et al. 2018: every power-of-two prefix of a PMJ02 sequence is a (0,2)-net
    (one point in each elementary interval of every shape); other counts are prefixes too."""
    x = baselines.generate(name, 1024, dims=2, count=3, seed=2)
    for s in x:
        assert all(baselines.is_02_net(s[: 1 << k]) for k in range(11))
    assert np.array_equal(baselines.generate(name, 300, dims=2, seed=2)[0], x[0, :300])
    assert not baselines.is_02_net(baselines.generate("white", 64, seed=0)[0])
    assert baselines.is_02_net(baselines.generate("sobol", 64, seed=0)[0])  # scrambled Sobol' is one too
    with pytest.raises(InvalidArgumentError):
        baselines.is_02_net(x[0, :100])
    with pytest.raises(InvalidArgumentError, match="2-D"):
        baselines.generate(name, 64, dims=3)


def test_pmj02bn_is_bluer_than_pmj02():
    """The best-candidate choice moves points apart where the (0,2) strata leave room: a larger
    minimum distance, most in the small prefixes (16 sets: 0.47 against 0.36 at 16 points, 0.39
    against 0.28 at 32; docs/progressive.md has the larger ones)."""
    from dpc.analysis.pcf import min_distance

    plain = baselines.generate("pmj02", 64, count=16, seed=0)
    blue = baselines.generate("pmj02bn", 64, count=16, seed=0)
    for n in (16, 32):
        assert min_distance(blue[:, :n]).mean_ratio > 1.2 * min_distance(plain[:, :n]).mean_ratio, n


def test_jitter_has_one_point_per_cell():
    x = baselines.generate("jitter", 256, dims=2, count=2, seed=1)
    for s in x:
        cells = np.floor(s * 16).astype(int)
        assert len({tuple(c) for c in cells}) == 256
    with pytest.raises(InvalidArgumentError, match="k\\^2"):
        baselines.generate("jitter", 200)


def test_sobol_is_scipys_scrambled_sobol():
    x = baselines.generate("sobol", 128, dims=2, seed=3)[0]
    want = qmc.Sobol(2, scramble=True, rng=np.random.default_rng(3)).random(128)
    np.testing.assert_array_equal(x, want)
    # A (0, m, 2)-net in base 2: every 1/16 x 1/8 box holds exactly one point.
    cells = np.floor(x * [16, 8]).astype(int)
    assert len({tuple(c) for c in cells}) == 128


def test_lhs_is_stratified_on_every_axis():
    x = baselines.generate("lhs", 50, dims=3, seed=0)[0]
    for k in range(3):
        assert sorted(np.floor(x[:, k] * 50).astype(int)) == list(range(50))


def test_halton_is_scipys():
    x = baselines.generate("halton", 40, dims=2, seed=4)[0]
    want = qmc.Halton(2, scramble=True, rng=np.random.default_rng(4)).random(40)
    np.testing.assert_array_equal(x, want)


def test_poisson_disk_keeps_its_radius_away_from_the_boundary():
    x = baselines.generate("poisson-disk", 256, dims=2, seed=2)[0]
    d = x[:, None] - x[None]  # scipy's sampler is not periodic: plain distance
    dist = np.sqrt((d**2).sum(-1)) + np.eye(256)
    d_max = math.sqrt(2 / (math.sqrt(3) * 256))
    assert dist.min() > 0.5 * d_max


@pytest.mark.parametrize("dims", [2, 5])
def test_dart_throwing_is_a_hard_core_set_on_the_torus(dims):
    """Relaxed dart throwing keeps every toroidal pair apart by a large share of the packing
    bound, across the cube's faces too (what scipy's non-periodic PoissonDisk does not); the
    n-D model cards quote delta_min of about 0.7 at m = 1,024."""
    from dpc import analysis

    x = baselines.generate("dart-throwing", 256, dims=dims, count=2, seed=3)
    md = analysis.min_distance(x)
    assert md.min_ratio > 0.55
    assert analysis.min_distance(baselines.generate("white", 256, dims=dims, count=2, seed=3)).ratios.max() < 0.3


def test_rank1_lattice_structure():
    z = baselines.korobov_generator(1024, 2)
    assert z[0] == 1 and math.gcd(z[1], 1024) == 1
    x = baselines.generate("rank1", 1024, dims=2, seed=0)[0]
    # Undo the random shift: the points are then exactly {i z / m mod 1}.
    shift = x[0] - 0.0
    pts = np.round(((x - shift) % 1.0) * 1024).astype(int) % 1024
    i = np.arange(1024)
    assert {tuple(p) for p in pts} == {(a, b) for a, b in zip(i, i * z[1] % 1024)}
    # P_2-optimal generators beat a poor one (a = 1: all points on the diagonal).
    d = x[:, None] - x[None]
    d -= np.rint(d)
    dist = np.sqrt((d**2).sum(-1)) + np.eye(1024)
    assert dist.min() > 0.8 * math.sqrt(2 / (math.sqrt(3) * 1024))


def test_fibonacci_lattice_needs_fibonacci_numbers():
    assert baselines.fibonacci_numbers(100) == [1, 2, 3, 5, 8, 13, 21, 34, 55, 89]
    assert baselines.nearest_fibonacci(1000) == 987
    x = baselines.generate("fibonacci", 233, seed=1)[0]
    shift = x[0]
    pts = np.round(((x - shift) % 1.0) * 233).astype(int) % 233
    i = np.arange(233)
    assert {tuple(p) for p in pts} == {(a, b) for a, b in zip(i, i * 144 % 233)}
    with pytest.raises(InvalidArgumentError, match="987 or 1597"):
        baselines.generate("fibonacci", 1024)
    with pytest.raises(InvalidArgumentError):
        baselines.generate("fibonacci", 233, dims=3)


def test_reference_sets_are_the_vendored_files():
    root = resources.files("dpc") / "data" / "deepsampling" / "pcf"
    x = baselines.reference_sets("bnot", 1024, 2)
    first = np.loadtxt(str(root / "pcf-bnot-d2-n1024" / "pointset-bnot-d2-n1024-00001.txt"))
    np.testing.assert_array_equal(x[0], first)
    assert baselines.reference_sets("bnot", 256, 2).shape == (20, 256, 2)  # pcf- and test-pcf-
    assert baselines.reference_sets("bnot", 256, 1).shape == (101, 256, 1)
    ref = baselines.get("ref-step")
    assert ref.available() == [(1024, 2, 8)]
    got = ref.generate_batch(3, seed=7)  # sets 7, 0, 1 (cyclic)
    np.testing.assert_array_equal(got, baselines.reference_sets("step", 1024, 2)[[7, 0, 1]])
    with pytest.raises(InvalidArgumentError, match="8 sets"):
        ref.generate_batch(9)
    with pytest.raises(InvalidArgumentError, match="not available"):
        baselines.generate("ref-bnot", 512)


def test_unknown_names_and_bad_arguments():
    assert set(SYNTHETIC) <= set(baselines.available())
    with pytest.raises(InvalidArgumentError, match="available"):
        baselines.get("nope")
    with pytest.raises(InvalidArgumentError):
        baselines.generate("white", 0)
    with pytest.raises(InvalidArgumentError):
        baselines.generate("white", 10, seed=-1)
    with pytest.raises(InvalidArgumentError):
        baselines.generate("white", None)
