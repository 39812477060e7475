"""Shared helpers: input validation, the maximal packing distance, progress bars."""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager

import numpy as np
from tqdm import tqdm

from .. import _args
from ..errors import InvalidArgumentError

# Best known centre densities delta_n of sphere packings in n dimensions (Conway & Sloane,
# "Sphere Packings, Lattices and Groups", Table 1.2): optimal for n <= 8 (n = 2: hexagonal,
# 3: fcc, 8: E8), best known for n = 9 (Lambda_9) and n = 10 (P_10c).
_CENTRE_DENSITY = {
    1: 0.5,
    2: 1.0 / (2.0 * math.sqrt(3.0)),
    3: 1.0 / (4.0 * math.sqrt(2.0)),
    4: 1.0 / 8.0,
    5: 1.0 / (8.0 * math.sqrt(2.0)),
    6: 1.0 / (8.0 * math.sqrt(3.0)),
    7: 1.0 / 16.0,
    8: 1.0 / 16.0,
    9: 1.0 / (16.0 * math.sqrt(2.0)),
    10: 5.0 / 128.0,
}
MAX_PACKING_DIMS = max(_CENTRE_DENSITY)


def count_of(k: int, noun: str = "set") -> str:
    """'1 set', '16 sets': a count with its noun, singular or plural."""
    return f"{k} {noun}" if k == 1 else f"{k} {noun}s"


def max_packing_distance(n_points: int, dims: int) -> float:
    """Largest possible minimum distance of ``n_points`` points in the unit torus [0,1)^dims,
    from the densest known sphere packing: m balls of radius d/2 cover the packing density,
    so d_max = 2 (delta_n / m)^(1/n) with delta_n the centre density.
    2-D: d_max = sqrt(2 / (sqrt(3) m)) (hexagonal packing)."""
    m, n = int(n_points), int(dims)
    if m < 1:
        raise InvalidArgumentError(f"n_points must be positive, got {n_points}")
    if n not in _CENTRE_DENSITY:
        raise InvalidArgumentError(
            f"maximal packing distance is tabulated for 1..{MAX_PACKING_DIMS} dimensions, got {n}"
        )
    return 2.0 * (_CENTRE_DENSITY[n] / m) ** (1.0 / n)


def as_sets(points, *, min_points: int = 1) -> np.ndarray:
    """Validate point sets and return them as a float64 array (sets, m, n) on the unit torus.

    Accepts (m,) [1-D points], (m, n) or (sets, m, n). Values must be finite and in [0, 1];
    1.0 is the same torus point as 0.0 and is wrapped."""
    a = _args.point_array(points)
    if a.shape[0] < 1 or a.shape[1] < min_points or a.shape[2] < 1:
        raise InvalidArgumentError(
            f"need at least 1 set of {min_points} point(s) with 1 dimension, got shape {a.shape}"
        )
    a = np.asarray(a, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise InvalidArgumentError("points contain NaN or infinite values")
    lo, hi = float(a.min()), float(a.max())
    if lo < 0.0 or hi > 1.0:
        raise InvalidArgumentError(f"points must lie in the unit cube [0, 1]; values range over [{lo:g}, {hi:g}]")
    if hi == 1.0:  # periodic domain: 1.0 is 0.0 (cKDTree's boxsize also needs [0, 1))
        a = np.where(a == 1.0, 0.0, a)
    return np.ascontiguousarray(a)


def check_dims(dims, n: int, count: int) -> tuple[int, ...]:
    """Validate a tuple of ``count`` distinct axis indices into n dimensions."""
    try:
        d = tuple(int(k) for k in dims)
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"dims must be a sequence of integers, got {dims!r}") from None
    if len(d) != count or len(set(d)) != count or any(k < 0 or k >= n for k in d):
        raise InvalidArgumentError(f"dims must be {count} distinct axes in 0..{n - 1}, got {dims!r}")
    return d


def progress(iterable, *, enabled: bool, desc: str, total: int | None = None):
    """A tqdm bar on stderr that only appears when the loop runs longer than a second."""
    return tqdm(iterable, desc=desc, total=total, disable=not enabled, delay=1.0, leave=False, dynamic_ncols=True)


def cpu_count() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


@contextmanager
def _single_threaded_blas():
    """BLAS limited to one thread, if threadpoolctl is installed (yields whether it is)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        yield False
        return
    with threadpool_limits(limits=1, user_api="blas"):
        yield True


def map_sets(fn, count: int, *, progress_bar: bool, desc: str):
    """Yield fn(0), ..., fn(count - 1) in order.

    The per-set work is numpy/BLAS code that releases the GIL, so the sets run on one thread
    per CPU with single-threaded BLAS. Multi-threaded BLAS on small products spends its time
    synchronising, and collapses when another process holds a core; one set per thread keeps
    every core busy either way. Without threadpoolctl: sequential, BLAS threads as configured."""
    with _single_threaded_blas() as limited:
        workers = min(cpu_count(), count) if limited else 1
        if workers <= 1:
            yield from progress(map(fn, range(count)), enabled=progress_bar, desc=desc, total=count)
            return
        with ThreadPoolExecutor(max_workers=workers) as pool:
            yield from progress(pool.map(fn, range(count)), enabled=progress_bar, desc=desc, total=count)
