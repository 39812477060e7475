"""Loss targets: the authors' files (vendored in the dpc package, dpc/data/deepsampling, see its README),
analytic step and jitter spectra, profiles measured from point sets, integrand spectra (Eq. 5).

Every spectral target is returned in the conventions of losses.py (white noise = 1, DC = 0,
radial bins floor(|q|), full 2-D spectra indexed [q + K, p + K]), so `radspec(X) − target`
and `spec(X) ∘ F` line up entry by entry.
"""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path

import numpy as np
import torch

from .losses import LossError, radial_bins, radspec, spec


def data_dir() -> Path:
    """The authors' target files, vendored in the dpc package (dpc/data/deepsampling, see its
    README), found through importlib.resources."""
    p = resources.files("dpc").joinpath("data", "deepsampling")
    if not p.is_dir():
        raise LossError(f"the dpc package has no deepsampling target files ({p})")
    return Path(str(p))


def load_radial_file(name: str, k: int, m: int) -> np.ndarray:
    """Radial (or 1-D) power profile of the authors' files, index = integer radius, DC = 0."""
    d = data_dir() / "spectra"
    cands = [d / f"{name}-powspec-radialmean-d{k}-n{m}.txt"]
    if k == 1:
        cands.append(d / f"{name}-powspec-d1-n{m}.txt")
    for p in cands:
        if p.is_file():
            a = np.loadtxt(p)
            if not np.allclose(a[:, 0], np.arange(len(a))):
                raise LossError(f"{p.name}: first column is not the integer radius 0, 1, 2, ...")
            prof = a[:, 1].astype(np.float64)
            prof[0] = 0.0  # files keep DC = m (bnot, step) or 0 (jitter): normalise to 0
            return prof
    avail = sorted(p.name for p in d.glob(f"{name}-powspec*"))
    raise LossError(f"no radial target file for {name!r}, d={k}, n={m}; have: {avail}")


def radial_target(name: str, m: int, k: int = 2, nu_max: float = 4.0, source: str = "auto") -> torch.Tensor:
    """Radial target of length radial_bins(m, k, nu_max), to compare with radspec(X, nu_max).

    source: "auto" (analytic profile for `step` and square-m 2-D `jitter`, else the authors'
    file), "file" (always the authors' `*-powspec-radialmean-*` file), "analytic".
    """
    if source not in ("auto", "file", "analytic"):
        raise LossError(f"radial_target source must be auto, file or analytic, got {source!r}")
    nb = radial_bins(m, k, nu_max)
    if source != "file":
        if name == "step":
            return step_radial(m, k, nu_max)
        if name == "jitter" and k == 2 and round(math.sqrt(m)) ** 2 == m:
            return jitter_radial(m, nu_max)
        if source == "analytic":
            raise LossError(f"no analytic radial profile for {name!r} (d={k}, n={m})")
    prof = load_radial_file(name, k, m)
    if len(prof) < nb:
        raise LossError(f"target {name!r} (d={k}, n={m}) has {len(prof)} radii, need {nb} for nu_max = {nu_max}")
    return torch.from_numpy(prof[:nb].copy())


def spectrum2d_target(name: str, m: int, K: int) -> torch.Tensor:
    """Full 2-D power spectrum file (`{name}-powspec-d2-n{m}.npy`, centred on DC), cropped to
    [−K, K]², DC = 0; matches spec(X, K)."""
    p = data_dir() / "spectra" / f"{name}-powspec-d2-n{m}.npy"
    if not p.is_file():
        raise LossError(f"no 2-D spectrum file {p.name}")
    return _crop_centred(np.load(p).astype(np.float64), K, p.name)


def spectrum2d_radial(name: str, m: int, nu_max: float = 4.0) -> torch.Tensor:
    """Radial mean of a 2-D spectrum file (`{name}-powspec-d2-n{m}.npy`) with radspec's binning
    (floor(|q|), DC = 0): an isotropic target from the authors' measured 2-D spectra (green and
    pink noise ship only as 2-D spectra)."""
    return _radial_mean(lambda R: spectrum2d_target(name, m, R), m, nu_max)


