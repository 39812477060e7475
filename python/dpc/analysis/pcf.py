"""Spatial statistics on the unit torus: pair correlation function and minimum distance.

Distances are toroidal (minimum image), found with ``scipy.spatial.cKDTree(boxsize=1)``. Radii
are also given in units of the maximal packing distance d_max (2-D: sqrt(2 / (sqrt(3) m))).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .. import _args
from ..errors import InvalidArgumentError
from ._common import as_sets, map_sets, max_packing_distance


def _ball_volume(n: int) -> float:
    return math.pi ** (n / 2.0) / math.gamma(n / 2.0 + 1.0)


@dataclass
class PCF:
    """Pair correlation g(r) on bins [edges[i], edges[i+1]); ``r`` are the bin centres,
    ``r_norm`` = r / d_max. g = 1 for white noise."""

    r: np.ndarray
    r_norm: np.ndarray
    g: np.ndarray
    edges: np.ndarray
    pairs: np.ndarray
    d_max: float
    n_points: int
    n_sets: int
    dims: int


def _close_pairs(x: np.ndarray, radius: float) -> np.ndarray:
    """Toroidal distances of the unordered pairs i < j closer than ``radius``."""
    tree = cKDTree(x, boxsize=1.0)
    ij = tree.query_pairs(radius, output_type="ndarray")
    d = x[ij[:, 0]] - x[ij[:, 1]]
    d -= np.rint(d)  # minimum image on the unit torus
    return np.sqrt(np.einsum("ij,ij->i", d, d))


def pcf(points, *, r_max: float = 2.5, bins: int = 100, progress_bar: bool = False) -> PCF:
    """Pair correlation function, averaged over sets.

    g(r) = (ordered pairs i != j with toroidal distance in the bin) / (sets m (m - 1) V_bin),
    V_bin the volume of the spherical shell: its expectation is exactly 1 for uniform random
    points while r < 1/2. ``r_max`` is in units of d_max; the shells must stay below 1/2."""
    return pair_statistics(points, r_max=r_max, bins=bins, progress_bar=progress_bar)[0]


def pair_statistics(
    points, *, r_max: float = 2.5, bins: int = 100, progress_bar: bool = False
) -> tuple[PCF, MinDistance]:
    """:func:`pcf` and :func:`min_distance` from one neighbour search per set (the nearest pair
    is almost always closer than r_max d_max; where not, a k-NN query finds it)."""
    sets = as_sets(points, min_points=2)
    s_count, m, n = sets.shape
    bins = _args.integer(bins, "bins", 1, whole_floats=True)
    d_max = max_packing_distance(m, n)
    top = float(r_max) * d_max
    if not 0.0 < top <= 0.5:
        raise InvalidArgumentError(f"r_max = {r_max} d_max = {top:.4g} must lie in (0, 0.5] on the unit torus")
    edges = np.linspace(0.0, top, int(bins) + 1)

    def one_set(s: int):
        dist = _close_pairs(sets[s], top)
        closest = float(dist.min()) if dist.size else _nearest(sets[s])
        return np.histogram(dist, bins=edges)[0], closest

    pairs = np.zeros(int(bins))
    closest = np.empty(s_count)
    for s, (hist, c) in enumerate(map_sets(one_set, s_count, progress_bar=progress_bar, desc="PCF")):
        pairs += 2.0 * hist
        closest[s] = c
    shells = _ball_volume(n) * (edges[1:] ** n - edges[:-1] ** n)
    g = pairs / (s_count * m * (m - 1.0) * shells)
    r = 0.5 * (edges[1:] + edges[:-1])
    return (
        PCF(r=r, r_norm=r / d_max, g=g, edges=edges, pairs=pairs, d_max=d_max, n_points=m, n_sets=s_count, dims=n),
        MinDistance(distances=closest, d_max=d_max),
    )


def _nearest(x: np.ndarray) -> float:
    dist, _ = cKDTree(x, boxsize=1.0).query(x, k=2)
    return float(dist[:, 1].min())


@dataclass
class MinDistance:
    """Per-set minimum toroidal distance and its ratio delta_min = min distance / d_max."""

    distances: np.ndarray
    d_max: float

    @property
    def ratios(self) -> np.ndarray:
        return self.distances / self.d_max

    @property
    def mean_ratio(self) -> float:
        return float(self.ratios.mean())

    @property
    def min_ratio(self) -> float:
        return float(self.ratios.min())


def min_distance(points, *, progress_bar: bool = False) -> MinDistance:
    """Smallest toroidal distance between two points of each set, and d_max for (m, n)."""
    sets = as_sets(points, min_points=2)
    s_count, m, n = sets.shape
    d_max = max_packing_distance(m, n)
    out = np.fromiter(
        map_sets(lambda s: _nearest(sets[s]), s_count, progress_bar=progress_bar, desc="min distance"),
        dtype=np.float64,
        count=s_count,
    )
    return MinDistance(distances=out, d_max=d_max)


def min_distance_ratio(points) -> float:
    """delta_min = (minimum toroidal distance) / d_max, averaged over sets."""
    return min_distance(points).mean_ratio
