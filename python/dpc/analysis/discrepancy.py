"""L2-type discrepancies of point sets in the unit cube [0, 1]^n (not periodic).

``CD`` (centred), ``WD`` (wrap-around), ``MD`` (mixture) and ``L2-star`` come from
``scipy.stats.qmc.discrepancy``. Two closed forms scipy lacks are written here:

* ``GL2``, the generalised (Hickernell's "modified") L2 discrepancy, as UTK's
  ``GeneralizedL2Discrepancy``: the sum of the squared L2-star discrepancies of every projection,
  GL2^2 = (4/3)^n - (2/m) sum_i prod_k (3 - x_ik^2)/2 + (1/m^2) sum_ij prod_k (2 - max(x_ik, x_jk));
* ``UL2``, the unanchored (L2-extreme, Morokoff & Caflisch 1994) discrepancy over all boxes
  [a, b): UL2^2 = 12^-n - (2^(1-n)/m) sum_i prod_k x_ik (1 - x_ik)
  + (1/m^2) sum_ij prod_k min(x_ik, x_jk) (1 - max(x_ik, x_jk)).

Every value returned is the discrepancy D itself (not D^2): scipy returns D^2 for CD, WD and MD,
so their square root is taken. All methods cost O(m^2 n) per set.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidArgumentError
from ._common import as_sets, map_sets

SCIPY_METHODS = ("CD", "WD", "MD", "L2-star")
CLOSED_FORMS = ("GL2", "UL2")
METHODS = SCIPY_METHODS + CLOSED_FORMS
_SQUARED_IN_SCIPY = {"CD", "WD", "MD"}
_BLOCK_ELEMS = 1 << 16


def _pair_sum(x: np.ndarray, kind: str) -> float:
    """sum over all ordered pairs (i, j) of prod_k h(x_ik, x_jk), h = 2 - max (GL2) or
    min (1 - max) (UL2). h is symmetric, so only j >= the row block is formed: pairs inside
    the diagonal block appear in both orders, the rest count twice. Row blocks and reused
    buffers keep the work in cache and free of allocations."""
    m, n = x.shape
    block = max(1, _BLOCK_ELEMS // m)
    total = 0.0
    prod, hi, tmp = (np.empty(block * m) for _ in range(3))
    for start in range(0, m, block):
        rows = x[start : start + block]
        r, width = rows.shape[0], m - start
        p = prod[: r * width].reshape(r, width)
        big = hi[: r * width].reshape(r, width)
        h = tmp[: r * width].reshape(r, width)
        for k in range(n):
            a, b = rows[:, k : k + 1], x[None, start:, k]
            np.maximum(a, b, out=big)
            if kind == "GL2":
                np.subtract(2.0, big, out=h)
            else:  # min = a + b - max
                np.add(a, b, out=h)
                h -= big
                np.subtract(1.0, big, out=big)
                h *= big
            if k == 0:
                p[...] = h
            else:
                p *= h
        total += float(p[:, :r].sum()) + 2.0 * float(p[:, r:].sum())
    return total


def generalized_l2(points: np.ndarray) -> float:
    """Generalised (modified) L2 discrepancy of one set (m, n); see the module notes."""
    x = np.asarray(points, dtype=np.float64)
    m, n = x.shape
    single = np.prod((3.0 - x * x) / 2.0, axis=1).sum()
    pairs = _pair_sum(x, "GL2")
    d2 = (4.0 / 3.0) ** n - 2.0 / m * single + pairs / (m * m)
    return float(np.sqrt(max(d2, 0.0)))


def unanchored_l2(points: np.ndarray) -> float:
    """Unanchored (L2-extreme) discrepancy of one set (m, n); see the module notes."""
    x = np.asarray(points, dtype=np.float64)
    m, n = x.shape
    single = np.prod(x * (1.0 - x), axis=1).sum()
    pairs = _pair_sum(x, "UL2")
    d2 = 12.0 ** (-n) - 2.0 ** (1 - n) / m * single + pairs / (m * m)
    return float(np.sqrt(max(d2, 0.0)))


def discrepancy_per_set(points, method: str = "CD", *, progress_bar: bool = False) -> np.ndarray:
    """Discrepancy ``method`` (one of :data:`METHODS`) of every set: array (sets,)."""
    if method not in METHODS:
        raise InvalidArgumentError(f"unknown discrepancy {method!r}; choose from {', '.join(METHODS)}")
    sets = as_sets(points)
    from scipy.stats import qmc  # here: scipy.stats takes a second to import

    def one_set(s: int) -> float:
        x = sets[s]
        if method == "GL2":
            return generalized_l2(x)
        if method == "UL2":
            return unanchored_l2(x)
        v = float(qmc.discrepancy(x, method=method))
        return float(np.sqrt(max(v, 0.0))) if method in _SQUARED_IN_SCIPY else v

    out = np.fromiter(
        map_sets(one_set, sets.shape[0], progress_bar=progress_bar, desc=f"discrepancy {method}"),
        dtype=np.float64,
        count=sets.shape[0],
    )
    return out


def discrepancy(points, method: str = "CD", *, progress_bar: bool = False) -> float:
    """Discrepancy ``method`` averaged over the sets."""
    return float(discrepancy_per_set(points, method, progress_bar=progress_bar).mean())
