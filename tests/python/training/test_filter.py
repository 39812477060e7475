"""The torch filter layer vs an independent numpy loop of docs/model-format.md §3, gradcheck, and
the analytic (Appendix A) backward vs autograd."""

import math

import numpy as np
import pytest
import torch

from dpc_train.filter import FilterConfigError, filter_layer, find_pairs


def numpy_layer(x, kernels, subspaces, radius, eps=1e-4, fixed=0):
    """Plain double loop over (i, j), written straight from the format page."""
    x = np.asarray(x, dtype=np.float64)
    m, n = x.shape
    b = kernels.shape[1]
    total = np.zeros_like(x)
    count = np.zeros(n)
    for t, (mask, rho) in enumerate(zip(subspaces, radius)):
        dims = [k for k in range(n) if mask >> k & 1]
        count[dims] += 1
        h = m ** (-1.0 / len(dims))
        r, e = min(rho * h, 0.5), eps * h
        for i in range(m):
            for j in range(m):
                dl = x[j, dims] - x[i, dims]
                dl = dl - np.floor(dl + 0.5)
                d = math.sqrt(float(dl @ dl))
                if e < d < r:
                    u = d * (b - 1) / r
                    q = min(int(math.floor(u)), b - 2)
                    f = u - q
                    g = kernels[t, q] + f * (kernels[t, q + 1] - kernels[t, q])
                    total[i, dims] += h * g * dl / d
    y = x.copy()
    for k in range(n):
        if count[k] > 0 and not fixed >> k & 1:
            y[:, k] += total[:, k] / count[k]
    y -= np.floor(y)
    y[y >= 1.0] = 0.0
    return y


CASES = {
    # name: (m, n, subspaces, radius, fixed)
    "2d": (40, 2, [0b11], [2.5], 0),
    "3d_subspaces": (50, 3, [0b111, 0b011, 0b100], [2.0, 2.5, 3.0], 0),
    "gridded": (36, 3, [0b111, 0b100], [2.0, 3.0], 0b011),
}


