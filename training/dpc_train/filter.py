"""One PointFilter layer (docs/model-format.md §3) in PyTorch.

Three implementations of the same op, all differentiable w.r.t. points and kernel tables:

* ``impl="torch"``: plain autograd over the gathered neighbour pairs (the reference; runs on
  CPU and CUDA).
* ``impl="analytic"``: a ``torch.autograd.Function`` whose backward is the closed form of paper
  Appendix A (adapted to the scale-aware radius and the normalised subspace sum): the template
  the C kernels follow.
* ``impl="c"``: libdpc's C kernels (float64 forward and Appendix-A backward, CPU, parallel
  over points) through ``dpc.training``; the fast path for training on the CPU.

Memory is O(m · neighbours): candidate pairs are found without grad (a toroidal cell grid for
subspaces of up to 3 dimensions, chunked all-pairs distances otherwise), only pairs inside the
radius are kept, and the differentiable interaction is computed on those pairs only.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import torch

# Max number of (i, j) candidates materialised at once in the chunked all-pairs search.
_PAIR_CHUNK = 1 << 22


class FilterConfigError(ValueError):
    """A filter layer description that does not follow docs/model-format.md."""


def mask_dims(mask: int, n: int) -> list[int]:
    """Dimension indices of a subspace bitmask."""
    return [k for k in range(n) if (mask >> k) & 1]


def check_layer(n: int, kernels: torch.Tensor, subspaces, radius, eps: float, fixed: int) -> None:
    """Validate a layer against the format's MUSTs (typed error, clear message)."""
    s = len(subspaces)
    if kernels.dim() != 2 or kernels.shape[0] != s:
        raise FilterConfigError(f"kernels must be [s, b] with s = {s} subspaces, got {tuple(kernels.shape)}")
    if kernels.shape[1] < 2:
        raise FilterConfigError(f"need at least 2 kernel bins, got {kernels.shape[1]}")
    if len(radius) != s:
        raise FilterConfigError(f"radius needs one entry per subspace ({s}), got {len(radius)}")
    if len(set(int(m) for m in subspaces)) != s:
        raise FilterConfigError(f"subspaces must be distinct, got {list(subspaces)}")
    for mask in subspaces:
        if int(mask) <= 0 or int(mask) >> n:
            raise FilterConfigError(f"subspace mask {mask} is empty or uses dims >= n = {n}")
    for r in radius:
        if not (0 < float(r) <= 1e6) or not math.isfinite(float(r)):
            raise FilterConfigError(f"radius must be in (0, 1e6], got {r}")
    if not (eps >= 0 and math.isfinite(eps)):
        raise FilterConfigError(f"eps must be finite and >= 0, got {eps}")
    if fixed < 0 or fixed >> n:
        raise FilterConfigError(f"fixed mask {fixed} uses dims >= n = {n}")


def subspace_geometry(m: int, mask: int, n: int, rho: float, eps: float):
    """(dims, h_t, r_t, e_t) of one subspace: spacing, radius and cutoff in absolute units."""
    dims = mask_dims(mask, n)
    h = float(m) ** (-1.0 / len(dims))
    return dims, h, min(float(rho) * h, 0.5), float(eps) * h


def _sqnorm(delta: torch.Tensor) -> torch.Tensor:
    """Row-wise squared norm of [N, k]; explicit column sums beat sum(-1) over a tiny last dim."""
    if delta.shape[1] > 4:
        return (delta * delta).sum(-1)
    out = delta[:, 0] * delta[:, 0]
    for a in range(1, delta.shape[1]):
        out = out + delta[:, a] * delta[:, a]
    return out


def _wrap_diff(d: torch.Tensor) -> torch.Tensor:
    # Minimum-image difference in [-1/2, 1/2); floor has zero gradient, so d(δ)/d(x) = 1.
    return d - torch.floor(d + 0.5)


# ----------------------------------------------------------------------------------------
# Neighbour search (no grad)
# ----------------------------------------------------------------------------------------


