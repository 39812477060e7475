"""Monte Carlo integration study (paper Sec. 6.2, Fig. 12): relative variance of the estimate
(1/m) sum_k f(x_k) over realisations, for seeded random families of integrands with known
integrals over [0, 1]^n, for several samplers and point counts.

Families (parameters drawn from ``numpy.random.default_rng(seed)``):

* ``gaussian``: f(x) = exp(-|x - mu|^2 / (2 sigma^2)), mu ~ U[0.3, 0.7]^n, sigma ~ U[0.05, 0.25];
  integral = prod_k sigma sqrt(pi/2) [erf((1 - mu_k) / (sigma sqrt 2))
  + erf(mu_k / (sigma sqrt 2))].
* ``heaviside``: f(x) = 1[<w, x - c> > 0], w a uniform random unit vector, c ~ U[0.25, 0.75]^n
  (a half-plane in 2-D); integral = 1 - volume of {x in [0,1]^n : <w, x> <= <w, c>}, exact
  from the alternating vertex sum (1 / (n! prod w_k)) sum_v (-1)^|v| max(0, t - <w, v>)^n.
* ``disk``: f(x) = 1[|x - c| < r], c ~ U[0.3, 0.7]^n, r ~ U[0.1, 0.3] (always inside the cube);
  integral = volume of the n-ball of radius r.

Relative variance, as in the paper: the variance of the estimates over realisations divided by
their squared mean, averaged over the integrands of a family.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .. import _args
from ..errors import InvalidArgumentError
from ._common import check_dims, progress

FAMILIES = ("gaussian", "heaviside", "disk")
# math.erf over the few parameters here; scipy.special costs half a second to import.
erf = np.vectorize(math.erf, otypes=[np.float64])


@dataclass
class IntegrandFamily:
    """``count`` integrands of one family in ``dims`` dimensions."""

    name: str
    dims: int
    params: dict

    @property
    def count(self) -> int:
        return len(next(iter(self.params.values())))

    def evaluate(self, x: np.ndarray, index: int) -> np.ndarray:
        """f_index at points x (..., dims)."""
        p = {k: v[index] for k, v in self.params.items()}
        if self.name == "gaussian":
            d2 = np.sum((x - p["mu"]) ** 2, axis=-1)
            return np.exp(-d2 / (2.0 * p["sigma"] ** 2))
        if self.name == "heaviside":
            return (np.tensordot(x - p["c"], p["w"], axes=([-1], [0])) > 0.0).astype(np.float64)
        d2 = np.sum((x - p["c"]) ** 2, axis=-1)
        return (d2 < p["r"] ** 2).astype(np.float64)

    def exact(self) -> np.ndarray:
        """The integrals over [0, 1]^dims, one per integrand."""
        n = self.dims
        if self.name == "gaussian":
            mu, sig = self.params["mu"], self.params["sigma"][:, None]
            s2 = sig * math.sqrt(2.0)
            return np.prod(sig * math.sqrt(math.pi / 2.0) * (erf((1 - mu) / s2) + erf(mu / s2)), axis=1)
        if self.name == "heaviside":
            return np.array(
                [1.0 - _halfspace_volume(w, float(w @ c)) for w, c in zip(self.params["w"], self.params["c"])]
            )
        r = self.params["r"]
        return math.pi ** (n / 2.0) / math.gamma(n / 2.0 + 1.0) * r**n


def _halfspace_volume(w: np.ndarray, t: float) -> float:
    """Volume of {x in [0,1]^n : <w, x> <= t}. Negative w_k are reflected (x_k -> 1 - x_k),
    zero ones do not constrain; then the alternating sum over the cube's vertices is exact."""
    w = np.asarray(w, dtype=np.float64)
    t = t - float(w[w < 0].sum())
    a = np.abs(w[np.abs(w) > 1e-9])
    n = a.size
    if n == 0:
        return 1.0 if t >= 0 else 0.0
    total = 0.0
    for v in itertools.product((0, 1), repeat=n):
        r = t - float(np.dot(a, v))
        if r > 0:
            total += (-1) ** sum(v) * r**n
    return float(min(max(total / (math.factorial(n) * float(np.prod(a))), 0.0), 1.0))


