"""Baseline point sets behind one interface, for comparisons with dpc models.

    >>> from dpc import baselines
    >>> baselines.available()                       # names
    >>> sets = baselines.generate("sobol", 1024, dims=2, count=16, seed=0)   # (16, 1024, 2)

Every baseline has ``generate_batch(count, n_points, dims, seed)`` returning float64
``(count, m, n)`` in [0, 1); set c is a pure function of ``seed + c`` (as for dpc models).

Synthetic: ``white`` (uniform random), ``jitter`` (one uniform point per cell of a k^n grid),
``sobol`` and ``halton`` (scrambled, scipy.stats.qmc), ``lhs`` (Latin hypercube), ``poisson-disk``
(scipy's PoissonDisk), ``dart-throwing`` (relaxed, on the torus), ``rank1`` (Korobov rank-1
lattice) and ``fibonacci`` (2-D Fibonacci lattice), both with a uniform random shift
(Cranley-Patterson rotation); ``pmj02`` and ``pmj02bn`` (progressive multi-jittered (0,2)
sequences, 2-D: every prefix of 2^k points is a (0,2)-net).

Reference: ``ref-bnot``, ``ref-jitter``, ``ref-step``, ``ref-staircase``: the point sets
published by the paper's authors (vendored under ``dpc/data/deepsampling/pcf``, BSD-3-Clause,
see the LICENSE and README there); only the (m, n) they exist for, and at most as many sets.

Threshold-mask baselines (void-and-cluster, STBN, white, Bayer) and the pixel limits are
:mod:`dpc.masks.baselines`, reachable here too.
"""

from __future__ import annotations

import functools
import math
import re
import warnings
from dataclasses import dataclass
from importlib import resources
from typing import Callable

import numpy as np

from . import _args
from .errors import InvalidArgumentError, LimitError

# The threshold-mask baselines (void-and-cluster, STBN, white, Bayer) and the pixel limits live
# with the masks (dpc.masks.baselines); they stay reachable here, beside the point sets.
from .masks.baselines import (  # noqa: F401
    DEFAULT_MAX_DESIGN_PIXELS,
    DEFAULT_MAX_PIXELS,
    bayer_mask,
    check_pixels,
    pixel_limit,
    stbn_scalar,
    vector_void_and_cluster,
    void_and_cluster,
    white_mask,
)


def _rng(seed: int) -> np.random.Generator:
    return np.random.default_rng(int(seed))


def _qmc_engine(name: str, dims: int, rng: np.random.Generator, **kw):
    # Imported here: scipy.stats takes a second to import, and most commands never need it.
    from scipy.stats import qmc

    cls = getattr(qmc, name)
    # scipy >= 1.15 takes rng=, older releases seed= (same meaning for a Generator).
    try:
        return cls(dims, rng=rng, **kw)
    except TypeError:
        return cls(dims, seed=rng, **kw)


# ---------------------------------------------------------------- synthetic samplers
def _white(m: int, n: int, rng: np.random.Generator) -> np.ndarray:
    return rng.random((m, n))


def _jitter(m: int, n: int, rng: np.random.Generator) -> np.ndarray:
    k = round(m ** (1.0 / n))
    if k**n != m:
        lo, hi = math.floor(m ** (1.0 / n)), math.ceil(m ** (1.0 / n))
        raise InvalidArgumentError(f"jitter needs m = k^{n} points; nearest: {max(lo, 1) ** n} or {hi**n}")
    cells = np.stack(np.meshgrid(*([np.arange(k)] * n), indexing="ij"), axis=-1).reshape(-1, n)
    return (cells + rng.random((m, n))) / k


def _sobol(m: int, n: int, rng: np.random.Generator) -> np.ndarray:
    eng = _qmc_engine("Sobol", n, rng, scramble=True)
    with warnings.catch_warnings():
        # scipy warns when m is not a power of two (the balance properties then hold only for
        # the leading power-of-two prefix); the first m points are still a valid baseline.
        warnings.simplefilter("ignore", UserWarning)
        return eng.random(m)


def _halton(m: int, n: int, rng: np.random.Generator) -> np.ndarray:
    return _qmc_engine("Halton", n, rng, scramble=True).random(m)


