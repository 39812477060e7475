"""Power spectra against their definitions and against analytic and published references."""

import math

import numpy as np
import pytest

from dpc import analysis, baselines
from dpc.analysis import spectrum as sp
from dpc.analysis.reference import reference_radial_spectrum
from dpc.errors import InvalidArgumentError


def _grid_q(freqs):
    qx, qy = np.meshgrid(freqs, freqs, indexing="ij")
    return np.stack([qx.ravel(), qy.ravel()], axis=1)


@pytest.fixture(scope="module")
def white_100x1024():
    return np.random.default_rng(12345).random((100, 1024, 2))


# ------------------------------------------------------------------ fast paths vs direct sums
@pytest.mark.parametrize("stride", [1, 3])
def test_separable_2d_matches_direct_sum(stride):
    x = np.random.default_rng(1).random((3, 150, 2))
    fast = analysis.power_spectrum_2d(x, nu_max=1.2, stride=stride, dtype=np.float64)
    direct = analysis.power_spectrum_direct(x, _grid_q(fast.freqs)).reshape(fast.power.shape)
    k = fast.freqs.size // 2
    assert direct[k, k] == pytest.approx(150.0)  # DC of the direct sum is m ...
    direct[k, k] = 0.0  # ... and removed in the spectrum
    np.testing.assert_allclose(fast.power, direct, rtol=1e-9, atol=1e-9)
    assert np.array_equal(fast.freqs, stride * np.arange(-k, k + 1))


def test_separable_2d_single_precision_is_close():
    x = np.random.default_rng(2).random((2, 300, 2))
    f64 = analysis.power_spectrum_2d(x, nu_max=2.0, dtype=np.float64).power
    f32 = analysis.power_spectrum_2d(x, nu_max=2.0, dtype=np.float32).power
    np.testing.assert_allclose(f32, f64, atol=2e-5 * f64.max())


