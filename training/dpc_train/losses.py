"""The loss language (paper Sec. 4; docs/training.md §3): differentiable point-correlation operators.

Conventions (docs/training.md): X is a batch [B, m, n] of point sets on the unit torus.
Power spectrum P(q) = |Σ_k exp(2πi⟨q, x_k⟩)|² / m at integer q (white noise = 1), DC set to 0,
averaged over the B realisations (paper Sec. 5.3: spectra are always averaged before the loss).
Normalised frequency ν = |q| / m^(1/n). Radial means bin integer frequencies by floor(|q|)
(the convention of the authors' target files, checked against their BNOT point sets).
"""

from __future__ import annotations

import itertools
import math

import torch

from .cascade import AXES

TWO_PI = 2.0 * math.pi


class LossError(ValueError):
    """A loss expression that cannot be evaluated (bad arguments, mismatched shapes)."""


def _batch(X: torch.Tensor) -> torch.Tensor:
    if X.dim() == 2:
        return X[None]
    if X.dim() != 3:
        raise LossError(f"point sets must be [m, n] or [B, m, n], got {tuple(X.shape)}")
    return X


def prefix(X: torch.Tensor, n: int) -> torch.Tensor:
    """The first n points of each set: prefix(X, 256) → [B, 256, dims]. For progressive
    patterns, whose every prefix of a level size is a point set of its own (training.md §3)."""
    X = _batch(X)
    if not 1 <= int(n) <= X.shape[1]:
        raise LossError(f"prefix length must be in 1..{X.shape[1]}, got {n}")
    return X[:, : int(n)]


# ----------------------------------------------------------------------------------------
# Swizzles
# ----------------------------------------------------------------------------------------


def swizzle(X: torch.Tensor, axes: str) -> torch.Tensor:
    """Keep the named dimensions, e.g. swizzle(X, "xz") → [B, m, 2]."""
    X = _batch(X)
    idx = []
    for c in axes:
        if c not in AXES or AXES.index(c) >= X.shape[-1]:
            raise LossError(f"axis {c!r} not available in {X.shape[-1]}-D points")
        idx.append(AXES.index(c))
    return X[..., idx]


def swizzle_functions(n_letters: int = 4) -> dict:
    """{'x': fn, 'xy': fn, 'zx': fn, ...} for all distinct-letter swizzles of the first axes."""
    out = {}
    letters = AXES[:n_letters]
    for k in range(1, n_letters + 1):
        for combo in itertools.permutations(letters, k):
            name = "".join(combo)
            out[name] = lambda X, _n=name: swizzle(X, _n)
    return out


# ----------------------------------------------------------------------------------------
# Spectra
# ----------------------------------------------------------------------------------------


def power_at(X: torch.Tensor, freqs: torch.Tensor, chunk: int = 4096) -> torch.Tensor:
    """Mean (over the batch) power |Σ_k e^{2πi⟨q,x_k⟩}|²/m at integer frequencies freqs [Q, k]."""
    X = _batch(X)
    m = X.shape[1]
    out = []
    f = freqs.to(X)
    for a in range(0, f.shape[0], chunk):
        ph = TWO_PI * torch.einsum("bmk,qk->bmq", X, f[a : a + chunk])
        re, im = torch.cos(ph).sum(1), torch.sin(ph).sum(1)
        out.append(((re * re + im * im) / m).mean(0))
    return torch.cat(out)


def spec(X: torch.Tensor, K: int | None = None) -> torch.Tensor:
    """Full power spectrum on the integer grid [−K, K]^k, DC = 0, averaged over the batch.

    For k ≤ 2 it is exact and separable: the 2-D sum Σ_k e^{2πi(q x_k + p y_k)} is the matrix
    product of per-axis factor matrices [Q, m]·[m, Q]. Default K = 2·m^(1/k) (ν up to 2).
    Result is indexed [q + K] (k = 1) or [q + K, p + K] (k = 2), ... for higher k.
    """
    X = _batch(X)
    B, m, k = X.shape
    if K is None:
        K = int(math.ceil(2 * m ** (1.0 / k)))
    q = torch.arange(-K, K + 1, dtype=X.dtype, device=X.device)
    if k == 1:
        ph = TWO_PI * X[..., 0:1] * q  # [B, m, Q]
        re, im = torch.cos(ph).sum(1), torch.sin(ph).sum(1)
        P = ((re * re + im * im) / m).mean(0)
        P = torch.cat([P[:K], P.new_zeros(1), P[K + 1 :]])  # DC removed
        return P
    if k == 2:
        ax = TWO_PI * X[..., 0:1] * q  # [B, m, Q]
        ay = TWO_PI * X[..., 1:2] * q
        cx, sx, cy, sy = torch.cos(ax), torch.sin(ax), torch.cos(ay), torch.sin(ay)
        cxt, sxt = cx.transpose(1, 2), sx.transpose(1, 2)
        re = cxt @ cy - sxt @ sy  # Σ cos(α+β)
        im = sxt @ cy + cxt @ sy  # Σ sin(α+β)
        P = ((re * re + im * im) / m).mean(0)
        dc = torch.zeros_like(P)
        dc[K, K] = 1.0
        return P * (1 - dc)
    n_freq = (2 * K + 1) ** k
    if n_freq > 4_000_000:
        raise LossError(
            f"spec of {k}-D points on a (2K+1)^k = {n_freq} grid is too large; use radspec (Monte Carlo) or a smaller K"
        )
    grid = torch.cartesian_prod(*([q] * k)).reshape(-1, k)
    P = power_at(X, grid)
    P = torch.where((grid == 0).all(-1), torch.zeros_like(P), P)
    return P.reshape(*([2 * K + 1] * k))


