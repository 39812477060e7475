"""Post-processes of a progressive point sequence (docs/progressive.md): its (0,2)-stratification
("Stratified variant"), the joint relaxation of all its prefixes ("Jointly relaxed prefixes")
and the order within its levels ("Between the levels").

    >>> import dpc
    >>> x = dpc.load("progressive-2d").generate(seed=0, n_points=1024)
    >>> y = dpc.stratify.stratify_02(x)               # every power-of-two prefix a (0,2)-net
    >>> z = dpc.stratify.stratify_02(x, up_to=64)     # only the first 64: the trade-off between the two
    >>> r = dpc.stratify.relax_prefixes(x)            # every point moves; every prefix 16 * 2^j stays blue
    >>> o = dpc.stratify.order_levels(x)              # x's order already: the generator makes it

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

:func:`relax_prefixes` lets every point of a progressive sequence move at once, by gradient steps
on the sum over its prefixes of a Gaussian pair energy at each prefix's own scale (the energy of
Gaussian blue noise, Ahmed et al. 2022, once per prefix: the prefix's pairs feel it), plus a
small term that cancels each prefix's lowest frequencies. A progressive model's levels hold the
earlier points in place; relaxed jointly, the full set and every power-of-two prefix are each as
blue as a set made for their size (the measurements in docs/progressive.md), and the first n
points are no longer the model's set of n. It is libdpc's ``dpc_relax_prefixes``, the last step
of a model with metadata ``dpc.relax`` (progressive-2d-relaxed: docs/model-format.md §6.1).

:func:`order_levels` puts the points of each level (the first ``base`` points, then blocks that
double the count) in the order that fills the emptiest place first, so that a prefix ending
inside a level is spread too. Every progressive model's generator does it as its last step
(docs/model-format.md §6); it is libdpc's ``dpc_order_levels``.
"""

from __future__ import annotations

import numpy as np

from . import _args, _core
from .baselines import _free_strata, _mark, _pmj02_steps
from .errors import InvalidArgumentError

__all__ = ["order_levels", "relax_prefixes", "stratify_02"]

RELAX_MAX_STEPS = 100_000  # libdpc's bound (DPC_RELAX_MAX_STEPS)


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
    m = len(x) if up_to is None else min(len(x), _args.integer(up_to, "up_to", 1))
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


def relax_prefixes(points, steps: int = 1600, base: int = 16, *, threads: int = 0) -> np.ndarray:
    """Every point of the ordered set ``points`` (m, 2) in [0, 1), m >= ``base``, moved at once so
    that each prefix of ``base`` * 2^j points and the whole set are blue noise; (m, 2) float32,
    the same order. libdpc's ``dpc_relax_prefixes`` (docs/model-format.md §6.1): ``steps``
    gradient steps on E = sum over those prefixes P of sum_{i<j in P} exp(-|x_i - x_j|^2 /
    (2 s_P^2)), s_P = 0.85 / sqrt(|P|) (0.60 / sqrt(m) for the whole set), toroidal distances,
    each pair's force shifted to reach 0 at min(3.5 s_P, 1/2), plus 0.05 * sum_q
    |sum_{i in P} exp(2 pi i q.x_i)|^2 / (|q|^2 |P|) over 0 < |q| <= min(8, sqrt(|P|) / 4), which
    cancels the torus-scale imbalance that smooth integrands see. Each step moves point i by 0.1
    (falling linearly to 0.02) times minus the gradient, the pair terms scaled by s_P^2. What the
    generator of a model with metadata ``dpc.relax`` (e.g. progressive-2d-relaxed) does after its
    levels, bit for bit; the same bits on every machine. The first n points of the result are not
    the relaxed set of n (it depends on m). ``threads`` (0: one per CPU) share the work from
    2,048 points on, with the same bits for any count."""
    x = np.asarray(points)
    base = _args.integer(base, "base", 2, _args.UINT32_MAX)
    if x.ndim != 2 or x.shape[1] != 2 or len(x) < base:
        raise InvalidArgumentError(f"points must be (m, 2) with m >= base = {base}, got shape {x.shape}")
    steps = _args.integer(steps, "steps", 0, RELAX_MAX_STEPS)
    y = np.ascontiguousarray(x, dtype=np.float32)
    if not np.all((y >= 0) & (y < 1)):
        raise InvalidArgumentError("points must lie in [0, 1) (as float32)")
    threads = _args.threads(threads)
    return _core.relax_prefixes(y, base, steps, threads)


def order_levels(points, base: int = 16) -> np.ndarray:
    """The ordered set ``points`` (m, d) in [0, 1) with the points of each level reordered; (m, d)
    float32. The levels are the first min(m, ``base``) points, then blocks of min(n, m - n) after
    the first n, ordered first to last. Within a level each pick is the emptiest place left: the
    point of least energy, the sum of b(r) = (1 - r^2 / R^2)^3 (0 beyond R) over the points
    before it (the earlier levels and the level's picks so far), R = min(2 N^(-1/d), 1/2) for the
    N points the level completes, toroidal distances, ties to the lower index; taken within a
    quota that keeps each prefix's picks in proportion to the level's points in every cell of a
    tree of cells (x and y halved at each depth) down to cells of about 8 of its points.
    libdpc's ``dpc_order_levels`` (docs/model-format.md §6): what the generator of every
    progressive model does last. Each level keeps its set of points, and the order is the same on
    every machine."""
    x = np.asarray(points)
    base = _args.integer(base, "base", 1, _args.UINT32_MAX)
    if x.ndim != 2 or x.shape[0] == 0 or x.shape[1] == 0:
        raise InvalidArgumentError(f"points must be (m, d) with m, d >= 1, got shape {x.shape}")
    y = np.ascontiguousarray(x, dtype=np.float32)
    if not np.all((y >= 0) & (y < 1)):
        raise InvalidArgumentError("points must lie in [0, 1) (as float32)")
    return _core.order_levels(y, base)