def _pairs_all(xs: torch.Tensor, r: float, e: float):
    """All pairs (i, j) of one set with e < d < r, by chunked distance computation."""
    m = xs.shape[0]
    rows = max(1, _PAIR_CHUNK // max(m, 1))
    out_i, out_j = [], []
    for a in range(0, m, rows):
        b = min(m, a + rows)
        delta = _wrap_diff(xs[None, :, :] - xs[a:b, None, :])
        d2 = (delta * delta).sum(-1)
        ok = (d2 < r * r) & (d2 > e * e)
        ii, jj = ok.nonzero(as_tuple=True)
        out_i.append(ii + a)
        out_j.append(jj)
    return torch.cat(out_i), torch.cat(out_j)


def _pairs_grid(x: torch.Tensor, r: float, e: float, g: int):
    """Pairs with e < d < r for a whole batch x [B, m, k] via a toroidal grid of g^k cells
    (side 1/g >= r) per set; indices address the flattened [B·m] points."""
    bsz, m, k = x.shape
    dev = x.device
    xs = x.reshape(bsz * m, k)
    cell = torch.clamp((xs * g).long(), 0, g - 1)  # [B·m, k]
    strides = torch.tensor([g**a for a in range(k)], device=dev)
    setoff = torch.arange(bsz, device=dev).repeat_interleave(m) * g**k
    cid = (cell * strides).sum(-1) + setoff
    order = torch.argsort(cid, stable=True)
    counts = torch.bincount(cid, minlength=bsz * g**k)
    starts = torch.cumsum(counts, 0) - counts
    cols = [xs[:, a].contiguous() for a in range(k)]
    out_i, out_j = [], []
    ar = torch.arange(bsz * m, device=dev)
    for off in itertools.product((-1, 0, 1), repeat=k):
        nb = (cell + torch.tensor(off, device=dev)) % g
        nid = (nb * strides).sum(-1) + setoff
        cnt = counts[nid]
        tot = int(cnt.sum())
        if tot == 0:
            continue
        ii = torch.repeat_interleave(ar, cnt, output_size=tot)
        # position of each candidate inside its neighbour cell
        first = torch.cumsum(cnt, 0) - cnt
        # index_select is much faster than advanced indexing on CPU
        pos = torch.arange(tot, device=dev) - first.index_select(0, ii)
        jj = order.index_select(0, (starts.index_select(0, nid)).index_select(0, ii) + pos)
        d2 = None
        for col in cols:  # per-column 1-D gathers: faster than [N, k] rows + sum(-1)
            dc = _wrap_diff(col.index_select(0, jj) - col.index_select(0, ii))
            d2 = dc * dc if d2 is None else d2 + dc * dc
        ok = ((d2 < r * r) & (d2 > e * e)).nonzero().squeeze(1)
        out_i.append(ii.index_select(0, ok))
        out_j.append(jj.index_select(0, ok))
    if not out_i:
        z = torch.zeros(0, dtype=torch.long, device=dev)
        return z, z
    return torch.cat(out_i), torch.cat(out_j)


@torch.no_grad()
def find_pairs(x: torch.Tensor, dims: list[int], r: float, e: float):
    """Ordered pairs (i, j), i ≠ j implied by e ≥ 0, with e < d_t(x_i, x_j) < r over a batch.

    x is [B, m, n]; returned indices address the flattened [B·m] points. Uses a cell grid when
    it pays (≤ 3 dims, at least 3 cells per axis), else chunked all pairs.
    """
    bsz, m, _ = x.shape
    g = int(math.floor(1.0 / r)) if r > 0 else 0
    use_grid = len(dims) <= 3 and g >= 3 and m > 64
    if use_grid:
        return _pairs_grid(x[:, :, dims], r, e, g)
    out_i, out_j = [], []
    for bi in range(bsz):
        ii, jj = _pairs_all(x[bi][:, dims], r, e)
        out_i.append(ii + bi * m)
        out_j.append(jj + bi * m)
    return torch.cat(out_i), torch.cat(out_j)


# ----------------------------------------------------------------------------------------
# Forward pieces shared by impl="torch" and impl="analytic"
# ----------------------------------------------------------------------------------------


@dataclass
class _Sub:
    dims: list[int]
    h: float
    r: float
    e: float
    ii: torch.Tensor
    jj: torch.Tensor


@torch.no_grad()
def _restrict(x: torch.Tensor, dims: list[int], ii, jj, r: float, e: float):
    """The pairs among candidates (ii, jj) with e < d < r at the current positions."""
    flat = x.reshape(-1, x.shape[-1])
    d2 = None
    for a in dims:
        col = flat[:, a]
        dc = _wrap_diff(col.index_select(0, jj) - col.index_select(0, ii))
        d2 = dc * dc if d2 is None else d2 + dc * dc
    ok = ((d2 < r * r) & (d2 > e * e)).nonzero().squeeze(1)
    return ii.index_select(0, ok), jj.index_select(0, ok)


def _prepare(x: torch.Tensor, subspaces, radius, eps: float, candidates=None):
    _, m, n = x.shape
    subs = []
    for t, (mask, rho) in enumerate(zip(subspaces, radius)):
        dims, h, r, e = subspace_geometry(m, int(mask), n, rho, eps)
        if candidates is None:
            ii, jj = find_pairs(x.detach(), dims, r, e)
        else:
            ii, jj = _restrict(x.detach(), dims, *candidates[t], r, e)
        subs.append(_Sub(dims, h, r, e, ii, jj))
    return subs


class NeighbourCache:
    """Verlet lists across the layers of a cascade: candidate pairs within r_t + skin·h_t are
    found once and reused while no point has moved more than skin·h_t / 2 (torus distance in
    the subspace) since they were built; then every pair with d < r_t is still a candidate
    (d_then ≤ d_now + 2·max move < r_t + skin·h_t), so results equal a fresh search's."""

    def __init__(self, subspaces, radius, skin: float = 1.0):
        self.subspaces = tuple(int(s) for s in subspaces)
        self.radius = tuple(float(r) for r in radius)
        self.skin = float(skin)
        self.entries: dict[int, tuple] = {}
        self.builds = 0

    @torch.no_grad()
    def candidates(self, x: torch.Tensor):
        x = x.detach()
        _, m, n = x.shape
        out = []
        for t, (mask, rho) in enumerate(zip(self.subspaces, self.radius)):
            dims, h, r, _ = subspace_geometry(m, mask, n, rho, 0.0)
            ent = self.entries.get(t)
            if ent is not None:
                ref, ii, jj, half = ent
                same = ref.shape == x[..., dims].shape
                mv = _wrap_diff(x[..., dims] - ref) if same else None
                if same and float(_sqnorm(mv.reshape(-1, len(dims))).max()) < half * half:
                    out.append((ii, jj))
                    continue
            rc = r + self.skin * h
            ii, jj = find_pairs(x, dims, rc, 0.0)
            self.entries[t] = (x[..., dims].clone(), ii, jj, 0.5 * self.skin * h)
            self.builds += 1
            out.append((ii, jj))
        return out


def _scale(n: int, subspaces, fixed: int, dtype, device) -> torch.Tensor:
    """Per-dimension factor 1/c_k for moving dims, 0 for fixed or uncovered dims."""
    c = [0] * n
    for mask in subspaces:
        for k in mask_dims(int(mask), n):
            c[k] += 1
    sc = [(1.0 / c[k]) if c[k] > 0 and not (fixed >> k) & 1 else 0.0 for k in range(n)]
    return torch.tensor(sc, dtype=dtype, device=device)


def _bins(d: torch.Tensor, r: float, b: int):
    u = d * ((b - 1) / r)
    q = torch.clamp(torch.floor(u), max=b - 2).long()
    return q, u - q.to(u.dtype)


def _wrap_points(y: torch.Tensor) -> torch.Tensor:
    y = y - torch.floor(y)
    # Float rounding can give exactly 1.0 for a tiny negative input: the format maps it to 0.
    return torch.where(y >= 1.0, torch.zeros_like(y), y)


def _as_batch(points: torch.Tensor):
    if points.dim() == 2:
        return points[None], True
    if points.dim() == 3:
        return points, False
    raise FilterConfigError(f"points must be [m, n] or [batch, m, n], got {tuple(points.shape)}")


# ----------------------------------------------------------------------------------------
# impl="torch": autograd on gathered pairs
# ----------------------------------------------------------------------------------------


def _filter_torch(x: torch.Tensor, kernels: torch.Tensor, subspaces, radius, eps, fixed, candidates=None):
    bsz, m, n = x.shape
    flat = x.reshape(bsz * m, n)
    b = kernels.shape[1]
    scale = _scale(n, subspaces, fixed, x.dtype, x.device)
    total = torch.zeros_like(flat)
    for t, sub in enumerate(_prepare(x, subspaces, radius, eps, candidates)):
        if sub.ii.numel() == 0:
            continue
        dims = torch.tensor(sub.dims, device=x.device)
        xd = flat.index_select(1, dims)
        delta = _wrap_diff(xd.index_select(0, sub.jj) - xd.index_select(0, sub.ii))
        d = torch.sqrt(_sqnorm(delta))
        q, f = _bins(d.detach(), sub.r, b)
        # f is recomputed with grad so that dg/dd flows (u − q with q constant)
        f = d * ((b - 1) / sub.r) - q.to(d.dtype)
        w = kernels[t]
        w0, w1 = w.index_select(0, q), w.index_select(0, q + 1)
        g = w0 + f * (w1 - w0)
        contrib = (sub.h * g / d)[:, None] * delta
        acc = torch.zeros(bsz * m, len(sub.dims), dtype=x.dtype, device=x.device)
        acc = acc.index_add(0, sub.ii, contrib)
        total = total.index_add(1, dims, acc)
    return _wrap_points(flat + total * scale).reshape(bsz, m, n)


# ----------------------------------------------------------------------------------------
# impl="analytic": closed-form backward (paper Appendix A)
# ----------------------------------------------------------------------------------------


class _FilterAnalytic(torch.autograd.Function):
    """Forward as §3; backward from the closed form (no autograd graph over pairs).

    For a pair (i, j) in subspace t with δ = x_j ⊖ x_i (over D_t), d = |δ|, the contribution to
    point i is v = h·g(d)·δ/d with g'(d) = (w[q+1] − w[q])·(b−1)/r. With G = ∂L/∂y scaled by
    1/c_k (0 on fixed dims), a = ∂L/∂δ = h·[g'·(G·δ)·δ/d² + g·(G/d − (G·δ)·δ/d³)];
    ∂L/∂x_j += a, ∂L/∂x_i −= a; ∂L/∂w[q] += h(1−f)(G·δ)/d, ∂L/∂w[q+1] += h·f·(G·δ)/d.
    """

    @staticmethod
    def forward(ctx, x, kernels, subspaces, radius, eps, fixed, candidates=None):
        bsz, m, n = x.shape
        b = kernels.shape[1]
        flat = x.reshape(bsz * m, n)
        scale = _scale(n, subspaces, fixed, x.dtype, x.device)
        total = torch.zeros_like(flat)
        saved = []
        for t, sub in enumerate(_prepare(x, subspaces, radius, eps, candidates)):
            dims = torch.tensor(sub.dims, device=x.device, dtype=torch.long)
            xd = flat.index_select(1, dims)
            delta = _wrap_diff(xd.index_select(0, sub.jj) - xd.index_select(0, sub.ii))
            d = torch.sqrt(_sqnorm(delta))
            q, f = _bins(d, sub.r, b)
            w = kernels[t]
            w0, w1 = w.index_select(0, q), w.index_select(0, q + 1)
            g = w0 + f * (w1 - w0)
            contrib = (sub.h * g / d)[:, None] * delta
            acc = torch.zeros(bsz * m, len(sub.dims), dtype=x.dtype, device=x.device)
            acc.index_add_(0, sub.ii, contrib)
            total.index_add_(1, dims, acc)
            saved.append((sub, dims, delta, d, q, f, g))
        ctx.saved = saved
        ctx.meta = (bsz, m, n, b)
        ctx.save_for_backward(kernels, scale)
        return _wrap_points(flat + total * scale).reshape(bsz, m, n)

    @staticmethod
    def backward(ctx, grad_out):
        kernels, scale = ctx.saved_tensors
        bsz, m, n, b = ctx.meta
        gy = grad_out.reshape(bsz * m, n)
        gx = gy.clone()  # the residual path: y = x + Δ (wrap has unit derivative)
        gs = gy * scale
        gk = torch.zeros_like(kernels)
        for t, (sub, dims, delta, d, q, f, g) in enumerate(ctx.saved):
            if sub.ii.numel() == 0:
                continue
            w = kernels[t]
            gi = gs.index_select(1, dims).index_select(0, sub.ii)  # ∂L/∂v for each pair
            gdot = (gi * delta).sum(-1)  # G·δ
            dg = (w.index_select(0, q + 1) - w.index_select(0, q)) * ((b - 1) / sub.r)  # g'(d)
            coef_d = sub.h * (dg * gdot / (d * d) - g * gdot / (d * d * d))
            a = coef_d[:, None] * delta + (sub.h * g / d)[:, None] * gi
            accj = torch.zeros(bsz * m, len(sub.dims), dtype=gy.dtype, device=gy.device)
            accj.index_add_(0, sub.jj, a)
            accj.index_add_(0, sub.ii, -a)
            gx.index_add_(1, dims, accj)
            base = sub.h * gdot / d
            gk[t].index_add_(0, q, base * (1 - f))
            gk[t].index_add_(0, q + 1, base * f)
        return gx.reshape(bsz, m, n), gk, None, None, None, None, None


# ----------------------------------------------------------------------------------------
# impl="c": libdpc's float64 layer kernels (dpc_layer_forward / dpc_layer_backward)
# ----------------------------------------------------------------------------------------


def to_torus_dtype(y: torch.Tensor, dtype: torch.dtype) -> torch.Tensor:
    """Cast points in [0, 1) to dtype, keeping them in [0, 1): in float32 a float64 value just
    below 1 rounds to 1.0, which wraps to 0 (as libdpc's float32 wrap does)."""
    out = y.to(dtype)
    return torch.where(out >= 1.0, out - 1.0, out)


class _FilterC(torch.autograd.Function):
    """Forward and backward in libdpc (C, float64, parallel over points, bits independent of
    the thread count), through dpc.training. Inputs of any float dtype are computed in float64
    and returned in their own dtype. The kernels use torch's intra-op thread count (``[train]
    threads`` sets both) and the ISA path libdpc picks (``isa="auto"``)."""

    @staticmethod
    def forward(ctx, x, kernels, subspaces, radius, eps, fixed):
        from dpc.training import layer_forward

        x64 = x.detach().to(torch.float64).contiguous().numpy()
        k64 = kernels.detach().to(torch.float64).contiguous().numpy()
        args = (list(subspaces), list(radius), float(eps), int(fixed))
        y = layer_forward(x64, k64, *args, threads=torch.get_num_threads())
        ctx.save_for_backward(x, kernels)
        ctx.args = args
        return to_torus_dtype(torch.from_numpy(y), x.dtype)

    @staticmethod
    def backward(ctx, grad_y):
        from dpc.training import layer_backward

        x, kernels = ctx.saved_tensors
        x64 = x.detach().to(torch.float64).contiguous().numpy()
        k64 = kernels.detach().to(torch.float64).contiguous().numpy()
        g64 = grad_y.detach().to(torch.float64).contiguous().numpy()
        gx, gk = layer_backward(x64, k64, *ctx.args, grad_y=g64, threads=torch.get_num_threads())
        return (torch.from_numpy(gx).to(x.dtype), torch.from_numpy(gk).to(kernels.dtype), None, None, None, None)


# ----------------------------------------------------------------------------------------
# Public entry point
# ----------------------------------------------------------------------------------------

IMPLS = ("auto", "torch", "analytic", "c")
# libdpc's layer descriptor holds at most this many dimensions (DPC_MAX_DIMS in dpc.h)
_C_MAX_DIMS = 64


def resolve_impl(impl: str, points: torch.Tensor) -> str:
    """The implementation "auto" stands for: libdpc's C kernels (the fastest on the CPU, same
    results as torch to float64 rounding) where they can serve, i.e. CPU tensors of at most
    _C_MAX_DIMS dimensions with the dpc package importable; pure torch otherwise (CUDA)."""
    if impl != "auto":
        return impl
    if points.device.type != "cpu" or points.shape[-1] > _C_MAX_DIMS:
        return "torch"
    try:
        import dpc.training  # noqa: F401
    except ImportError:
        return "torch"
    return "c"


def filter_layer(
    points: torch.Tensor,
    kernels: torch.Tensor,
    subspaces,
    radius,
    eps: float = 1e-4,
    fixed: int = 0,
    impl: str = "torch",
    cache: NeighbourCache | None = None,
) -> torch.Tensor:
    """Apply one PointFilter layer (docs/model-format.md §3).

    points: [m, n] or [batch, m, n] in [0, 1); kernels: [s, b] (kernel values in units of the
    subspace's mean spacing); subspaces: s bitmasks; radius: s values ρ_t (in spacings);
    eps: cutoff in spacings; fixed: bitmask of dims that never move. impl: one of IMPLS ("auto":
    "c" on the CPU, else "torch"; resolve_impl). cache: optional
    NeighbourCache shared by the layers of a cascade (same subspaces and radii) to reuse the
    neighbour search; the result is the same pair set either way.
    """
    x, squeeze = _as_batch(points)
    check_layer(x.shape[-1], kernels, subspaces, radius, float(eps), int(fixed))
    if kernels.dtype != x.dtype:
        raise FilterConfigError(f"kernels dtype {kernels.dtype} != points dtype {x.dtype}")
    subspaces = tuple(int(s) for s in subspaces)
    radius = tuple(float(r) for r in radius)
    impl = resolve_impl(impl, x)
    cands = None
    if cache is not None and impl in ("torch", "analytic"):
        if cache.subspaces != subspaces or cache.radius != radius:
            raise FilterConfigError("NeighbourCache was built for other subspaces/radii")
        cands = cache.candidates(x)
    if impl == "torch":
        y = _filter_torch(x, kernels, subspaces, radius, float(eps), int(fixed), cands)
    elif impl == "analytic":
        y = _FilterAnalytic.apply(x, kernels, subspaces, radius, float(eps), int(fixed), cands)
    elif impl == "c":
        if x.device.type != "cpu":
            raise FilterConfigError("impl='c' runs libdpc on the CPU; use impl='torch' on CUDA")
        y = _FilterC.apply(x, kernels, subspaces, radius, float(eps), int(fixed))
    else:
        raise FilterConfigError(f"impl must be one of {IMPLS}, got {impl!r}")
    return y[0] if squeeze else y
