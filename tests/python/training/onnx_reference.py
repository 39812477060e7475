"""A Python implementation of the ai.dpc PointFilter op for onnx.reference.ReferenceEvaluator:
an independent oracle of what a dpc model file means (docs/model-format.md §3), in numpy float64
with dense all-pairs distances (no torch, no neighbour search).

    from onnx.reference import ReferenceEvaluator
    from onnx_reference import PointFilter
    sess = ReferenceEvaluator("models/bnot-2d.onnx", new_ops=[PointFilter])
    (y,) = sess.run(None, {"points": x})
"""

from __future__ import annotations

import numpy as np
from onnx.reference.op_run import OpRun


def point_filter(
    points: np.ndarray, kernels: np.ndarray, subspaces, radius, eps: float = 1e-4, fixed: int = 0
) -> np.ndarray:
    """One layer on [m, n] or [batch, m, n]; float64 arithmetic, float32 result."""
    x = np.asarray(points, dtype=np.float64)
    if x.ndim == 2:
        return point_filter(x[None], kernels, subspaces, radius, eps, fixed)[0]
    w = np.asarray(kernels, dtype=np.float64)
    bsz, m, n = x.shape
    b = w.shape[1]
    count = np.zeros(n)
    total = np.zeros_like(x)
    for t, (mask, rho) in enumerate(zip(subspaces, radius)):
        dims = [k for k in range(n) if (int(mask) >> k) & 1]
        count[dims] += 1
        h = float(m) ** (-1.0 / len(dims))
        r, e = min(float(rho) * h, 0.5), float(eps) * h
        xs = x[:, :, dims]
        delta = xs[:, None, :, :] - xs[:, :, None, :]  # [B, i, j, k] = x_j − x_i
        delta -= np.floor(delta + 0.5)
        d = np.sqrt((delta**2).sum(-1))
        inside = (d > e) & (d < r)
        ds = np.where(inside, d, 1.0)
        u = ds * (b - 1) / r
        q = np.minimum(np.floor(u), b - 2).astype(np.int64)
        f = u - q
        g = w[t, q] + f * (w[t, q + 1] - w[t, q])
        coef = np.where(inside, h * g / ds, 0.0)
        total[:, :, dims] += (coef[..., None] * delta).sum(axis=2)
    y = x.copy()
    for k in range(n):
        if count[k] > 0 and not (int(fixed) >> k) & 1:
            y[:, :, k] += total[:, :, k] / count[k]
    y -= np.floor(y)
    y = y.astype(np.float32)
    y[y >= 1.0] = 0.0
    return y


class PointFilter(OpRun):
    """ai.dpc::PointFilter for onnx.reference (attributes per docs/model-format.md §2)."""

    op_domain = "ai.dpc"

    def _run(self, points, kernels, subspaces=None, radius=None, eps=None, fixed=None):
        if subspaces is None or radius is None:
            raise ValueError("PointFilter needs the subspaces and radius attributes")
        eps = 1e-4 if eps is None else float(eps)
        fixed = 0 if fixed is None else int(fixed)
        return (point_filter(points, kernels, list(subspaces), list(radius), eps, fixed),)