def _radial_mean(spectrum, m: int, nu_max: float) -> torch.Tensor:
    """Radial mean of the 2-D spectrum ``spectrum(R)`` (frequencies -R..R per axis) with radspec's
    binning: ring b holds floor(|q|) = b, DC = 0."""
    nb = radial_bins(m, 2, nu_max)
    R = nb - 1
    P = spectrum(R)
    q = torch.arange(-R, R + 1, dtype=torch.float64)
    idx = torch.floor(torch.sqrt(q[:, None] ** 2 + q[None, :] ** 2) + 1e-9).long().reshape(-1)
    ok = idx <= R
    sums = torch.zeros(nb, dtype=torch.float64).index_add(0, idx[ok], P.reshape(-1)[ok])
    out = sums / torch.bincount(idx[ok], minlength=nb).double()
    out[0] = 0
    return out


def _crop_centred(a: np.ndarray, K: int, what: str) -> torch.Tensor:
    c0, c1 = a.shape[0] // 2, a.shape[1] // 2
    if K > min(c0, c1) - 1:
        raise LossError(f"{what}: K = {K} exceeds the stored resolution {a.shape}")
    out = a[c0 - K : c0 + K + 1, c1 - K : c1 + K + 1].copy()
    out[K, K] = 0.0
    return torch.from_numpy(out)


def integrand_spectrum(name: str, K: int) -> torch.Tensor:
    """Mean integrand power spectrum F (paper Sec. 6.3: font, softshadows, envmap), cropped to
    [−K, K]², DC = 0, normalised to sum 1 so that Σ F·spec(X) (Eq. 5) is the integration variance
    relative to white noise (= 1 for uniform random points)."""
    d = data_dir() / "integrand-spectra"
    files = sorted(d.glob(f"{name}_spectrum_*.npy"))
    if not files:
        raise LossError(
            f"no integrand spectrum {name!r}; have {sorted(p.name.split('_spectrum')[0] for p in d.glob('*.npy'))}"
        )
    F = _crop_centred(np.load(files[0]).astype(np.float64), K, files[0].name)
    return F / F.sum()


def eq5_variance(X: torch.Tensor, F: torch.Tensor) -> torch.Tensor:
    """Σ_q F(q)·E[S(q)] (paper Eq. 5) with S = spec(X) averaged over the batch."""
    K = (F.shape[0] - 1) // 2
    return (spec(X, K=K) * F.to(X)).sum()


def step_radial(m: int, k: int = 2, nu_max: float = 4.0, nu0: float = 0.8, height: float = 1.0) -> torch.Tensor:
    """Analytic step profile (Heck et al. 2013): 0 below ν0, `height` above (DC = 0)."""
    nb = radial_bins(m, k, nu_max)
    nu = torch.arange(nb, dtype=torch.float64) / m ** (1.0 / k)
    out = torch.where(nu < nu0, torch.zeros_like(nu), torch.full_like(nu, height))
    out[0] = 0
    return out


def jitter_spectrum(m: int, K: int) -> torch.Tensor:
    """Expected spectrum of jittered sampling on an N×N grid (m = N²), on [−K, K]²:
    E P(q) = 1 − sinc²(q_x/N)·sinc²(q_y/N) (sinc(t) = sin(πt)/(πt)), DC = 0."""
    N = round(math.sqrt(m))
    if N * N != m:
        raise LossError(f"jitter target needs a square m, got {m}")
    q = torch.arange(-K, K + 1, dtype=torch.float64)
    s = torch.sinc(q / N) ** 2
    P = 1 - s[:, None] * s[None, :]
    P[K, K] = 0
    return P


def jitter_radial(m: int, nu_max: float = 4.0) -> torch.Tensor:
    """Radial mean of jitter_spectrum with the binning of radspec (exact, no sampling)."""
    return _radial_mean(lambda R: jitter_spectrum(m, R), m, nu_max)


def load_point_sets(folder: str | Path) -> torch.Tensor:
    """All point sets of a folder (one point per line), [S, m, n] float64, sorted by file name.
    A bare name is looked up under the vendored pcf/ folder."""
    p = Path(folder)
    if not p.is_dir():
        p = data_dir() / "pcf" / str(folder)
    files = sorted(p.glob("*.txt"))
    if not files:
        raise LossError(f"no point-set files in {p}")
    sets = [np.loadtxt(f, ndmin=2) for f in files]
    if len({s.shape for s in sets}) != 1:
        raise LossError(f"point sets in {p} differ in shape")
    return torch.from_numpy(np.stack(sets))


def measured_radial(point_sets, nu_max: float = 4.0) -> torch.Tensor:
    """A radial target measured from point sets [S, m, k] (spectra averaged over the sets)."""
    return radspec(torch.as_tensor(point_sets, dtype=torch.float64), nu_max=nu_max)