def _inputs(case, dtype=torch.float64, seed=0, b=6):
    m, n, subs, rad, fixed = CASES[case]
    g = torch.Generator().manual_seed(seed)
    x = torch.rand(m, n, generator=g, dtype=dtype)
    if fixed:
        side = int(round(math.sqrt(m)))
        idx = torch.arange(m)
        x[:, 0] = ((idx % side).to(dtype) + 0.5) / side
        x[:, 1] = ((idx // side).to(dtype) + 0.5) / side
    # points near the torus seam: interactions that wrap around
    x[0, -1] = 0.002
    x[1, -1] = 0.997
    k = 0.1 * torch.randn(len(subs), b, generator=g, dtype=dtype)
    return x, k, subs, rad, fixed


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("impl", ["torch", "analytic"])
def test_forward_matches_numpy_loop(case, impl):
    x, k, subs, rad, fixed = _inputs(case)
    y = filter_layer(x, k, subs, rad, 1e-4, fixed, impl=impl).numpy()
    ref = numpy_layer(x.numpy(), k.numpy(), subs, rad, 1e-4, fixed)
    diff = np.abs(y - ref)
    diff = np.minimum(diff, 1 - diff)  # a point on the seam may wrap either way
    assert diff.max() < 1e-12
    assert np.abs(y - x.numpy()).max() > 1e-3  # the layer really moved points


def _safe(x, k, subs, rad, fixed, margin=1e-6):
    """True when no pair sits within `margin` of a kink (bin edge, eps, radius)."""
    m, n = x.shape
    b = k.shape[1]
    for mask, rho in zip(subs, rad):
        dims = [d for d in range(n) if mask >> d & 1]
        h = m ** (-1.0 / len(dims))
        r = min(rho * h, 0.5)
        dl = x[None, :, dims] - x[:, None, dims]
        dl = dl - torch.floor(dl + 0.5)
        d = dl.norm(dim=-1)
        u = d * (b - 1) / r
        off = d > 0
        if ((u[off] - torch.round(u[off])).abs() < margin * (b - 1) / r).any():
            return False
        if ((d[off] - r).abs() < margin).any():
            return False
    return True


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("impl", ["torch", "analytic"])
def test_gradcheck_float64(case, impl):
    for seed in range(20):
        x, k, subs, rad, fixed = _inputs(case, seed=seed)
        if case != "gridded":
            x = x[:24]  # gradcheck is O(inputs · cost): keep it small
        if _safe(x, k, subs, rad, fixed):
            break
    else:
        pytest.fail("no kink-free input found")
    x = x.clone().requires_grad_()
    k = k.clone().requires_grad_()
    fn = lambda xx, kk: filter_layer(xx, kk, subs, rad, 1e-4, fixed, impl=impl)  # noqa: E731
    assert torch.autograd.gradcheck(fn, (x, k), eps=1e-7, atol=1e-6, rtol=1e-5)


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_analytic_backward_matches_autograd(case, dtype):
    """float64: agreement to rounding (≤ 1e-10). float32: ≤ 1e-5 relative to the largest
    gradient entry (measured 4e-6: in 1-D subspaces d(δ/|δ|)/dδ = 0 is a difference of two
    large terms for close pairs, and float32 rounds the two formulas differently)."""
    x, k, subs, rad, fixed = _inputs(case, dtype=dtype)
    x = torch.stack([x, torch.rand(x.shape, generator=torch.Generator().manual_seed(5), dtype=dtype)])
    if fixed:
        x[1][:, :2] = x[0][:, :2]
    w = torch.randn(x.shape, generator=torch.Generator().manual_seed(7), dtype=dtype)
    grads = {}
    for impl in ("torch", "analytic"):
        xx, kk = x.clone().requires_grad_(), k.clone().requires_grad_()
        y = filter_layer(xx, kk, subs, rad, 1e-4, fixed, impl=impl)
        (y * w).sum().backward()
        grads[impl] = (y.detach(), xx.grad, kk.grad)
    for a, b in zip(grads["torch"], grads["analytic"]):
        tol = 1e-10 if dtype == torch.float64 else 1e-5 * max(1.0, b.abs().max().item())
        assert (a - b).abs().max() <= tol
    assert grads["analytic"][2].abs().max() > 1e-3  # kernels really get a gradient


def test_grid_search_equals_all_pairs():
    g = torch.Generator().manual_seed(3)
    for k_dims, m in ((1, 300), (2, 1000), (3, 1500)):
        x = torch.rand(2, m, k_dims, generator=g, dtype=torch.float64)
        r = 3.0 * m ** (-1.0 / k_dims)
        e = 1e-4 * m ** (-1.0 / k_dims)
        ii, jj = find_pairs(x, list(range(k_dims)), r, e)  # grid (m > 64, >= 3 cells)
        ref = set()
        for bi in range(2):
            dl = x[bi][None] - x[bi][:, None]
            dl = dl - torch.floor(dl + 0.5)
            d = dl.norm(dim=-1)
            a, c = ((d < r) & (d > e)).nonzero(as_tuple=True)
            ref |= set(zip((a + bi * m).tolist(), (c + bi * m).tolist()))
        got = set(zip(ii.tolist(), jj.tolist()))
        assert len(got) == len(ii)  # no duplicates
        assert got == ref


def test_zero_kernel_is_identity_and_wraps():
    x = torch.rand(3, 100, 2, dtype=torch.float64)
    k = torch.zeros(1, 8, dtype=torch.float64)
    assert torch.equal(filter_layer(x, k, [3], [3.0]), x)
    y = filter_layer(x, k - 0.3, [3], [3.0])
    assert ((y >= 0) & (y < 1)).all()


def test_unknown_impl_is_a_config_error():
    x = torch.rand(10, 2, dtype=torch.float64)
    with pytest.raises(FilterConfigError, match="impl"):
        filter_layer(x, torch.zeros(1, 4, dtype=torch.float64), [3], [2.0], impl="cuda-magic")


@pytest.mark.parametrize(
    "bad",
    [
        dict(subspaces=[4], radius=[2.0]),  # dim 2 in a 2-D set
        dict(subspaces=[3, 3], radius=[2.0, 2.0]),  # duplicate
        dict(subspaces=[3], radius=[-1.0]),
        dict(subspaces=[3], radius=[2.0, 1.0]),
    ],
)
def test_bad_layers_rejected(bad):
    with pytest.raises(FilterConfigError):
        filter_layer(torch.rand(10, 2), torch.zeros(len(bad["subspaces"]), 4), **bad)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device")
@pytest.mark.parametrize("impl", ["torch", "analytic"])
def test_cuda_matches_cpu(impl):
    x, k, subs, rad, fixed = _inputs("3d_subspaces", dtype=torch.float64)
    x = torch.cat([x, torch.rand(300, 3, dtype=torch.float64)])  # large enough for the grid path
    w = torch.randn(x.shape, dtype=torch.float64)
    out = {}
    for dev in ("cpu", "cuda"):
        xx = x.to(dev).requires_grad_()
        kk = k.to(dev).requires_grad_()
        y = filter_layer(xx, kk, subs, rad, 1e-4, fixed, impl=impl)
        (y * w.to(dev)).sum().backward()
        out[dev] = [t.detach().cpu() for t in (y, xx.grad, kk.grad)]
    for a, b in zip(out["cpu"], out["cuda"]):
        assert (a - b).abs().max() < 1e-9
