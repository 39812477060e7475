"""Power spectra of point sets on the unit torus (docs/architecture.md, "Analysis conventions"; paper Sec. 4.3 and 4.5).

Conventions: P(q) = |sum_k exp(2 pi i <q, x_k>)|^2 / m at integer frequencies q (white noise = 1),
DC (q = 0) removed, averaged over the realisations (sets) given. Normalised frequency
nu = |q| / m^(1/n), n being the dimension of the (sub)space analysed.

Only integer q matter on the unit torus, so the 2-D spectrum is exact on the integer grid. It is a
separable DFT: exp(2 pi i (a x + b y)) = exp(2 pi i a x) exp(2 pi i b y), so the whole grid is one
matrix product of an (m x Q) phase table per axis (BLAS does the O(m Q^2) work; only O(m Q)
trigonometric calls are made). Grids too large for that are sampled at every s-th integer
frequency ("stride"), still exact at the frequencies computed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import _args
from ..errors import InvalidArgumentError, LimitError
from ._common import as_sets, check_dims, map_sets

_TWO_PI = 2.0 * math.pi
# Work arrays are cut into chunks of about this many elements to bound memory.
_CHUNK_ELEMS = 1 << 22
# Above this many multiply-adds per set, single precision: ~10x faster trigonometry, twice the
# BLAS speed, and still ~1e-5 relative in |F| (phases are reduced to [0, 1) in float64 first).
_SINGLE_ABOVE = 1 << 20


@dataclass
class Spectrum2D:
    """Mean power spectrum of a 2-D (sub)space on the integer grid.

    ``power[i, j]`` is P at q = (freqs[i], freqs[j]); the DC entry (centre) is 0."""

    power: np.ndarray
    freqs: np.ndarray
    stride: int
    n_points: int
    n_sets: int
    dims: tuple[int, int]

    @property
    def nu_extent(self) -> float:
        """Largest normalised frequency on each axis."""
        return float(self.freqs[-1]) / math.sqrt(self.n_points)

    def low_frequency_energy(self, nu_max: float) -> float:
        """Mean P over the grid frequencies with 0 < |q| / sqrt(m) < nu_max."""
        nu = np.hypot(self.freqs[:, None], self.freqs[None, :]) / math.sqrt(self.n_points)
        sel = (nu > 0) & (nu < nu_max)
        if not np.any(sel):
            raise InvalidArgumentError(f"no grid frequencies below nu = {nu_max}")
        return float(self.power[sel].mean())

    def radial(self, nu_max: float | None = None) -> RadialSpectrum:
        """Radial mean and anisotropy, rings of width ``stride`` (see :func:`radial_profile`)."""
        return radial_profile(self, nu_max=nu_max)


@dataclass
class Spectrum1D:
    """Mean power spectrum of a 1-D projection at the integer frequencies ``freqs`` (> 0)."""

    power: np.ndarray
    freqs: np.ndarray
    stride: int
    n_points: int
    n_sets: int
    dim: int

    @property
    def nu(self) -> np.ndarray:
        return self.freqs / float(self.n_points)


@dataclass
class RadialSpectrum:
    """Radially averaged spectrum: ring (or sampled radius) centres and statistics.

    ``mean``: radial mean of P; ``anisotropy_db``: 10 log10(variance / mean^2) of P over the
    ring, for the realisation-averaged P; ``weights``: how much of frequency space a ring
    stands for (grid: its number of frequencies; Monte Carlo: the ring's shell volume).
    ``points``: the (sub)space's point sets, kept by the Monte Carlo spectrum so that
    :meth:`low_frequency_energy` is exact there."""

    nu: np.ndarray
    radius: np.ndarray
    mean: np.ndarray
    anisotropy_db: np.ndarray
    samples: np.ndarray
    weights: np.ndarray
    n_points: int
    n_sets: int
    dims: int
    method: str
    points: np.ndarray | None = field(default=None, repr=False, compare=False)

    def low_frequency_energy(self, nu_max: float) -> float:
        """E_low: mean power over the frequencies with 0 < nu < nu_max. Monte Carlo spectra
        (n >= 3) evaluate it exactly at every integer frequency of that ball
        (:func:`low_frequency_energy`): a ring average would count the whole ring that straddles
        nu_max, where the power of a blue-noise spectrum rises steeply. Grid rings: weighted by
        their frequency counts (exact when nu_max * sqrt(m) is an integer)."""
        if self.method == "monte-carlo" and self.points is not None:
            return low_frequency_energy(self.points, nu_max)
        sel = (self.nu < nu_max) & (self.samples > 0)
        if not np.any(sel):
            raise InvalidArgumentError(f"no frequencies below nu = {nu_max}")
        return float(np.sum(self.mean[sel] * self.weights[sel]) / np.sum(self.weights[sel]))

    def peak(self, nu_max: float | None = None) -> tuple[float, float]:
        """(largest radial mean, its nu) over nu <= nu_max."""
        sel = self.samples > 0
        if nu_max is not None:
            sel &= self.nu <= nu_max + 1e-12
        i = np.flatnonzero(sel)[np.argmax(self.mean[sel])]
        return float(self.mean[i]), float(self.nu[i])


def _auto_dtype(dtype, work: float):
    if dtype is None:
        return np.float32 if work > _SINGLE_ABOVE else np.float64
    dt = np.dtype(dtype)
    if dt not in (np.float32, np.float64):
        raise InvalidArgumentError(f"dtype must be float32 or float64, got {dtype}")
    return dt.type


def _phases(x: np.ndarray, q: np.ndarray, cos_out: np.ndarray, sin_out: np.ndarray) -> None:
    """cos/sin(2 pi q x) for every (point, frequency) into the given (m, Q) views (q >= 0).

    The phase q x must be reduced modulo 1 before single precision trigonometry. float64 does
    it with floor; float32 output uses 32-bit fixed point instead: with X = round(x 2^32),
    X q mod 2^32 is exactly what uint32 multiplication wraps to, in one pass of 4-byte values
    (x is quantised to 2^-32, far below the float32 resolution of the points)."""
    if cos_out.dtype == np.float32:
        fixed = np.mod(np.rint(x * 4294967296.0), 4294967296.0).astype(np.uint32)
        ph = np.multiply.outer(fixed, q.astype(np.uint32)).astype(np.float32)
        ph *= np.float32(_TWO_PI / 4294967296.0)
    else:
        ph = np.multiply.outer(x, q.astype(np.float64))
        np.subtract(ph, np.floor(ph), out=ph)
        ph *= _TWO_PI
    np.cos(ph, out=cos_out)
    np.sin(ph, out=sin_out)


def _dft2_quadrants(xy: np.ndarray, q: np.ndarray, dtype) -> tuple[np.ndarray, np.ndarray]:
    """|F(a, b)|^2 and |F(a, -b)|^2 for a, b in q (q >= 0), F = sum_k exp(2 pi i (a x + b y)).

    With C = cos, S = sin tables per axis, [Cx Sx]^T [Cy Sy] holds A = Cx'Cy, D = Cx'Sy,
    C = Sx'Cy, B = Sx'Sy; then F(a, b) = (A - B) + i (C + D) and F(a, -b) = (A + B) + i (C - D)."""
    k1 = q.size
    acc = np.zeros((2 * k1, 2 * k1), dtype=dtype)
    chunk = max(1, _CHUNK_ELEMS // (2 * k1))
    for start in range(0, xy.shape[0], chunk):
        part = xy[start : start + chunk]
        left = np.empty((part.shape[0], 2 * k1), dtype=dtype)
        right = np.empty_like(left)
        _phases(part[:, 0], q, left[:, :k1], left[:, k1:])
        _phases(part[:, 1], q, right[:, :k1], right[:, k1:])
        acc += left.T @ right
    a, d = acc[:k1, :k1], acc[:k1, k1:]
    c, b = acc[k1:, :k1], acc[k1:, k1:]
    pp = (a - b) ** 2 + (c + d) ** 2
    pm = (a + b) ** 2 + (c - d) ** 2
    return pp.astype(np.float64), pm.astype(np.float64)


def grid_stride(n_points: int, nu_max: float, max_size: int, dims: int = 2) -> int:
    """Frequency stride so that a grid reaching nu_max has at most ``max_size`` entries per axis."""
    half = (int(max_size) - 1) // 2 - 1
    if half < 1:
        raise InvalidArgumentError(f"max_size must be at least 5, got {max_size}")
    reach = nu_max * n_points ** (1.0 / dims)
    return max(1, math.ceil(reach / half))


def power_spectrum_2d(
    points,
    *,
    dims=(0, 1),
    nu_max: float = 4.0,
    max_size: int = 513,
    stride: int | None = None,
    dtype=None,
    progress_bar: bool = False,
) -> Spectrum2D:
    """Exact mean power spectrum of the 2-D (sub)space ``dims`` on the integer frequency grid
    |q_x|, |q_y| <= nu_max sqrt(m) (plus one ring), sampled every ``stride`` integers; by
    default the smallest stride keeping the grid within ``max_size`` x ``max_size``."""
    sets = as_sets(points)
    s_count, m, n = sets.shape
    d = check_dims(dims, n, 2)
    nu_max = _args.positive_real(nu_max, "nu_max")
    if stride is None:
        stride = grid_stride(m, nu_max, max_size)
    else:
        stride = _args.integer(stride, "stride", 1, whole_floats=True)
    # +1: the last complete ring (radius k - 1 strides) must reach nu_max.
    k = math.ceil(nu_max * math.sqrt(m) / stride) + 1
    q = stride * np.arange(k + 1)
    dt = _auto_dtype(dtype, float(m) * (k + 1) ** 2)
    pp = np.zeros((k + 1, k + 1))
    pm = np.zeros((k + 1, k + 1))
    for a, b in map_sets(
        lambda s: _dft2_quadrants(sets[s][:, d], q, dt), s_count, progress_bar=progress_bar, desc="2-D spectrum"
    ):
        pp += a
        pm += b
    pp /= m * s_count
    pm /= m * s_count
    full = np.empty((2 * k + 1, 2 * k + 1))
    full[k:, k:] = pp
    full[k::-1, k::-1] = pp
    full[k:, k::-1] = pm
    full[k::-1, k:] = pm
    full[k, k] = 0.0  # DC removed
    freqs = stride * np.arange(-k, k + 1)
    return Spectrum2D(power=full, freqs=freqs, stride=stride, n_points=m, n_sets=s_count, dims=d)


def radial_profile(spec: Spectrum2D, nu_max: float | None = None) -> RadialSpectrum:
    """Radial mean and anisotropy of a grid spectrum. Ring b holds the grid frequencies with
    b <= |q| / stride < b + 1 and is reported at |q| = b stride, as in the authors' radial target
    files; only complete rings. The ring-weighted mean below nu0 is then exactly the grid mean
    over 0 < |q| < nu0 sqrt(m) whenever nu0 sqrt(m) / stride is an integer."""
    k = (spec.freqs.size - 1) // 2
    j = np.arange(-k, k + 1)
    ring = np.floor(np.hypot(j[:, None], j[None, :])).astype(np.int64).ravel()
    p = spec.power.ravel()
    keep = (ring >= 1) & (ring <= k - 1)
    ring, p = ring[keep], p[keep]
    counts = np.bincount(ring, minlength=k)[1:k]
    s1 = np.bincount(ring, weights=p, minlength=k)[1:k]
    s2 = np.bincount(ring, weights=p * p, minlength=k)[1:k]
    mean = s1 / counts
    var = np.maximum(s2 / counts - mean**2, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        anis = 10.0 * np.log10(var / mean**2)
    radius = spec.stride * np.arange(1, k, dtype=np.float64)
    nu = radius / math.sqrt(spec.n_points)
    if nu_max is not None:
        sel = nu <= nu_max + 1e-12
        nu, radius, mean, anis, counts = nu[sel], radius[sel], mean[sel], anis[sel], counts[sel]
    return RadialSpectrum(
        nu=nu,
        radius=radius,
        mean=mean,
        anisotropy_db=anis,
        samples=counts,
        weights=counts.astype(np.float64),
        n_points=spec.n_points,
        n_sets=spec.n_sets,
        dims=2,
        method="grid",
    )


def _progression_power(xs: np.ndarray, q0: int, step: int, count: int, dtype, progress_bar: bool) -> np.ndarray:
    """sum over sets of |sum_k exp(2 pi i q x_k)|^2 at q = q0 + step i, i = 0..count-1.

    Separable again: with i = B t + j, z^q = z^(q0 + step B t) z^(step j), so all the sums are
    one matrix product of a (m x T) and a (m x B) phase table: O(m sqrt(count)) trigonometry,
    the O(m count) multiply-adds done by BLAS."""
    s_count, m = xs.shape
    b = math.isqrt(count) + 1
    t = -(-count // b)
    cdt = np.complex64 if dtype == np.float32 else np.complex128
    q_in = step * np.arange(b)
    q_out = q0 + step * b * np.arange(t)
    chunk = max(1, _CHUNK_ELEMS // (b + t))

    def one_set(s: int) -> np.ndarray:
        acc = np.zeros((t, b), dtype=cdt)
        for start in range(0, m, chunk):
            part = xs[s, start : start + chunk]
            u = np.empty((part.size, t), cdt)
            v = np.empty((part.size, b), cdt)
            _phases(part, q_out, u.real, u.imag)  # exp(2 pi i q x) written in place
            _phases(part, q_in, v.real, v.imag)
            acc += u.T @ v
        return np.abs(acc.ravel()[:count]).astype(np.float64) ** 2

    total = np.zeros(count)
    for p in map_sets(one_set, s_count, progress_bar=progress_bar, desc="1-D spectrum"):
        total += p
    return total


def power_spectrum_1d(
    points,
    *,
    dim: int = 0,
    nu_max: float = 4.0,
    max_freqs: int = 4096,
    stride: int | None = None,
    dtype=None,
    progress_bar: bool = False,
) -> Spectrum1D:
    """Mean power spectrum of the projection of the points on axis ``dim``, at integer q up to
    nu_max m (nu = q / m for a 1-D set of m points).

    Where that is more than ``max_freqs`` frequencies, the first max_freqs/2 are every integer
    (the low band, where stratification shows) and the rest are spread evenly to nu_max with
    stride ``Spectrum1D.stride``. An explicit ``stride`` samples q = stride, 2 stride, ..."""
    sets = as_sets(points)
    s_count, m, n = sets.shape
    (dim,) = check_dims((dim,), n, 1)
    nu_max = _args.positive_real(nu_max, "nu_max")
    max_freqs = _args.integer(max_freqs, "max_freqs", 2, whole_floats=True)
    reach = math.ceil(nu_max * m)
    if stride is not None:
        stride = _args.integer(stride, "stride", 1, whole_floats=True)
        parts = [(stride, stride, -(-reach // stride))]
    elif reach <= int(max_freqs):
        parts = [(1, 1, reach)]
    else:
        low = int(max_freqs) // 2
        step = -(-(reach - low) // (int(max_freqs) - low))
        parts = [(1, 1, low), (low + step, step, -(-(reach - low) // step))]
    xs = np.ascontiguousarray(sets[:, :, dim])
    dt = _auto_dtype(dtype, float(m) * sum(c for _, _, c in parts))
    power = np.concatenate([_progression_power(xs, q0, st, c, dt, progress_bar) for q0, st, c in parts]) / (m * s_count)
    freqs = np.concatenate([q0 + st * np.arange(c) for q0, st, c in parts])
    return Spectrum1D(power=power, freqs=freqs, stride=parts[-1][1], n_points=m, n_sets=s_count, dim=dim)


def power_spectrum_direct(points, q, *, dtype=np.float64) -> np.ndarray:
    """Reference O(m |q|) evaluation: mean over sets of |sum_k exp(2 pi i <q, x_k>)|^2 / m at the
    integer frequencies ``q`` (shape (count, n), or (count,) for n = 1). No DC removal.
    ``dtype=float32`` does the trigonometry in single precision (phases still reduced in
    float64): ~10x faster, ~1e-6 relative error per term."""
    sets = as_sets(points)
    s_count, m, n = sets.shape
    qa = np.asarray(q)
    if qa.ndim == 1 and n == 1:
        qa = qa[:, None]
    if qa.ndim != 2 or qa.shape[1] != n:
        raise InvalidArgumentError(f"q must have shape (count, {n}), got {np.shape(q)}")
    if qa.dtype.kind not in "iu":
        if qa.dtype.kind != "f" or not np.all(qa == np.rint(qa)):
            raise InvalidArgumentError("frequencies q must be integers")
    dt = _auto_dtype(dtype, 0.0)
    qf = qa.astype(np.float64)
    out = np.zeros(qf.shape[0])
    chunk = max(1, _CHUNK_ELEMS // m)
    for s in range(s_count):
        for start in range(0, qf.shape[0], chunk):
            ph = sets[s] @ qf[start : start + chunk].T  # (m, chunk) phases in cycles
            ph -= np.floor(ph)
            ph = ph.astype(dt, copy=False)
            ph *= _TWO_PI
            re = np.cos(ph).sum(axis=0, dtype=np.float64)
            im = np.sin(ph).sum(axis=0, dtype=np.float64)
            out[start : start + chunk] += re * re + im * im
    return out / (m * s_count)


def radial_spectrum_mc(
    points, *, dims=None, nu_max: float = 4.0, directions: int = 128, seed: int = 0, progress_bar: bool = False
) -> RadialSpectrum:
    """n-D radial mean spectrum by Monte Carlo (paper Sec. 4.5). Ring b (b <= |q| < b + 1, as on
    the grid) gets ``directions`` samples q = round(rho u): u a uniform random unit vector
    (normalised Gaussian), rho uniform in [b, b + 1), snapped to the integer grid, P(q)
    evaluated exactly. Samples that snap to q = 0 are dropped. The same frequencies serve every
    set, so P is realisation-averaged before the ring statistics."""
    sets = as_sets(points)
    s_count, m, n = sets.shape
    d = tuple(range(n)) if dims is None else check_dims(dims, n, len(tuple(dims)))
    sub = np.ascontiguousarray(sets[:, :, d])
    nd = len(d)
    directions = _args.integer(directions, "directions", 1, whole_floats=True)
    nu_max = _args.positive_real(nu_max, "nu_max")
    h = m ** (1.0 / nd)
    ring = np.arange(1, math.floor(nu_max * h + 1e-9) + 1, dtype=np.float64)
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((ring.size, int(directions), nd))
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    rho = ring[:, None] + rng.random((ring.size, int(directions)))
    q = np.rint(rho[:, :, None] * u).astype(np.int64)
    nonzero = np.any(q != 0, axis=-1)
    flat = q.reshape(-1, nd)
    p = np.zeros(flat.shape[0])
    # Single precision trigonometry: the estimate is Monte Carlo anyway (see the docstring).
    for ps in map_sets(
        lambda s: power_spectrum_direct(sub[s], flat, dtype=np.float32),
        s_count,
        progress_bar=progress_bar,
        desc="radial spectrum (MC)",
    ):
        p += ps
    p = (p / s_count).reshape(ring.size, int(directions))
    cnt = nonzero.sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = np.where(nonzero, p, 0.0).sum(axis=1) / cnt
        var = np.where(nonzero, (p - mean[:, None]) ** 2, 0.0).sum(axis=1) / cnt
        anis = 10.0 * np.log10(var / mean**2)
    shell = (ring + 1.0) ** nd - ring**nd  # frequency-space volume of each ring
    return RadialSpectrum(
        nu=ring / h,
        radius=ring,
        mean=mean,
        anisotropy_db=anis,
        samples=cnt,
        weights=shell,
        n_points=m,
        n_sets=s_count,
        dims=nd,
        method="monte-carlo",
        points=sub,
    )


# Work bound of the exact E_low: frequencies x points x sets (about 10 s of trigonometry).
_ELOW_WORK = 4e9


def frequencies_below(n_points: int, dims: int, nu_max: float) -> np.ndarray:
    """The integer frequencies q of a ``dims``-D torus with 0 < |q| / n_points^(1/dims) < nu_max,
    one of each pair q, -q (the first nonzero coordinate positive; both have the same power):
    shape (count, dims), ordered lexicographically. LimitError where the ball is too large to
    list (more than 5e7 candidates)."""
    nu_max = _args.positive_real(nu_max, "nu_max")
    # |q|^2 < r2, strictly: a frequency exactly at nu_max (|q|^2 = 8 for nu 0.5 at m = 1,024 in
    # 4-D) is outside whatever the rounding of m^(1/n) does
    r2 = (nu_max * n_points ** (1.0 / dims)) ** 2 * (1.0 - 1e-12)
    k = int(math.floor(math.sqrt(r2)))
    if (2 * k + 1) ** dims > 5e7:
        raise LimitError(f"the frequencies below nu = {nu_max} in {dims}-D at m = {n_points} are too many to list")
    axis = np.arange(-k, k + 1)
    q = np.stack(np.meshgrid(*([axis] * dims), indexing="ij"), axis=-1).reshape(-1, dims)
    norm2 = np.sum(q * q, axis=1)
    first = q[np.arange(len(q)), np.argmax(q != 0, axis=1)]  # the first nonzero coordinate
    return q[(norm2 > 0) & (norm2 < r2) & (first > 0)]


def low_frequency_energy(points, nu_max: float, *, dims=None) -> float:
    """E_low(nu_max) by its definition (docs/analysis.md): the mean of P = |sum_k e^{2 pi i <q, x_k>}|^2 / m,
    averaged over sets, over every integer frequency q != 0 of the (sub)space ``dims`` with
    |q| / m^(1/n) < nu_max (:func:`frequencies_below`), each evaluated exactly
    (:func:`power_spectrum_direct`). InvalidArgumentError where no integer frequency lies below
    nu_max; LimitError where the ball holds too many (frequencies x points x sets > 4e9): use the
    2-D grid spectrum or a smaller nu_max there."""
    sets = as_sets(points)
    s_count, m, n = sets.shape
    d = tuple(range(n)) if dims is None else check_dims(dims, n, len(tuple(dims)))
    q = frequencies_below(m, len(d), nu_max)
    if len(q) == 0:
        raise InvalidArgumentError(f"no integer frequencies below nu = {nu_max} (m = {m}, {len(d)}-D)")
    if float(len(q)) * m * s_count > _ELOW_WORK:
        raise LimitError(
            f"E_low below nu = {nu_max} needs {len(q):,} frequencies x {m:,} points x {s_count} sets: "
            "more than the exact evaluation's bound"
        )
    sub = np.ascontiguousarray(sets[:, :, d])
    return float(np.mean(power_spectrum_direct(sub, q)))


def radial_spectrum(
    points,
    *,
    dims=None,
    nu_max: float = 4.0,
    max_size: int = 513,
    directions: int = 128,
    seed: int = 0,
    progress_bar: bool = False,
) -> RadialSpectrum:
    """Radial mean spectrum of the (sub)space ``dims`` (default: all axes): exact grid for 2-D,
    Monte Carlo (:func:`radial_spectrum_mc`) for 3-D and up, the plain spectrum for 1-D."""
    sets = as_sets(points)
    n = sets.shape[2]
    d = tuple(range(n)) if dims is None else check_dims(dims, n, len(tuple(dims)))
    if len(d) == 2:
        return power_spectrum_2d(sets, dims=d, nu_max=nu_max, max_size=max_size, progress_bar=progress_bar).radial(
            nu_max
        )
    if len(d) == 1:
        sp = power_spectrum_1d(sets, dim=d[0], nu_max=nu_max, progress_bar=progress_bar)
        ones = np.ones_like(sp.power)
        return RadialSpectrum(
            nu=sp.nu,
            radius=sp.freqs.astype(np.float64),
            mean=sp.power,
            anisotropy_db=np.full_like(sp.power, np.nan),
            samples=ones * 2,
            weights=ones,
            n_points=sp.n_points,
            n_sets=sp.n_sets,
            dims=1,
            method="1-d",
        )
    return radial_spectrum_mc(sets, dims=d, nu_max=nu_max, directions=directions, seed=seed, progress_bar=progress_bar)