def integrands(family: str, count: int = 10, *, dims: int = 2, seed: int = 0) -> IntegrandFamily:
    """A seeded family of ``count`` random integrands (see the module notes)."""
    if family not in FAMILIES:
        raise InvalidArgumentError(f"unknown integrand family {family!r}; choose from {FAMILIES}")
    c = _args.integer(count, "count", 1, whole_floats=True)
    n = _args.integer(dims, "dims", 1, whole_floats=True)
    rng = np.random.default_rng(seed)
    if family == "gaussian":
        params = {"mu": rng.uniform(0.3, 0.7, (c, n)), "sigma": rng.uniform(0.05, 0.25, c)}
    elif family == "heaviside":
        w = rng.standard_normal((c, n))
        w /= np.linalg.norm(w, axis=1, keepdims=True)
        params = {"w": w, "c": rng.uniform(0.25, 0.75, (c, n))}
    else:
        params = {"c": rng.uniform(0.3, 0.7, (c, n)), "r": rng.uniform(0.1, 0.3, c)}
    return IntegrandFamily(name=family, dims=n, params=params)


def estimates(sets: np.ndarray, family: IntegrandFamily) -> np.ndarray:
    """MC estimates (1/m) sum_k f(x_k): array (integrands, realisations)."""
    x = np.asarray(sets, dtype=np.float64)
    if x.ndim != 3 or x.shape[2] != family.dims:
        raise InvalidArgumentError(f"sets must have shape (realisations, m, {family.dims}), got {x.shape}")
    return np.stack([family.evaluate(x, i).mean(axis=1) for i in range(family.count)])


def relative_variance(sets: np.ndarray, family: IntegrandFamily) -> np.ndarray:
    """Per integrand: variance of the estimates over the sets / their squared mean."""
    if np.shape(sets)[0] < 2:
        raise InvalidArgumentError("relative variance needs at least 2 realisations")
    e = estimates(sets, family)
    return e.var(axis=1, ddof=1) / e.mean(axis=1) ** 2


# A sampler: (count, n_points, seed) -> array (count, m', n); m' may differ from n_points
# (a Fibonacci lattice only exists for Fibonacci numbers), and is recorded.
Sampler = Callable[[int, int, int], np.ndarray]


@dataclass
class IntegrationStudy:
    """Relative variance per family, sampler and point count (mean over the integrands).
    ``rel_var[family][sampler][i]`` belongs to ``points[sampler][i]`` actual points."""

    families: tuple[str, ...]
    point_counts: tuple[int, ...]
    points: dict[str, list[int]] = field(default_factory=dict)
    rel_var: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    integrands: int = 10
    realisations: int = 64
    dims: tuple[int, ...] = (0, 1)
    seed: int = 0

    def to_json(self) -> dict:
        return {
            "families": list(self.families),
            "point_counts": list(self.point_counts),
            "points": self.points,
            "relative_variance": self.rel_var,
            "integrands": self.integrands,
            "realisations": self.realisations,
            "dims": list(self.dims),
            "seed": self.seed,
        }


def integration_study(
    samplers: Mapping[str, Sampler],
    point_counts: Sequence[int],
    *,
    families: Sequence[str] = FAMILIES,
    integrands_per_family: int = 10,
    realisations: int = 64,
    dims: Sequence[int] = (0, 1),
    seed: int = 0,
    progress_bar: bool = False,
) -> IntegrationStudy:
    """Relative variance of every sampler at every point count on every family. Each sampler is
    called once per point count for ``realisations`` sets (seeded with ``seed``); the integrands
    live in the subspace ``dims`` of the samples (default the first two axes)."""
    counts = tuple(_args.integer(c, "a point count", 1, whole_floats=True) for c in point_counts)
    if not counts:
        raise InvalidArgumentError("point_counts must hold at least one point count")
    realisations = _args.integer(realisations, "realisations", 2, whole_floats=True)
    fams = {
        f: integrands(f, integrands_per_family, dims=len(tuple(dims)), seed=seed + i) for i, f in enumerate(families)
    }
    study = IntegrationStudy(
        families=tuple(families),
        point_counts=counts,
        integrands=int(integrands_per_family),
        realisations=int(realisations),
        dims=tuple(int(d) for d in dims),
        seed=int(seed),
    )
    for f in families:
        study.rel_var[f] = {name: [] for name in samplers}
    jobs = [(name, c) for name in samplers for c in counts]
    for name, c in progress(jobs, enabled=progress_bar, desc="integration study"):
        sets = np.asarray(samplers[name](int(realisations), c, int(seed)), dtype=np.float64)
        if sets.ndim != 3 or sets.shape[0] != int(realisations):
            raise InvalidArgumentError(f"sampler {name!r} returned shape {sets.shape}, expected ({realisations}, m, n)")
        d = check_dims(dims, sets.shape[2], len(tuple(dims)))
        sub = sets[:, :, d]
        study.points.setdefault(name, []).append(int(sets.shape[1]))
        for f in families:
            study.rel_var[f][name].append(float(relative_variance(sub, fams[f]).mean()))
    return study