def radial_bins(m: int, k: int, nu_max: float) -> int:
    """Number of radial bins R + 1 (integer radii 0..R) for ν up to nu_max."""
    return int(math.ceil(nu_max * m ** (1.0 / k))) + 1


def radspec(
    X: torch.Tensor, nu_max: float = 4.0, directions: int = 64, generator: torch.Generator | None = None
) -> torch.Tensor:
    """Radially averaged power spectrum: entry ρ = mean of P(q) over floor(|q|) = ρ (ρ = 0 → 0).

    k ≤ 2: exact grid quadrature over all integer q with |q| < R + 1. k ≥ 3: Monte Carlo
    (paper Sec. 4.5): per radius, `directions` random unit vectors scaled by ρ + ½ and snapped to
    the integer grid. Length R + 1 with R = ceil(nu_max · m^(1/k)).
    """
    X = _batch(X)
    B, m, k = X.shape
    nb = radial_bins(m, k, nu_max)
    R = nb - 1
    if k <= 2:
        P = spec(X, K=R)
        q = torch.arange(-R, R + 1, dtype=torch.float64, device=X.device)
        rr = q.abs() if k == 1 else torch.sqrt(q[:, None] ** 2 + q[None, :] ** 2)
        idx = torch.floor(rr + 1e-9).long().reshape(-1)
        ok = idx <= R
        idx, vals = idx[ok], P.reshape(-1)[ok]
        sums = torch.zeros(nb, dtype=P.dtype, device=P.device).index_add(0, idx, vals)
        cnt = torch.bincount(idx, minlength=nb).to(P.dtype)
        out = sums / cnt.clamp(min=1)
        return torch.cat([out.new_zeros(1), out[1:]])
    g = torch.randn(nb, directions, k, generator=generator, dtype=torch.float64)
    g = g / g.norm(dim=-1, keepdim=True)
    rad = torch.arange(nb, dtype=torch.float64)[:, None, None] + 0.5
    freqs = torch.round(g * rad).reshape(-1, k)
    P = power_at(X, freqs.to(X.device)).reshape(nb, directions)
    P = torch.where((freqs == 0).all(-1).reshape(nb, directions).to(P.device), torch.zeros_like(P), P)
    out = P.mean(1)
    return torch.cat([out.new_zeros(1), out[1:]])


# ----------------------------------------------------------------------------------------
# Differential domain
# ----------------------------------------------------------------------------------------


def _pair_offsets(X: torch.Tensor, max_dist: float | None):
    """Toroidal offsets x_j ⊖ x_i [P, k] over all pairs i ≠ j of every set (or those with
    |offset| < max_dist, found without grad), plus the batch size and m."""
    from .filter import find_pairs

    X = _batch(X)
    B, m, k = X.shape
    r = 0.5 * math.sqrt(k) + 1e-6 if max_dist is None else float(max_dist)
    ii, jj = find_pairs(X.detach(), list(range(k)), min(r, 0.5 * math.sqrt(k) + 1e-6), 0.0)
    flat = X.reshape(B * m, k)
    d = flat[jj] - flat[ii]
    return d - torch.floor(d + 0.5), B, m


def ddom(X: torch.Tensor, nc: int = 64, max_dist: float | None = None) -> torch.Tensor:
    """Differential-domain histogram of offsets on an nc^k grid of [−½, ½)^k (k ≤ 2), soft-binned
    with a Gaussian of std 2/nc (paper Sec. 4.4), normalised so uniform random points give ≈ 1.

    Separable in 2-D: H = Σ_pairs N(q_a − dx) N(q_b − dy) is a matrix product. Cost O(pairs · nc);
    pass max_dist to restrict to near pairs (bins farther out then read ≈ 0).
    """
    d, B, m = _pair_offsets(X, max_dist)
    k = d.shape[1]
    if k > 2:
        raise LossError("ddom is implemented for 1-D and 2-D (sub)spaces; use raddom for more")
    sigma = 2.0 / nc
    centres = (torch.arange(nc, dtype=d.dtype, device=d.device) + 0.5) / nc - 0.5

    def factor(col):
        diff = centres[None, :] - col[:, None]
        diff = diff - torch.floor(diff + 0.5)  # periodic Gaussian on the torus
        return torch.exp(-0.5 * (diff / sigma) ** 2) / (math.sqrt(TWO_PI) * sigma)

    norm = B * m * (m - 1)
    if k == 1:
        return factor(d[:, 0]).sum(0) / norm
    return factor(d[:, 0]).T @ factor(d[:, 1]) / norm