def _lhs(m: int, n: int, rng: np.random.Generator) -> np.ndarray:
    return _qmc_engine("LatinHypercube", n, rng).random(m)


def _poisson_disk(m: int, n: int, rng: np.random.Generator) -> np.ndarray:
    # scipy grows the set outwards from a seed point, so taking its first m points would leave
    # part of the square empty. Instead fill the whole cube at a radius small enough to give
    # at least m points, then drop the surplus (a few percent) at random.
    from .analysis._common import max_packing_distance

    radius = 0.71 * max_packing_distance(m, n)  # ~5% surplus in 2-D, more in 3-D
    for _ in range(60):
        pts = _qmc_engine("PoissonDisk", n, rng, radius=radius).fill_space()
        if len(pts) >= m:
            keep = np.sort(rng.choice(len(pts), size=m, replace=False))
            return pts[keep]
        radius *= 0.97
    raise InvalidArgumentError(f"poisson-disk could not place {m} points in {n}-D")


def _dart_throwing(m: int, n: int, rng: np.random.Generator) -> np.ndarray:
    # Relaxed dart throwing on the torus (McCool and Fiume 1992): a uniform candidate is kept if
    # it is farther than r from every kept point (toroidal distance); r starts at the packing
    # bound d_max and shrinks by 2% whenever a round of m candidates keeps (almost) none. scipy's
    # PoissonDisk is not toroidal, so its sets have close pairs across the cube's faces.
    # Shrinking already when a round keeps fewer than 1% of m (not only none) costs about 0.01
    # in delta_min and saves most of the rounds near saturation.
    from .analysis._common import max_packing_distance

    r = max_packing_distance(m, n)
    kept = np.empty((0, n))
    while len(kept) < m:
        cand = rng.random((m, n))
        d = cand[:, None, :] - kept[None, :, :]
        d -= np.rint(d)
        ok = np.flatnonzero(np.all(np.einsum("cpk,cpk->cp", d, d) >= r * r, axis=1))
        added = []
        for c in ok:  # candidates of one round against each other, in order
            if len(kept) + len(added) == m:
                break
            e = cand[c] - cand[added]
            e -= np.rint(e)
            if np.all(np.einsum("pk,pk->p", e, e) >= r * r):  # none added yet: all of nothing
                added.append(c)
        kept = np.concatenate([kept, cand[added]])
        if len(added) < max(1, m // 100) and len(kept) < m:
            r *= 0.98
    return kept


@functools.lru_cache(maxsize=64)
def korobov_generator(m: int, n: int) -> tuple[int, ...]:
    """Generating vector z = (1, a, a^2, ...) mod m of a Korobov rank-1 lattice, with a chosen
    to minimise the classical figure of merit P_2 (Sloan & Joe 1994):
    P_2(z) = -1 + (1/m) sum_i prod_j (1 + 2 pi^2 B_2({i z_j / m})), B_2(x) = x^2 - x + 1/6.
    Candidates: every a in [2, m/2] coprime to m (at most 1,024, evenly spread)."""
    if m < 4 or n == 1:
        return tuple([1] * n)
    cands = np.array([a for a in range(2, m // 2 + 1) if math.gcd(a, m) == 1], dtype=np.int64)
    if cands.size == 0:
        return tuple([1] * n)
    if cands.size > 1024:
        cands = cands[np.linspace(0, cands.size - 1, 1024).round().astype(int)]
    i = np.arange(m, dtype=np.int64)
    best, best_a = math.inf, 1
    for a in cands:
        z = [pow(int(a), j, m) for j in range(n)]
        prod = np.ones(m)
        for zj in z:
            x = (i * zj % m) / m
            prod *= 1.0 + 2.0 * math.pi**2 * (x * x - x + 1.0 / 6.0)
        p2 = prod.mean() - 1.0
        if p2 < best:
            best, best_a = p2, int(a)
    return tuple(pow(best_a, j, m) for j in range(n))


def _lattice(m: int, z, rng: np.random.Generator) -> np.ndarray:
    i = np.arange(m, dtype=np.int64)[:, None]
    pts = (i * np.asarray(z, dtype=np.int64)[None, :] % m) / m
    pts = pts + rng.random(len(z))  # Cranley-Patterson rotation
    return pts - np.floor(pts)


def _rank1(m: int, n: int, rng: np.random.Generator) -> np.ndarray:
    return _lattice(m, korobov_generator(m, n), rng)


def fibonacci_numbers(limit: int) -> list[int]:
    """Fibonacci numbers 1, 2, 3, 5, 8, ... up to ``limit``."""
    out, a, b = [], 1, 2
    while a <= limit:
        out.append(a)
        a, b = b, a + b
    return out


def nearest_fibonacci(m: int) -> int:
    """The Fibonacci number closest to m (the smaller one on a tie)."""
    fib = fibonacci_numbers(2 * max(int(m), 2))
    return min(fib, key=lambda f: (abs(f - m), f))


def _fibonacci(m: int, n: int, rng: np.random.Generator) -> np.ndarray:
    if n != 2:
        raise InvalidArgumentError(f"the Fibonacci lattice is 2-D, got dims = {n}")
    fib = fibonacci_numbers(2 * max(m, 2))
    if m not in fib or m < 3:
        below = max([f for f in fib if f < m] or [3])
        above = min(f for f in fib if f > m)
        raise InvalidArgumentError(
            f"the Fibonacci lattice needs a Fibonacci number of points >= 3; nearest: {below} or {above}"
        )
    k = fib.index(m)
    return _lattice(m, (1, fib[k - 1]), rng)


# ---------------------------------------------------------------- progressive (0,2) sequences
# Christensen, Kensler and Kilpatrick 2018, "Progressive Multi-Jittered Sample Sequences" (PMJ02
# and its best-candidate variant PMJ02BN), written here from the paper: no maintained Python
# package generates them (scipy.stats.qmc has Sobol', whose 2-D points are a (0,2)-sequence too,
# but not PMJ). Every prefix of 2^k points is a (0,2)-net: each elementary interval of area 2^-k
# (2^a x 2^(k-a) cells) holds one point.


def _free_strata(occ: list, level: int, x0: int, y0: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """The (x, y) strata of size 2^-level in the square [x0, x0 + width) x [y0, y0 + width)
    (in strata) whose elementary intervals of every shape are all unoccupied."""
    xs, ys = np.meshgrid(np.arange(x0, x0 + width), np.arange(y0, y0 + width), indexing="ij")
    xs, ys = xs.ravel(), ys.ravel()
    free = np.ones(xs.shape, bool)
    for a in range(level + 1):
        free &= ~occ[a][xs >> (level - a), ys >> a]
    return xs[free], ys[free]


def _occupancy(points: np.ndarray, level: int) -> list[np.ndarray]:
    """Per shape a = 0 .. level, which elementary intervals (2^a x 2^(level-a) cells) hold a point."""
    occ = [np.zeros((1 << a, 1 << (level - a)), bool) for a in range(level + 1)]
    for p in points:
        _mark(occ, level, p)
    return occ


def _mark(occ: list, level: int, point: np.ndarray) -> None:
    c = np.floor(point * (1 << level)).astype(np.int64)
    for a in range(level + 1):
        occ[a][c[0] >> (level - a), c[1] >> a] = True


def _pmj02_steps(points: np.ndarray, m: int):
    """PMJ02's doublings (Christensen et al. 2018, Sec. 5) up to m points, for a caller that fills
    points[n .. 2n) at each: yields (n, odd, level, width, squares, occupancy). From n = 4^k points
    (one per cell of a 2^k grid; odd False) the squares are the subquadrants diagonally opposite
    the first n points; from n = 2 x 4^k (odd True), the two remaining subquadrants of each cell
    (those of cell i at i and 4^k + i). A point placed in its square's free strata (:func:`_free_strata`, then
    :func:`_mark`) keeps every elementary interval of the new power of two free."""
    n = 1
    while n < m:
        g = 1 << ((n.bit_length() - 1) // 2)  # the first g^2 points, one per cell of the g x g grid
        level = (2 * n).bit_length() - 1
        width = (1 << level) // (2 * g)  # a subquadrant's width in strata
        q = np.floor(points[: g * g] * 2 * g).astype(np.int64)
        odd = n != g * g
        if not odd:
            squares = np.stack([(q[:, 0] ^ 1) * width, (q[:, 1] ^ 1) * width], 1)
        else:
            squares = np.concatenate(
                [
                    np.stack([(q[:, 0] ^ 1) * width, q[:, 1] * width], 1),
                    np.stack([q[:, 0] * width, (q[:, 1] ^ 1) * width], 1),
                ]
            )
        yield n, odd, level, width, squares, _occupancy(points[:n], level)
        n *= 2


def pmj02(m: int, rng: np.random.Generator, candidates: int = 1) -> np.ndarray:
    """m points of a progressive multi-jittered (0,2) sequence (Christensen et al. 2018, Sec. 5):
    from 4^k points (one per cell of a 2^k grid) the next 4^k go to the subquadrants diagonally
    opposite the first ones, the 2 x 4^k after that to the two remaining subquadrants, each point
    inside the strata that keep every elementary interval of the new power of two free.
    candidates > 1 is PMJ02BN (their Sec. 6): of that many random valid positions, the one
    farthest from all earlier points (toroidal distance)."""
    pts = np.empty((m, 2))
    pts[0] = rng.random(2)

    def place(i: int, square: np.ndarray, width: int, level: int, occ: list) -> bool:
        xs, ys = _free_strata(occ, level, int(square[0]), int(square[1]), width)
        if len(xs) == 0:
            return False
        pick = rng.integers(0, len(xs), candidates)
        cand = (np.stack([xs[pick], ys[pick]], 1) + rng.random((candidates, 2))) / (1 << level)
        best = 0
        if candidates > 1:
            d = cand[:, None, :] - pts[None, :i, :]
            d -= np.round(d)
            best = int(np.argmax((d * d).sum(-1).min(1)))
        pts[i] = cand[best]
        _mark(occ, level, pts[i])
        return True

    def fail() -> None:  # never seen; a (0,2) extension in this order always exists in practice
        raise RuntimeError("pmj02: no valid position for a point; try another seed")

    for n, odd, level, width, squares, occ in _pmj02_steps(pts, m):
        if not odd:  # the diagonally opposite subquadrants
            for i in range(min(n, m - n)):
                if not place(n + i, squares[i], width, level, occ):
                    fail()
            continue
        half = n // 2  # g^2: the points whose cells get their last two subquadrants
        first = rng.integers(0, 2, half)  # which of the two each cell fills first
        for i in range(min(half, m - n)):
            if not place(n + i, squares[first[i] * half + i], width, level, occ):
                first[i] ^= 1
                if not place(n + i, squares[first[i] * half + i], width, level, occ):
                    fail()
        for i in range(min(half, m - n - half)):
            if not place(n + half + i, squares[(1 - first[i]) * half + i], width, level, occ):
                fail()
    return pts[:m]


def is_02_net(points) -> bool:
    """Whether m = 2^k points form a (0,2)-net in base 2: one point in every elementary interval
    of area 1/m, for every shape 2^a x 2^(k-a)."""
    return net_occupancy(points) == 1.0


def net_occupancy(points) -> float:
    """How close m = 2^k points come to a (0,2)-net: the fraction of the m elementary intervals of
    each shape 2^a x 2^(k-a) that hold a point, averaged over the k + 1 shapes (1 exactly for a
    net; about 1 - 1/e = 0.63 for white noise)."""
    p = np.asarray(points, dtype=np.float64)
    m = len(p)
    if m < 1 or m & (m - 1):
        raise InvalidArgumentError(f"elementary intervals of base 2 need a power-of-two number of points, got {m}")
    k = m.bit_length() - 1
    fractions = []
    for a in range(k + 1):
        cells = (np.floor(p[:, 0] * (1 << a)).astype(np.int64) << (k - a)) + np.floor(p[:, 1] * (1 << (k - a))).astype(
            np.int64
        )
        fractions.append(len(np.unique(cells)) / m)
    return float(np.mean(fractions))


def _pmj(candidates: int):
    def make(m: int, n: int, rng: np.random.Generator) -> np.ndarray:
        if n != 2:
            raise InvalidArgumentError(f"PMJ02 sequences are 2-D, got dims = {n}")
        return pmj02(m, rng, candidates)

    return make


@dataclass(frozen=True)
class Baseline:
    """A synthetic sampler: ``make(m, n, rng) -> (m, n)``."""

    name: str
    description: str
    make: Callable[[int, int, np.random.Generator], np.ndarray]

    def generate(self, n_points: int, dims: int = 2, seed: int = 0) -> np.ndarray:
        """One set (m, n) from ``seed``."""
        return self.generate_batch(1, n_points, dims, seed)[0]

    def generate_batch(
        self, count: int, n_points: int | None, dims: int | None = 2, seed: int = 0, max_bytes: float | None = None
    ) -> np.ndarray:
        """``count`` sets (count, m, n); set c from seed ``seed + c``. ``max_bytes``: the
        largest output (as for dpc models: default 4 GiB or $DPC_MAX_OUTPUT_BYTES); a larger
        request raises LimitError before anything is allocated."""
        if n_points is None:
            raise InvalidArgumentError(f"{self.name} needs a number of points")
        m = _args.size(n_points, "the number of points", 1)
        n = _args.size(2 if dims is None else dims, "dims", 1)
        c = _args.size(count, "count", 1)
        s = _args.numpy_seed(seed)
        check_output_size(c, m, n, max_bytes)
        out = np.empty((c, m, n))
        for i in range(c):
            out[i] = self.make(m, n, _rng(s + i))
        # Guard the unit torus: shifted lattices and rounding can land exactly on 1.0.
        out[out >= 1.0] = 0.0
        return out


def check_output_size(count: int, n_points: int, dims: int, max_bytes: float | None = None) -> None:
    """LimitError when ``count`` float64 sets of ``n_points`` ``dims``-D points exceed the byte
    limit of one call (``max_bytes``, else $DPC_MAX_OUTPUT_BYTES, else 4 GiB, as for models)."""
    from ._model import _max_bytes

    limit = _max_bytes(max_bytes)
    size = count * n_points * dims * 8
    if size > limit:
        raise LimitError(
            f"the output would take {count * n_points * dims:,} floats ({size / 2**30:.3g} GiB), more than the "
            f"limit of {limit / 2**30:.3g} GiB: pass max_bytes (CLI: --max-output, environment: "
            "DPC_MAX_OUTPUT_BYTES) to raise it"
        )


# ---------------------------------------------------------------- the authors' point sets
_REF_DIR = re.compile(r"^(?:test-)?pcf-([a-z]+)-d(\d+)-n(\d+)$")


def _ref_root():
    return resources.files("dpc") / "data" / "deepsampling" / "pcf"


@functools.lru_cache(maxsize=1)
def _reference_index() -> dict[tuple[str, int, int], tuple[str, ...]]:
    """(pattern, dims, m) -> sorted file names relative to the pcf folder."""
    index: dict[tuple[str, int, int], list[str]] = {}
    root = _ref_root()
    if not root.is_dir():
        return {}
    for folder in sorted(root.iterdir(), key=lambda p: p.name):
        match = _REF_DIR.match(folder.name)
        if not match or not folder.is_dir():
            continue
        key = (match[1], int(match[2]), int(match[3]))
        files = sorted(f.name for f in folder.iterdir() if f.name.endswith(".txt"))
        index.setdefault(key, []).extend(f"{folder.name}/{f}" for f in files)
    return {k: tuple(v) for k, v in index.items()}


@functools.lru_cache(maxsize=32)
def reference_sets(pattern: str, n_points: int, dims: int = 2) -> np.ndarray:
    """All of the authors' sets of ``pattern`` (bnot, jitter, step, staircase) with m points in
    n dims: float64 (sets, m, n). Read-only array (cached)."""
    key = (pattern, int(dims), int(n_points))
    files = _reference_index().get(key)
    if not files:
        have = ", ".join(f"{p} d={d} m={m}" for p, d, m in sorted(_reference_index()))
        raise InvalidArgumentError(f"no reference sets for {pattern} with dims={dims}, m={n_points}; available: {have}")
    root = _ref_root()
    sets = []
    for name in files:
        pts = np.loadtxt(str(root / name), ndmin=2)
        if pts.shape != (key[2], key[1]):
            raise InvalidArgumentError(f"reference file {name} has shape {pts.shape}")
        sets.append(pts)
    arr = np.stack(sets)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class ReferenceBaseline:
    """The authors' published sets of one pattern."""

    name: str
    pattern: str
    description: str

    def available(self) -> list[tuple[int, int, int]]:
        """(m, dims, number of sets) for which sets exist."""
        return sorted((m, d, len(f)) for (p, d, m), f in _reference_index().items() if p == self.pattern)

    def generate(self, n_points: int | None = None, dims: int | None = None, seed: int = 0) -> np.ndarray:
        return self.generate_batch(1, n_points, dims, seed)[0]

    def generate_batch(
        self, count: int, n_points: int | None = None, dims: int | None = None, seed: int = 0
    ) -> np.ndarray:
        """``count`` distinct published sets, set c being number (seed + c) mod sets.
        ``n_points``/``dims`` may be omitted where only one collection fits."""
        s = _args.numpy_seed(seed)
        fits = [
            (m, d, k)
            for m, d, k in self.available()
            if (n_points is None or m == int(n_points)) and (dims is None or d == int(dims))
        ]
        if len(fits) > 1 and dims is None:  # unspecified dims: 2-D, like the other baselines
            fits = [f for f in fits if f[1] == 2] or fits
        if len(fits) != 1:
            have = ", ".join(f"m={m} dims={d} ({k} sets)" for m, d, k in self.available())
            want = "ambiguous" if fits else "not available"
            raise InvalidArgumentError(f"{self.name}: m={n_points}, dims={dims} is {want}; published: {have}")
        m, d, k = fits[0]
        if not 1 <= int(count) <= k:
            raise InvalidArgumentError(f"{self.name} has {k} sets of m={m}, dims={d}; asked for {count}")
        sets = reference_sets(self.pattern, m, d)
        idx = [(s + c) % k for c in range(int(count))]
        return np.array(sets[idx])


_SYNTHETIC = [
    Baseline("white", "uniform random points (white noise)", _white),
    Baseline("jitter", "jittered grid: one uniform point per cell of a k^n grid (m = k^n)", _jitter),
    Baseline("sobol", "Owen-scrambled Sobol' (scipy.stats.qmc.Sobol)", _sobol),
    Baseline("halton", "scrambled Halton (scipy.stats.qmc.Halton)", _halton),
    Baseline("lhs", "Latin hypercube (scipy.stats.qmc.LatinHypercube)", _lhs),
    Baseline("poisson-disk", "maximal Poisson disk (scipy.stats.qmc.PoissonDisk), trimmed to m", _poisson_disk),
    Baseline("dart-throwing", "relaxed dart throwing on the torus (McCool and Fiume 1992), any n", _dart_throwing),
    Baseline("rank1", "Korobov rank-1 lattice (P_2-optimal generator), random shift", _rank1),
    Baseline("fibonacci", "2-D Fibonacci lattice z = (1, F_(k-1)), m = F_k, random shift", _fibonacci),
    Baseline("pmj02", "progressive multi-jittered (0,2) sequence (Christensen et al. 2018), 2-D", _pmj(1)),
    Baseline("pmj02bn", "PMJ02 with best-candidate blue noise (of 10 valid positions), 2-D", _pmj(10)),
]
_REFERENCE = [
    ReferenceBaseline("ref-bnot", "bnot", "the authors' BNOT sets (De Goes et al. 2012)"),
    ReferenceBaseline("ref-jitter", "jitter", "the authors' jittered sets"),
    ReferenceBaseline("ref-step", "step", "the authors' step blue-noise sets (Heck et al. 2013)"),
    ReferenceBaseline("ref-staircase", "staircase", "the authors' staircase sets (Kailkhura 2016)"),
]
BASELINES: dict[str, Baseline | ReferenceBaseline] = {b.name: b for b in _SYNTHETIC + _REFERENCE}


def available() -> list[str]:
    """Names of all baselines."""
    return list(BASELINES)


def get(name: str) -> Baseline | ReferenceBaseline:
    """The baseline called ``name``."""
    try:
        return BASELINES[name]
    except KeyError:
        raise InvalidArgumentError(f"unknown baseline {name!r}; available: {', '.join(BASELINES)}") from None


def generate(name: str, n_points: int | None, dims: int | None = 2, count: int = 1, seed: int = 0) -> np.ndarray:
    """``count`` sets of baseline ``name``: float64 (count, m, n)."""
    return get(name).generate_batch(count, n_points, dims, seed)
