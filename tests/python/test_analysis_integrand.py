"""Integrand-spectrum sampling analysis (paper Eq. 5) against direct computations."""

import numpy as np
import pytest

from dpc import baselines
from dpc.analysis import integrand_spectra as IS
from dpc.errors import InvalidArgumentError


def test_spectrum_is_normalised_and_centred():
    for name in IS.NAMES:
        F = IS.integrand_spectrum(name, K=20)
        assert F.shape == (41, 41) and F[20, 20] == 0
        assert abs(F.sum() - 1) < 1e-12 and np.all(F >= 0)
    with pytest.raises(InvalidArgumentError):
        IS.integrand_spectrum("font", K=64)
    with pytest.raises(InvalidArgumentError):
        IS.integrand_spectrum("teapot")


def test_sample_dft_matches_a_direct_sum():
    x = np.random.default_rng(0).random((37, 2))
    S = IS.sample_dft(x, 3)[0]
    for a, qx in enumerate(range(-3, 4)):
        for b, qy in enumerate(range(-3, 4)):
            direct = np.exp(2j * np.pi * (qx * x[:, 0] + qy * x[:, 1])).mean()
            assert abs(S[a, b] - direct) < 1e-12


def test_estimates_equal_averaging_the_integrand_at_the_points():
    fam = IS.random_phase_family("softshadows", count=3, seed=1, K=12)
    sets = np.random.default_rng(2).random((2, 50, 2))
    est = IS.mc_estimates(sets, fam)
    for j in range(3):
        for s in range(2):
            assert abs(est[j, s] - fam.evaluate(sets[s], j).mean()) < 1e-12


def test_white_noise_scores_one_and_the_error_follows_eq5():
    F = IS.integrand_spectrum("font", K=16)
    white = baselines.generate("white", 256, 2, count=200, seed=0)
    assert abs(IS.eq5_variance(white, F) - 1) < 0.03
    # MC error of random-phase integrands = Eq. 5 / (2m) in expectation
    fam = IS.random_phase_family("font", count=200, seed=3, K=16)
    jit = baselines.generate("jitter", 256, 2, count=100, seed=0)
    for sets in (white, jit):
        expect = IS.eq5_variance(sets, F) / (2 * 256)
        assert abs(IS.mc_error(sets, fam) / expect - 1) < 0.1


def test_mc_error_standard_error():
    fam = IS.random_phase_family("font", count=5, seed=0, K=8)
    sets = np.random.default_rng(0).random((4, 64, 2))
    err, se = IS.mc_error(sets, fam, with_se=True)
    e2 = IS.mc_estimates(sets, fam) ** 2
    assert err == pytest.approx(e2.mean()) and se == pytest.approx(e2.std(ddof=1) / np.sqrt(20))