def raddom(
    X: torch.Tensor,
    r_max: float = 2.5,
    nbins: int = 50,
    sigma: float = 0.05,
) -> torch.Tensor:
    """Pair correlation function g(r) at nbins radii in (0, r_max] (in mean spacings m^(−1/k)),
    soft-binned with a Gaussian of std sigma (spacings); uniform random points give g ≈ 1.

    g(r) = Σ_{i≠j} N_σ(r − d_ij) / (B · m(m−1) · S_k r^(k−1)), S_k = surface of the unit sphere.
    """
    X = _batch(X)
    B, m, k = X.shape
    h = m ** (-1.0 / k)
    d, _, _ = _pair_offsets(X, (r_max + 8 * sigma) * h)  # tails < e^-32
    dist = torch.sqrt((d * d).sum(-1) + 1e-30) / h
    r = torch.arange(1, nbins + 1, dtype=X.dtype, device=X.device) * (r_max / nbins)
    w = torch.exp(-0.5 * ((r[None, :] - dist[:, None]) / sigma) ** 2) / (math.sqrt(TWO_PI) * sigma)
    surf = 2 * math.pi ** (k / 2) / math.gamma(k / 2)
    # pairs per unit (spacing) radius for uniform points: m(m−1)·S_k·(r h)^(k−1)·h
    expect = m * (m - 1) * surf * (r * h) ** (k - 1) * h
    return w.sum(0) / (B * expect)


def pcf_radii(r_max: float = 2.5, nbins: int = 50) -> torch.Tensor:
    """The radii (in spacings) at which raddom evaluates g."""
    return torch.arange(1, nbins + 1, dtype=torch.float64) * (r_max / nbins)


# ----------------------------------------------------------------------------------------
# Metrics
# ----------------------------------------------------------------------------------------


def _match(a, b=None):
    if b is None:
        return a
    if a.shape != b.shape:
        raise LossError(
            f"shape mismatch {tuple(a.shape)} vs {tuple(b.shape)}: build the target "
            f"with the same nu_max / K / bins as the operator"
        )
    return a - b.to(a)


def l1(a: torch.Tensor, b: torch.Tensor | None = None, weight=None) -> torch.Tensor:
    """Mean absolute value of a (or of a − b), optionally weighted per entry."""
    d = _match(a, b).abs()
    return (d * weight.to(d)).sum() / weight.sum().to(d) if weight is not None else d.mean()


def l2(a: torch.Tensor, b: torch.Tensor | None = None, weight=None) -> torch.Tensor:
    """Mean squared value of a (or of a − b), optionally weighted per entry."""
    d = _match(a, b) ** 2
    return (d * weight.to(d)).sum() / weight.sum().to(d) if weight is not None else d.mean()


def rel_l1(a: torch.Tensor, b: torch.Tensor, floor: float = 0.01) -> torch.Tensor:
    """Mean |a − b| / (b + floor): weights the near-zero low band of a blue-noise target."""
    return ((a - b.to(a)).abs() / (b.to(a).abs() + floor)).mean()


def log_l1(a: torch.Tensor, b: torch.Tensor, eps: float = 1e-3) -> torch.Tensor:
    """Mean |log(a + eps) − log(b + eps)|: error measured in decades."""
    return (torch.log(a.clamp(min=0) + eps) - torch.log(b.to(a).clamp(min=0) + eps)).abs().mean()


def lowband_weight(m: int, k: int, nu_max: float = 4.0, nu_low: float = 0.75, factor: float = 10.0) -> torch.Tensor:
    """Per-radial-bin weight: `factor` below nu_low, 1 above (DC bin 0)."""
    nb = radial_bins(m, k, nu_max)
    nu = torch.arange(nb, dtype=torch.float64) / m ** (1.0 / k)
    w = torch.where(nu < nu_low, torch.full_like(nu, factor), torch.ones_like(nu))
    w[0] = 0
    return w


def lowband_energy(X: torch.Tensor, nu_low: float) -> torch.Tensor:
    """E_low (docs/architecture.md, "A quick study"): mean power over all integer q with 0 < ν < nu_low (area-weighted,
    k ≤ 2), spectra averaged over the batch. The authors' 20 BNOT sets at m = 256 give 0.0024
    (ν < 0.5) and 0.026 (ν < 0.75)."""
    X = _batch(X)
    m, k = X.shape[1], X.shape[2]
    if k > 2:
        raise LossError("lowband_energy is defined for 1-D and 2-D (sub)spaces")
    K = int(math.ceil(nu_low * m ** (1.0 / k)))
    P = spec(X, K=K)
    q = torch.arange(-K, K + 1, dtype=torch.float64, device=X.device)
    rr = q.abs() if k == 1 else torch.sqrt(q[:, None] ** 2 + q[None, :] ** 2)
    nu = rr / m ** (1.0 / k)
    return P[(nu > 0) & (nu < nu_low)].mean()
