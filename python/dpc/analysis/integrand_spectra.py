"""Sampling for an integrand family given by its mean power spectrum (paper Sec. 6.3, Eq. 5).

The authors ship the mean power spectra F of three families of 2-D integrands (font glyphs,
soft shadows, environment maps; `dpc/data/deepsampling/integrand-spectra/`). For a sampler with
expected power spectrum E[P(q)], the expected squared error of the Monte Carlo estimate of an
integrand with power |f̂(q)|² is (1/m) Σ_q |f̂(q)|² E[P(q)], so Σ_q F(q) E[P(q)] (Eq. 5, F
normalised to sum 1: white noise scores 1) ranks samplers for the whole family.

``random_phase_family`` gives concrete integrands with that expected power,
f(x) = Re Σ_q √F(q) e^{iφ_q} e^{2πi q·x}, and ``mc_error`` integrates them with point sets: the
estimate (1/m) Σ_k f(x_k) = Re Σ_q √F(q) e^{iφ_q} S(q) with S(q) = (1/m) Σ_k e^{2πi q·x_k}, exact
by linearity, so one small DFT per set replaces evaluating f at every point.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from .. import _args
from ..errors import InvalidArgumentError
from ._common import as_sets

NAMES = ("font", "softshadows", "envmap")
_FILES = {
    "font": "font_spectrum_128.npy",
    "softshadows": "softshadows_spectrum_128.npy",
    "envmap": "envmap_spectrum_512.npy",
}


def _path(name: str) -> Path:
    if name not in _FILES:
        raise InvalidArgumentError(f"unknown integrand spectrum {name!r}; choose from {NAMES}")
    return Path(str(resources.files("dpc") / "data" / "deepsampling" / "integrand-spectra" / _FILES[name]))


def integrand_spectrum(name: str, K: int = 63) -> np.ndarray:
    """The family's mean power spectrum on q ∈ [−K, K]² (centred, DC = 0), summing to 1."""
    a = np.load(_path(name)).astype(np.float64)
    c = a.shape[0] // 2
    if not 1 <= int(K) <= c - 1:
        raise InvalidArgumentError(f"K must be in [1, {c - 1}] for {name!r} ({a.shape}), got {K}")
    K = int(K)
    F = a[c - K : c + K + 1, c - K : c + K + 1].copy()
    F[K, K] = 0.0
    total = F.sum()
    if not total > 0:
        raise InvalidArgumentError(f"{name!r}: the spectrum has no power off DC")
    return F / total


def sample_dft(points, K: int) -> np.ndarray:
    """S(q) = (1/m) Σ_k e^{2πi q·x_k} on q ∈ [−K, K]² for each set: (sets, 2K+1, 2K+1) complex.
    Separable: one (2K+1 × m)·(m × 2K+1) product per set."""
    sets = as_sets(points)
    if sets.shape[2] != 2:
        raise InvalidArgumentError(f"integrand spectra are 2-D; got {sets.shape[2]}-D points")
    q = np.arange(-int(K), int(K) + 1, dtype=np.float64)
    out = np.empty((sets.shape[0], q.size, q.size), dtype=np.complex128)
    for s, x in enumerate(sets.astype(np.float64)):
        ex = np.exp(2j * np.pi * np.outer(x[:, 0], q))
        ey = np.exp(2j * np.pi * np.outer(x[:, 1], q))
        out[s] = ex.T @ ey / x.shape[0]
    return out


def eq5_variance(points, F: np.ndarray) -> float:
    """Σ_q F(q)·P(q) (paper Eq. 5) with P = m·|S(q)|² averaged over the sets; white noise = 1."""
    K = (F.shape[0] - 1) // 2
    S = sample_dft(points, K)
    m = as_sets(points).shape[1]
    return float(np.sum(F * (m * np.abs(S) ** 2).mean(axis=0)))


@dataclass
class RandomPhaseFamily:
    """Integrands f_j(x) = Re Σ_q A_j(q) e^{2πi q·x}, A_j = √F e^{iφ_j}: E|f̂|² = F, ∫f = 0."""

    name: str
    amplitudes: np.ndarray  # (count, 2K+1, 2K+1) complex

    @property
    def count(self) -> int:
        return self.amplitudes.shape[0]

    def evaluate(self, x: np.ndarray, j: int) -> np.ndarray:
        """f_j at points x (N, 2), directly (for tests; mc_error does not need it)."""
        K = (self.amplitudes.shape[1] - 1) // 2
        q = np.arange(-K, K + 1, dtype=np.float64)
        ex = np.exp(2j * np.pi * np.outer(x[:, 0], q))
        ey = np.exp(2j * np.pi * np.outer(x[:, 1], q))
        return np.real(np.sum((ex @ self.amplitudes[j]) * ey, axis=1))


def random_phase_family(name: str, count: int = 20, seed: int = 0, K: int = 63) -> RandomPhaseFamily:
    count = _args.integer(count, "count", 1, whole_floats=True)
    F = integrand_spectrum(name, K)
    rng = np.random.default_rng(seed)
    phase = rng.uniform(0.0, 2.0 * np.pi, (int(count),) + F.shape)
    return RandomPhaseFamily(name=name, amplitudes=np.sqrt(F)[None] * np.exp(1j * phase))


def mc_estimates(points, family: RandomPhaseFamily) -> np.ndarray:
    """(1/m) Σ_k f_j(x_k) for every integrand j and set s: array (count, sets)."""
    K = (family.amplitudes.shape[1] - 1) // 2
    S = sample_dft(points, K)
    return np.real(np.einsum("jab,sab->js", family.amplitudes, S))


def mc_error(points, family: RandomPhaseFamily, *, with_se: bool = False):
    """Mean squared error of the estimates over integrands and sets (every ∫f_j is 0); with
    ``with_se``, also its standard error (std of the squared errors / √(count · sets))."""
    e2 = mc_estimates(points, family) ** 2
    if with_se:
        return float(e2.mean()), float(e2.std(ddof=1) / np.sqrt(e2.size))
    return float(e2.mean())
