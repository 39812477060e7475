"""libdpc's float64 training kernels for one filter layer: dpc._core.layer_forward / layer_backward.

* forward against the independent float64 reference (reference_cascade.filter_layer) to 1e-12 on
  2-D, 3-D projection (xy, xz, yz), mixed (xyz + z), gridded (fixed dims) and 6-D layers, with
  points on the torus seam and duplicate points;
* backward against central finite differences of the C forward (relative error <= 1e-6) for
  grad_x and grad_kernels, on random points checked to lie away from every kink (window edges,
  bin edges), seam points included; torch.autograd.gradcheck on a Function wrapping the bindings;
* bit-identical results for 1 and 4 threads (chunk-parallel and set-parallel paths), batches equal
  to per-set calls;
* every ISA path (DPC_ISA = scalar, avx2, avx512 where the CPU has them) on its own against the
  reference and finite differences, and each vector path against the scalar one to 1e-12 relative
  (2-D grid, 3-D grid, 4-D and 10-D all pairs, subspaces, fixed dimensions);
* every bad input raises a typed dpc.errors exception.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import dpc
import reference_cascade as rc
from cpu_isa import VECTOR_ISAS
from dpc import _core, errors  # noqa: E402

EPS = 1e-4
ISAS = ["scalar"] + VECTOR_ISAS


@pytest.fixture(params=ISAS)
def isa(request, monkeypatch):
    """Run the test on one ISA path (the kernels read DPC_ISA on every call)."""
    monkeypatch.setenv("DPC_ISA", request.param)
    return request.param


# name: (n, subspaces, radius, fixed, grid shape of the fixed dims or None, m)
LAYERS = {
    "2d": (2, [0b11], [3.0], 0, None, 300),
    "3d_proj": (3, [0b011, 0b101, 0b110], [2.5, 3.0, 2.0], 0, None, 400),
    "mixed": (3, [0b111, 0b100], [2.0, 4.0], 0, None, 300),
    "mixed_grid3d": (3, [0b111, 0b001], [1.5, 3.0], 0, None, 2000),  # xyz on the cell grid
    "gridded": (3, [0b111, 0b100, 0b011], [2.0, 3.0, 1.5], 0b011, (16, 16), 256),
    "6d": (6, [0b111111, 0b000011], [1.5, 2.5], 0, None, 300),
}


def seam_points(rng, m, n, grid=None, exact=True):
    """Uniform points with coordinates pinned on both sides of the torus seam and one duplicated
    point (d = 0 must be dropped by the cutoff). exact: pins at 0, 1e-12, 1e-7, 1 - 1e-7, the
    largest double below 1 and 0.5 (distinct within each dimension); else random pins within
    0.01 of the seam and no duplicate (for derivatives: exact pins sit on the cutoff kink)."""
    x = rng.random((m, n))
    near = [0.0, 1e-12, 1e-7, 1 - 1e-7, np.nextafter(1.0, 0.0), 0.5]
    for i in range(min(m // 4, n * len(near))):
        k = i % n
        x[i, k] = near[i // n] if exact else (rng.random() * 0.02 - 0.01) % 1.0
    if exact:
        x[m - 1] = x[m - 2]
    if grid is not None:
        x = rc.grid_fill(x, [0, 1], list(grid))
    return x


def kernels_for(rng, s, b, scale=0.05):
    return rng.normal(size=(s, b)) * scale


def run_ref(x, w, subspaces, radius, eps, fixed):
    layer = rc.RefLayer(subspaces=list(subspaces), radius=list(radius), kernels=w, eps=eps, fixed=fixed)
    return rc.filter_layer(x, layer)


# ------------------------------------------------------------------------------------------------
# Forward
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(LAYERS))
def test_forward_matches_reference(name, isa):
    n, subs, rad, fixed, grid, m = LAYERS[name]
    rng = np.random.default_rng(sorted(LAYERS).index(name))
    x = seam_points(rng, m, n, grid)
    w = kernels_for(rng, len(subs), 17)
    y = _core.layer_forward(x, w, subs, rad, EPS, fixed, 1)
    ref = run_ref(x, w, subs, rad, EPS, fixed)
    assert y.shape == x.shape and y.dtype == np.float64
    assert np.all((y >= 0) & (y < 1))
    err = rc.torus_diff(y, ref).max()
    assert err <= 1e-12, f"{name}: max torus error {err:.3g}"
    # The layer did something (a broken kernel returning x would pass the bound otherwise).
    assert rc.torus_diff(y, x).max() > 1e-4
    for k in range(n):
        if (fixed >> k) & 1:
            assert np.array_equal(y[:, k], x[:, k])


def test_zero_kernels_are_the_identity():
    rng = np.random.default_rng(5)
    x = seam_points(rng, 200, 3)
    w = np.zeros((2, 9))
    y = _core.layer_forward(x, w, [0b111, 0b100], [2.0, 3.0], EPS, 0, 1)
    assert np.array_equal(y, x)
    g = rng.normal(size=x.shape)
    gx, gk = _core.layer_backward(x, w, [0b111, 0b100], [2.0, 3.0], EPS, 0, g, 1)
    assert np.array_equal(gx, g)  # g = g' = 0: only the residual path is left
    assert gk.shape == (2, 9) and np.abs(gk).max() > 0  # kernel gradients do not vanish


# ------------------------------------------------------------------------------------------------
# Backward: finite differences and gradcheck
# ------------------------------------------------------------------------------------------------


def kink_distance(x, subspaces, radius, eps, fixed, b):
    """Smallest distance (coordinate units) of any pair of a moving subspace from a kink: the
    window edges e_t, r_t and the bin edges of the kernel lookup."""
    m, n = x.shape
    worst = np.inf
    for mask, rho in zip(subspaces, radius):
        dims = [k for k in range(n) if (mask >> k) & 1]
        if all((fixed >> k) & 1 for k in dims):
            continue
        h = float(m) ** (-1.0 / len(dims))
        r, e = min(rho * h, 0.5), eps * h
        delta = x[None, :, dims] - x[:, None, dims]
        delta -= np.floor(delta + 0.5)
        d = np.sqrt((delta**2).sum(-1))
        off = ~np.eye(m, dtype=bool)
        worst = min(worst, np.abs(d - r)[off].min(), np.abs(d - e)[off].min())
        inside = off & (d > e) & (d < r)
        if inside.any():
            u = d[inside] * (b - 1) / r
            worst = min(worst, np.abs(u - np.rint(u)).min() * r / (b - 1))
    return worst


def smooth_points(n, m, subspaces, radius, fixed, b, margin, grid=None, seam=True, interior=0.0, start=0):
    """A deterministic random set whose pairs all lie `margin` away from every kink."""
    for seed in range(start, start + 500):
        rng = np.random.default_rng(seed)
        if seam:
            x = seam_points(rng, m, n, grid, exact=False)
        else:
            x = interior + (1 - 2 * interior) * rng.random((m, n))
        if grid is not None:
            x = rc.grid_fill(x, [0, 1], list(grid))
        if kink_distance(x, subspaces, radius, EPS, fixed, b) > margin:
            return x, rng
    raise AssertionError("no kink-free point set found")


def unwrapped(y, y0):
    d = y - y0
    return d - np.rint(d)


FD_CASES = {
    "2d": (2, [0b11], [3.0], 0, None, 90, 8),
    "3d_proj": (3, [0b011, 0b101, 0b110], [2.5, 3.0, 2.0], 0, None, 70, 6),
    "mixed": (3, [0b111, 0b100], [2.0, 3.5], 0, None, 70, 6),
    "gridded": (3, [0b111, 0b100], [2.5, 4.0], 0b011, (8, 8), 64, 6),
    "6d": (6, [0b111111, 0b000001], [1.2, 3.0], 0, None, 40, 5),
}


@pytest.mark.parametrize("name", sorted(FD_CASES))
def test_backward_matches_finite_differences(name, isa):
    n, subs, rad, fixed, grid, m, b = FD_CASES[name]
    step = 1e-6
    x, rng = smooth_points(n, m, subs, rad, fixed, b, margin=20 * step, grid=grid)
    w = kernels_for(rng, len(subs), b, scale=0.2)
    G = rng.normal(size=x.shape)
    gx, gk = _core.layer_backward(x, w, subs, rad, EPS, fixed, G, 1)
    y0 = _core.layer_forward(x, w, subs, rad, EPS, fixed, 1)

    def loss(xx, ww):  # Σ G·(y − y0) with the wrap undone: smooth across the output seam
        return float((G * unwrapped(_core.layer_forward(xx, ww, subs, rad, EPS, fixed, 1), y0)).sum())

    fd_x = np.zeros_like(x)
    for idx in np.ndindex(*x.shape):
        xp, xm = x.copy(), x.copy()
        xp[idx] = (x[idx] + step) % 1.0  # the layer is periodic: a seam point wraps around
        xm[idx] = (x[idx] - step) % 1.0
        fd_x[idx] = (loss(xp, w) - loss(xm, w)) / (2 * step)
    fd_k = np.zeros_like(w)
    for idx in np.ndindex(*w.shape):
        wp, wm = w.copy(), w.copy()
        wp[idx] += 1e-4
        wm[idx] -= 1e-4
        fd_k[idx] = (loss(x, wp) - loss(x, wm)) / 2e-4

    ex = np.linalg.norm(gx - fd_x) / np.linalg.norm(fd_x)
    ek = np.linalg.norm(gk - fd_k) / np.linalg.norm(fd_k)
    assert ex <= 1e-6, f"{name}: grad_x relative error {ex:.3g}"
    assert ek <= 1e-6, f"{name}: grad_kernels relative error {ek:.3g}"
    # Not just the residual path: the pair terms are a sizeable part of grad_x.
    assert np.linalg.norm(gx - G) > 1e-2 * np.linalg.norm(G)
    if fixed:  # gradients reach fixed coordinates through the distances
        fixed_dims = [k for k in range(n) if (fixed >> k) & 1]
        assert np.abs(gx[:, fixed_dims] - G[:, fixed_dims]).max() > 0


torch = None


def _torch():
    global torch
    if torch is None:
        import torch as t

        torch = t
    return torch


def _layer_function():
    t = _torch()

    class CLayer(t.autograd.Function):
        """The shape of impl="c": forward and backward run the libdpc bindings."""

        @staticmethod
        def forward(ctx, x, w, subspaces, radius, eps, fixed):
            ctx.save_for_backward(x, w)
            ctx.layer = (subspaces, radius, eps, fixed)
            y = _core.layer_forward(x.detach().numpy(), w.detach().numpy(), subspaces, radius, eps, fixed, 1)
            return t.from_numpy(y)

        @staticmethod
        def backward(ctx, grad_y):
            x, w = ctx.saved_tensors
            gx, gk = _core.layer_backward(
                x.detach().numpy(), w.detach().numpy(), *ctx.layer, grad_y.contiguous().numpy(), 1
            )
            return t.from_numpy(gx), t.from_numpy(gk), None, None, None, None

    return CLayer


@pytest.mark.parametrize(
    "case",
    [
        (2, [0b11], [2.5], 0, None, 24, 6),
        (3, [0b111, 0b100], [2.0, 3.0], 0, None, 20, 5),
        (3, [0b011, 0b100], [2.0, 3.0], 0b011, (4, 4), 16, 5),
    ],
)
def test_gradcheck(case):
    t = _torch()
    n, subs, rad, fixed, grid, m, b = case
    # gradcheck perturbs inputs by 1e-6 and does not undo the wrap: stay clear of the seam, and of
    # outputs near it (checked below).
    for start in range(0, 5000, 500):
        x, rng = smooth_points(
            n, m, subs, rad, fixed, b, margin=2e-5, grid=grid, seam=False, interior=0.05, start=start
        )
        w = kernels_for(rng, len(subs), b, scale=0.2)
        y = _core.layer_forward(x, w, subs, rad, EPS, fixed, 1)
        if np.minimum(y, 1 - y).min() > 1e-3:
            break
    xt = t.tensor(x, dtype=t.float64, requires_grad=True)
    wt = t.tensor(w, dtype=t.float64, requires_grad=True)
    fn = _layer_function()
    assert t.autograd.gradcheck(
        lambda a, k: fn.apply(a, k, subs, rad, EPS, fixed), (xt, wt), eps=1e-6, atol=1e-6, rtol=1e-5
    )


# ------------------------------------------------------------------------------------------------
# Determinism and batches
# ------------------------------------------------------------------------------------------------


def _bits(a):
    return np.ascontiguousarray(a).view(np.uint64)


def _both(x, w, subs, rad, fixed, g, threads):
    y = _core.layer_forward(x, w, subs, rad, EPS, fixed, threads)
    gx, gk = _core.layer_backward(x, w, subs, rad, EPS, fixed, g, threads)
    return y, gx, gk


@pytest.mark.parametrize(
    "shape,subs,rad",
    [
        ((20000, 2), [0b11], [3.0]),  # one big set: chunks across threads
        ((2, 9000, 3), [0b011, 0b101, 0b110], [2.0, 2.0, 2.0]),  # fewer sets than threads, big sets
        ((5, 1500, 3), [0b111, 0b100], [2.0, 3.0]),  # sets across threads
    ],
)
def test_thread_count_does_not_change_bits(shape, subs, rad, isa):
    rng = np.random.default_rng(11)
    x = rng.random(shape)
    w = kernels_for(rng, len(subs), 32)
    g = rng.normal(size=shape)
    one = _both(x, w, subs, rad, 0, g, 1)
    for threads in (4, 3, 0):
        other = _both(x, w, subs, rad, 0, g, threads)
        for a, b in zip(one, other):
            assert np.array_equal(_bits(a), _bits(b)), f"threads={threads}"


@pytest.mark.parametrize(
    "shape,subs,rad,fixed",
    [
        ((3, 1024, 4), [0b1111], [2.0], 0),  # 4-D all pairs
        ((2, 700, 10), [0b1111111111, 0b11], [1.0, 3.0], 0),  # 10-D all pairs + a 2-D grid subspace
        ((2, 1500, 3), [0b111, 0b100], [2.5, 3.0], 0b001),  # 3-D grid, a fixed dimension
    ],
)
def test_vector_thread_count_does_not_change_bits(shape, subs, rad, fixed, monkeypatch):
    rng = np.random.default_rng(13)
    x = rng.random(shape)
    w = kernels_for(rng, len(subs), 32)
    g = rng.normal(size=shape)
    for isa_name in VECTOR_ISAS:
        monkeypatch.setenv("DPC_ISA", isa_name)
        one = _both(x, w, subs, rad, fixed, g, 1)
        for threads in (2, 3, 0):
            other = _both(x, w, subs, rad, fixed, g, threads)
            for a, b in zip(one, other):
                assert np.array_equal(_bits(a), _bits(b)), f"{isa_name} threads={threads}"


VECTOR_CASES = {
    # name: (n, subspaces, radius, fixed, grid shape of the fixed dims or None, count, m)
    "2d_grid": (2, [0b11], [4.0], 0, None, 2, 1024),
    "3d_grid": (3, [0b111], [2.5], 0, None, 2, 1024),
    "4d_all_pairs": (4, [0b1111], [2.0], 0, None, 2, 1024),
    "10d_all_pairs": (10, [(1 << 10) - 1], [1.0], 0, None, 2, 1024),
    "subspaces": (3, [0b011, 0b101, 0b110, 0b111], [2.5, 3.0, 2.0, 2.0], 0, None, 2, 999),
    "gridded": (3, [0b111, 0b100, 0b011], [2.0, 3.0, 1.5], 0b011, (16, 16), 1, 256),
}


@pytest.mark.skipif(not VECTOR_ISAS, reason="no vector ISA on this CPU")
@pytest.mark.parametrize("name", sorted(VECTOR_CASES))
def test_vector_paths_match_scalar(name, monkeypatch):
    n, subs, rad, fixed, grid, count, m = VECTOR_CASES[name]
    rng = np.random.default_rng(sorted(VECTOR_CASES).index(name) + 40)
    x = np.stack([seam_points(rng, m, n, grid) for _ in range(count)])
    w = kernels_for(rng, len(subs), 32)
    g = rng.normal(size=x.shape)
    monkeypatch.setenv("DPC_ISA", "scalar")
    y0, gx0, gk0 = _both(x, w, subs, rad, fixed, g, 1)
    disp0 = rc.torus_diff(y0, x)
    assert disp0.max() > 1e-4, "the layer barely moves the points: a vacuous comparison"
    for isa_name in VECTOR_ISAS:
        monkeypatch.setenv("DPC_ISA", isa_name)
        y, gx, gk = _both(x, w, subs, rad, fixed, g, 2)
        d = y - y0
        d -= np.rint(d)
        assert np.abs(d).max() <= 1e-12 * disp0.max(), f"{isa_name}: forward"
        assert np.abs(gx - gx0).max() <= 1e-12 * np.abs(gx0 - g).max(), f"{isa_name}: grad_x"
        assert np.abs(gk - gk0).max() <= 1e-12 * np.abs(gk0).max(), f"{isa_name}: grad_kernels"


def test_batch_equals_sets():
    rng = np.random.default_rng(12)
    subs, rad = [0b111, 0b100], [2.0, 3.0]
    x = rng.random((3, 500, 3))
    w = kernels_for(rng, 2, 12)
    g = rng.normal(size=x.shape)
    y, gx, gk = _both(x, w, subs, rad, 0, g, 2)
    total = None
    for c in range(3):
        yc, gxc, gkc = _both(x[c], w, subs, rad, 0, g[c], 1)
        assert np.array_equal(y[c], yc)
        assert np.array_equal(gx[c], gxc)
        total = gkc if total is None else total + gkc  # set order, as documented
    assert np.array_equal(gk, total)


# ------------------------------------------------------------------------------------------------
# Bad inputs
# ------------------------------------------------------------------------------------------------


def _good():
    rng = np.random.default_rng(2)
    return dict(
        x=rng.random((50, 3)), kernels=np.zeros((2, 8)), subspaces=[0b111, 0b100], radius=[2.0, 3.0], eps=EPS, fixed=0
    )


def _call_both(**kw):
    a = {**_good(), **kw}
    with pytest.raises(errors.InvalidArgumentError) as e1:
        _core.layer_forward(a["x"], a["kernels"], a["subspaces"], a["radius"], a["eps"], a["fixed"], 1)
    g = a.pop("grad_y", np.zeros(np.shape(a["x"])))
    with pytest.raises(errors.InvalidArgumentError) as e2:
        _core.layer_backward(a["x"], a["kernels"], a["subspaces"], a["radius"], a["eps"], a["fixed"], g, 1)
    return str(e1.value), str(e2.value)


@pytest.mark.parametrize(
    "kw,match",
    [
        (dict(x=np.full((50, 3), np.nan)), "finite and in \\[0, 1\\)"),
        (dict(x=np.ones((50, 3))), "finite and in \\[0, 1\\)"),
        (dict(x=-np.full((50, 3), 1e-9)), "finite and in \\[0, 1\\)"),
        (dict(x=np.zeros((0, 3))), "positive"),
        (dict(x=np.zeros(5)), "shape"),
        (dict(x=np.zeros((4, 65)), subspaces=[1, 2]), "dims"),
        (dict(kernels=np.full((2, 8), np.inf)), "not finite"),
        (dict(kernels=np.zeros((2, 1))), "bins"),
        (dict(kernels=np.zeros((2, 8, 1))), "shape"),
        (dict(kernels=np.zeros((3, 8))), "must agree"),
        (dict(radius=[2.0]), "must agree"),
        (dict(subspaces=[0, 4]), "nonzero"),
        (dict(subspaces=[0b1000, 4]), "nonzero"),
        (dict(subspaces=[4, 4]), "equal"),
        (dict(subspaces=[-1, 4]), "negative"),
        (dict(subspaces=[1.5, 4]), "int"),
        (dict(radius=[0.0, 3.0]), "radius"),
        (dict(radius=[-1.0, 3.0]), "radius"),
        (dict(radius=[np.inf, 3.0]), "radius"),
        (dict(radius=[np.nan, 3.0]), "radius"),
        (dict(radius=[2e6, 3.0]), "radius"),
        (dict(eps=-1e-4), "eps"),
        (dict(eps=np.nan), "eps"),
        (dict(eps=np.inf), "eps"),
        (dict(fixed=0b1000), "fixed"),
        (dict(fixed=-1), "negative"),
        (dict(fixed=2**64), "64 bits"),
    ],
)
def test_bad_inputs_raise_typed_errors(kw, match):
    m1, m2 = _call_both(**kw)
    assert re.search(match, m1), m1
    assert re.search(match, m2), m2


def test_bad_grad_y():
    a = _good()
    args = (a["x"], a["kernels"], a["subspaces"], a["radius"], a["eps"], a["fixed"])
    with pytest.raises(errors.InvalidArgumentError, match="shape of x"):
        _core.layer_backward(*args, np.zeros((49, 3)), 1)
    bad = np.zeros((50, 3))
    bad[7, 1] = np.nan
    with pytest.raises(errors.InvalidArgumentError, match="point 7, dimension 1 is not finite"):
        _core.layer_backward(*args, bad, 1)


def test_public_layer_ops_take_the_isa_as_an_argument(monkeypatch):
    """dpc.training (the public home of these ops): isa= gives the bits of DPC_ISA naming that
    path, whatever DPC_ISA says meanwhile; unknown names and paths the CPU lacks are refused."""
    from dpc import training

    rng = np.random.default_rng(21)
    x = rng.random((2, 800, 3))
    w = kernels_for(rng, 2, 16)
    g = rng.normal(size=x.shape)
    args = (x, w, [0b111, 0b011], [2.0, 3.0], EPS, 0b100)
    for isa_name in ISAS:
        monkeypatch.setenv("DPC_ISA", isa_name)
        want = _both(x, w, [0b111, 0b011], [2.0, 3.0], 0b100, g, 2)
        for other in ISAS:
            monkeypatch.setenv("DPC_ISA", other)
            got = (
                training.layer_forward(*args, threads=2, isa=isa_name),
                *training.layer_backward(*args, grad_y=g, threads=2, isa=isa_name),
            )
            for a, b in zip(want, got):
                assert np.array_equal(_bits(a), _bits(b)), (isa_name, other)
    monkeypatch.delenv("DPC_ISA")
    assert np.array_equal(training.layer_forward(*args), _core.layer_forward(*args, 1))  # defaults: 1 thread, auto
    with pytest.raises(errors.InvalidArgumentError, match="isa"):
        training.layer_forward(*args, isa="sse9")
    with pytest.raises(errors.InvalidArgumentError, match="threads"):
        training.layer_forward(*args, threads=-1)
    if not dpc.isa_supported("avx512"):
        with pytest.raises(errors.UnsupportedError, match="AVX-512"):
            training.layer_forward(*args, isa="avx512")
