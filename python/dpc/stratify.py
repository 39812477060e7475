"""(0,2)-stratification of a progressive point sequence (docs/progressive.md, "Stratified variant").

    >>> import dpc
    >>> x = dpc.load("progressive-2d").generate(seed=0, n_points=1024)
    >>> y = dpc.stratify.stratify_02(x)               # every power-of-two prefix a (0,2)-net
    >>> z = dpc.stratify.stratify_02(x, up_to=64)     # only the first 64: the trade-off between the two

A (0,2)-sequence in base 2 (every prefix of 2^k points has one point in each elementary interval
of area 2^-k, of every shape 2^a x 2^(k-a)) is what scrambled Sobol' and PMJ02 give renderers;
a blue-noise sequence is what progressive dpc gives. :func:`stratify_02` makes the (0,2)-sequence
nearest to a given sequence by PMJ02's construction (Christensen et al. 2018, the same as
:func:`dpc.baselines.pmj02`) with its free choices taken from the given points instead of
chance: at each doubling, the new points are assigned to the subquadrants the construction
opens (a minimum-cost matching of points to subquadrant centres, toroidal distance, scipy's
``linear_sum_assignment``), then each takes the position of its subquadrant's free strata
nearest to it. ``up_to`` stops the construction at a prefix: the points after it are left as
they are, so the small prefixes are nets and the large ones keep the given sequence's blue
noise; docs/progressive.md measures that trade-off.
"""

from __future__ import annotations

import numpy as np

from .baselines import _free_strata, _mark, _pmj02_steps
from .errors import InvalidArgumentError

__all__ = ["stratify_02"]


def _place(target: np.ndarray, square: np.ndarray, width: int, level: int, occ: list) -> np.ndarray:
    """The point of the square's free strata nearest to target (toroidally); marks it taken."""
    xs, ys = _free_strata(occ, level, int(square[0]), int(square[1]), width)
    if len(xs) == 0:  # never seen: PMJ02's order leaves a free stratum in every opened subquadrant
        raise RuntimeError("stratify_02: no free elementary interval for a point")
    lo = np.stack([xs, ys], 1) / (1 << level)
    hi = lo + 1.0 / (1 << level)
    t = target + np.round((lo + hi) / 2 - target)  # the target's copy nearest to each cell
    p = np.clip(t, lo, np.nextafter(hi, lo))
    best = int(np.argmin(((p - t) ** 2).sum(1)))
    y = p[best] % 1.0
    _mark(occ, level, y)
    return y


def stratify_02(points, up_to: int | None = None) -> np.ndarray:
    """The (0,2)-sequence nearest to ``points`` (m, 2) in [0, 1), point by point in their order:
    float64 (m, 2); every prefix of 2^k <= m points is a (0,2)-net (:func:`dpc.baselines.is_02_net`).
    ``up_to`` (a positive integer, default m): only the first ``up_to`` points are moved (the
    prefixes of 2^k <= up_to are nets), the rest are returned as given."""
    from scipy.optimize import linear_sum_assignment

    x = np.asarray(points, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 2 or len(x) < 1:
        raise InvalidArgumentError(f"points must be (m, 2) with m >= 1, got shape {x.shape}")
    if not np.all((x >= 0) & (x < 1)):
        raise InvalidArgumentError("points must lie in [0, 1)")
    if up_to is not None and (isinstance(up_to, bool) or not isinstance(up_to, int) or up_to < 1):
        raise InvalidArgumentError(f"up_to must be a positive integer, got {up_to!r}")
    m = len(x) if up_to is None else min(len(x), up_to)
    y = x.copy()
    for n, _, level, width, squares, occ in _pmj02_steps(y, m):
        # the new points to the subquadrants this step opens: nearest centres, one each
        new = np.arange(n, min(2 * n, m))
        d = x[new][:, None, :] - (squares + width / 2)[None, :, :] / (1 << level)
        d -= np.round(d)
        rows, cols = linear_sum_assignment((d * d).sum(-1))
        square_of = dict(zip(new[rows].tolist(), cols.tolist()))
        for i in new.tolist():
            y[i] = _place(x[i], squares[square_of[i]], width, level, occ)
    return y