def test_2d_subspace_of_nd_set_is_the_2d_spectrum_of_the_projection():
    x = np.random.default_rng(3).random((2, 200, 4))
    sub = analysis.power_spectrum_2d(x, dims=(3, 1), nu_max=1.0, dtype=np.float64)
    proj = analysis.power_spectrum_2d(x[:, :, [3, 1]], nu_max=1.0, dtype=np.float64)
    np.testing.assert_array_equal(sub.power, proj.power)
    direct = analysis.power_spectrum_direct(x[:, :, [3, 1]], _grid_q(sub.freqs))
    direct = direct.reshape(sub.power.shape)
    direct[sub.freqs.size // 2, sub.freqs.size // 2] = 0
    np.testing.assert_allclose(sub.power, direct, atol=1e-9)


@pytest.mark.parametrize("stride", [None, 7])
def test_1d_projection_blocked_product_matches_direct_sum(stride):
    x = np.random.default_rng(4).random((3, 257, 3))
    s1 = analysis.power_spectrum_1d(x, dim=2, nu_max=1.5, stride=stride, dtype=np.float64)
    direct = analysis.power_spectrum_direct(x[:, :, 2:], s1.freqs[:, None])
    np.testing.assert_allclose(s1.power, direct, rtol=1e-9, atol=1e-9)
    assert s1.freqs[0] == s1.stride and s1.freqs[-1] >= 1.5 * 257
    s32 = analysis.power_spectrum_1d(x, dim=2, nu_max=1.5, stride=stride, dtype=np.float32)
    np.testing.assert_allclose(s32.power, direct, atol=1e-4 * direct.max())


def test_1d_two_band_sampling_beyond_max_freqs():
    x = np.random.default_rng(14).random((2, 257, 1))
    s1 = analysis.power_spectrum_1d(x, nu_max=4.0, max_freqs=200, dtype=np.float64)
    assert np.array_equal(s1.freqs[:100], np.arange(1, 101))  # every integer first
    assert np.all(np.diff(s1.freqs[100:]) == s1.stride) and s1.stride == 10
    assert s1.freqs[-1] >= 4 * 257 and s1.freqs.size <= 200
    np.testing.assert_allclose(s1.power, analysis.power_spectrum_direct(x, s1.freqs), rtol=1e-9, atol=1e-9)


def test_spectrum_symmetry_and_dc():
    x = np.random.default_rng(5).random((4, 64, 2))
    s = analysis.power_spectrum_2d(x, dtype=np.float64)
    np.testing.assert_allclose(s.power, s.power[::-1, ::-1], rtol=1e-12)  # P(q) = P(-q)
    k = s.freqs.size // 2
    assert s.power[k, k] == 0.0
    assert s.freqs[-1] >= 4 * math.sqrt(64) + 1


# ------------------------------------------------------------------ white noise and jitter
def test_white_noise_is_flat_at_one_within_2_percent(white_100x1024):
    s = analysis.power_spectrum_2d(white_100x1024)
    assert s.stride == 1 and s.n_sets == 100
    nu = np.hypot(*np.meshgrid(s.freqs, s.freqs, indexing="ij")) / 32.0
    for lo in np.arange(0.0, 4.0, 0.5):  # every band of width 0.5 in (0, 4]
        band = (nu > lo) & (nu <= lo + 0.5)
        assert abs(s.power[band].mean() - 1.0) < 0.02, (lo, s.power[band].mean())
    r = s.radial(4.0)
    assert abs(r.mean.mean() - 1.0) < 0.01
    # The anisotropy of an average of 100 exponential variables is 10 log10(1/100) = -20 dB.
    assert np.median(r.anisotropy_db[r.nu > 0.5]) == pytest.approx(-20.0, abs=1.0)


def test_white_noise_projection_and_mc_radial_are_flat(white_100x1024):
    p = analysis.power_spectrum_1d(white_100x1024[:40], dim=1)
    assert abs(p.power.mean() - 1.0) < 0.02
    x3 = np.random.default_rng(6).random((16, 512, 3))
    r = analysis.radial_spectrum_mc(x3, directions=64)
    assert r.method == "monte-carlo" and r.dims == 3
    assert abs(np.average(r.mean, weights=r.samples) - 1.0) < 0.03
    assert r.nu[-1] == pytest.approx(4.0, abs=1 / 8)


def _analytic_jitter(freqs, k):
    a = np.sinc(freqs / k) ** 2  # numpy sinc(x) = sin(pi x)/(pi x)
    p = 1.0 - a[:, None] * a[None, :]
    c = freqs.size // 2
    p[c, c] = 0.0
    return p


def test_jittered_32x32_matches_its_analytic_spectrum():
    x = baselines.generate("jitter", 1024, dims=2, count=64, seed=7)
    s = analysis.power_spectrum_2d(x)
    ref = sp.Spectrum2D(
        power=_analytic_jitter(s.freqs, 32), freqs=s.freqs, stride=1, n_points=1024, n_sets=1, dims=(0, 1)
    )
    got, want = s.radial(4.0), ref.radial(4.0)
    ratio = got.mean / want.mean
    assert np.all(np.abs(ratio[1:] - 1.0) < 0.15), np.abs(ratio - 1).max()
    assert abs(np.mean(ratio) - 1.0) < 0.02
    # Grid-wise: the mean absolute deviation is what 64 sets of noise allow.
    assert np.mean(np.abs(s.power - ref.power)) < 0.12
    # And the analytic profile equals the authors' jitter radial target (which stores DC = 0).
    tgt = reference_radial_spectrum("jitter", 1024, 2)
    n = min(tgt.power.size, want.mean.size)
    assert np.max(np.abs(tgt.power[:n] - want.mean[:n])) < 0.05


def test_mc_radial_agrees_with_grid_on_jitter():
    x = baselines.generate("jitter", 256, dims=2, count=24, seed=8)
    grid = analysis.radial_spectrum(x)
    mc = analysis.radial_spectrum_mc(x, directions=96)
    both = min(grid.mean.size, mc.mean.size)
    assert np.array_equal(grid.radius[:both], mc.radius[:both])
    # Rounding directions to integers blurs rings by under one frequency: compare bands.
    g = grid.mean[:both].reshape(-1, 8).mean(axis=1)
    m = mc.mean[:both].reshape(-1, 8).mean(axis=1)
    np.testing.assert_allclose(m, g, atol=0.08)


# ------------------------------------------------------------------ the authors' BNOT sets
def test_bnot_sets_match_the_bnot_radial_target():
    sets = baselines.reference_sets("bnot", 1024, 2)
    assert sets.shape == (10, 1024, 2)
    r = analysis.power_spectrum_2d(sets).radial(4.0)
    tgt = reference_radial_spectrum("bnot", 1024, 2)  # DC row (= m) dropped
    assert tgt.radius[0] == 1 and np.array_equal(r.radius, tgt.radius[: r.radius.size])
    diff = np.abs(r.mean - tgt.power[: r.mean.size])
    assert diff.mean() < 0.03
    assert diff[r.nu < 0.5].max() < 0.01
    assert abs(int(np.argmax(r.mean)) - int(np.argmax(tgt.power[: r.mean.size]))) <= 2
    # The comparison discriminates: white noise is nowhere near the target.
    w = analysis.power_spectrum_2d(np.random.default_rng(9).random((10, 1024, 2))).radial(4.0)
    assert np.abs(w.mean - tgt.power[: w.mean.size]).mean() > 0.3


def test_reference_copies_find_the_2d_spectrum_in_the_5d_and_10d_targets():
    copies = {(c.copy, c.source): c for c in analysis.reference_spectrum_copies()}
    five = copies[("bnot-powspec-radialmean-d5-n1024.txt", "bnot-powspec-radialmean-d2-n16_old.txt")]
    ten = copies[("bnot-powspec-radialmean-d10-n1024.txt", "bnot-powspec-radialmean-d2-n16_old.txt")]
    assert (five.stride, five.rings) == (1, 31) and (ten.stride, ten.rings) == (2, 15)
    # The same numbers at the same nu: 5-D at 1,024 points and 2-D at 16 both have m^(1/n) = 4.
    t5, t2 = reference_radial_spectrum("bnot", 1024, 5), reference_radial_spectrum("bnot", 256, 4)
    np.testing.assert_array_equal(t5.power, t2.power)
    np.testing.assert_array_equal(t5.nu, t2.nu)
    # The 3-D and 4-D targets the cards use are not copies, and every copy goes to fewer dimensions.
    used = {c.copy for c in copies.values()}
    assert "bnot-powspec-radialmean-d3-n1024.txt" not in used
    assert "bnot-powspec-radialmean-d4-n1024.txt" not in used
    assert all(c.source_dims < c.copy_dims for c in copies.values())
    assert all(f"-d{c.source_dims}-" in c.source and f"-d{c.copy_dims}-" in c.copy for c in copies.values())


def test_bnot_256_low_frequency_energy_and_peak():
    # docs/architecture.md ("A quick study") measured these for the authors' 20 BNOT sets at m = 256.
    sets = np.concatenate([baselines.generate("ref-bnot", 256, dims=2, count=20)])
    s = analysis.power_spectrum_2d(sets)
    assert s.low_frequency_energy(0.5) == pytest.approx(0.0024, rel=0.05)
    assert s.low_frequency_energy(0.75) == pytest.approx(0.026, rel=0.05)
    r = s.radial(4.0)
    # nu0 sqrt(m) is an integer here, so the ring-weighted mean is exactly the grid mean.
    assert r.low_frequency_energy(0.5) == pytest.approx(s.low_frequency_energy(0.5), rel=1e-12)
    peak, nu = r.peak()
    assert 2.2 < peak < 2.6 and nu == pytest.approx(1.06, abs=0.07)


def test_exact_low_frequency_energy_is_its_definition():
    """E_low in 2-D equals the grid spectrum's (every frequency of the disc); in 3-D it equals a
    brute-force mean over the integer ball, and the Monte Carlo radial spectrum reports it."""
    x2 = np.random.default_rng(3).random((4, 300, 2))
    grid = analysis.power_spectrum_2d(x2, nu_max=1.0, dtype=np.float64)
    for nu in (0.3, 0.5, 0.75):
        assert analysis.low_frequency_energy(x2, nu) == pytest.approx(grid.low_frequency_energy(nu), rel=1e-9)
    x3 = baselines.generate("jitter", 512, dims=3, count=3, seed=2)
    r = 0.75 * 512 ** (1 / 3)
    k = int(r)
    q = np.array([(a, b, c) for a in range(-k, k + 1) for b in range(-k, k + 1) for c in range(-k, k + 1)])
    q = q[(np.sum(q * q, axis=1) > 0) & (np.sum(q * q, axis=1) < r * r)]
    want = float(np.mean(analysis.power_spectrum_direct(x3, q)))
    assert analysis.low_frequency_energy(x3, 0.75) == pytest.approx(want, rel=1e-12)
    assert analysis.radial_spectrum(x3, nu_max=2.0).low_frequency_energy(0.75) == pytest.approx(want, rel=1e-12)
    # a subspace: the same as the projection's own E_low
    assert analysis.low_frequency_energy(x3, 0.75, dims=(0, 2)) == pytest.approx(
        analysis.low_frequency_energy(x3[:, :, [0, 2]], 0.75), rel=1e-12
    )
    with pytest.raises(InvalidArgumentError, match="no integer frequencies"):
        analysis.low_frequency_energy(np.random.default_rng(0).random((1, 1024, 10)), 0.5)
    with pytest.raises(InvalidArgumentError):  # LimitError is one
        analysis.low_frequency_energy(np.random.default_rng(0).random((1, 4096, 6)), 3.0)


def test_stride_kicks_in_for_large_sets_and_stays_exact():
    x = np.random.default_rng(10).random((1, 4096, 2))
    s = analysis.power_spectrum_2d(x, max_size=129)
    assert s.stride == math.ceil(4 * 64 / 63) and s.freqs.size <= 129
    pick = np.array([[s.freqs[-1], s.freqs[3]], [s.freqs[70], s.freqs[64]]])
    want = analysis.power_spectrum_direct(x, pick)
    c = s.freqs.size // 2
    assert s.power[-1, 3] == pytest.approx(want[0], rel=1e-4)
    assert s.power[70, 64] == pytest.approx(want[1], rel=1e-4)
    assert s.radial().nu[-1] >= 4.0 and c == (s.freqs.size - 1) // 2


# ------------------------------------------------------------------ input validation
@pytest.mark.parametrize(
    "bad", [np.full((5, 2), np.nan), np.full((5, 2), 1.5), np.zeros((2, 2, 2, 2)), np.array([["a", "b"]])]
)
def test_bad_points_raise_typed_errors(bad):
    with pytest.raises(InvalidArgumentError):
        analysis.power_spectrum_2d(bad)


def test_bad_options_raise_typed_errors():
    x = np.random.default_rng(0).random((10, 3))
    with pytest.raises(InvalidArgumentError):
        analysis.power_spectrum_2d(x, dims=(0, 0))
    with pytest.raises(InvalidArgumentError):
        analysis.power_spectrum_2d(x, dims=(0, 3))
    with pytest.raises(InvalidArgumentError):
        analysis.power_spectrum_1d(x, nu_max=0)
    with pytest.raises(InvalidArgumentError):
        analysis.power_spectrum_direct(x, [[0.5, 1, 2]])
    one = analysis.power_spectrum_2d(np.where(x == 0, 1.0, x)[:, :2])  # 1.0 wraps to 0.0
    assert np.isfinite(one.power).all()
