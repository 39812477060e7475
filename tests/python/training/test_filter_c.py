"""impl="c" (libdpc's float64 layer kernels behind a torch.autograd.Function) against the
pure-torch reference: forward values, gradients, gradcheck, and use inside a cascade."""

import pytest
import torch

from dpc_train.filter import FilterConfigError, filter_layer, to_torus_dtype

CASES = {
    # name: (dims, subspaces, radius, fixed, bins)
    "2d": (2, [0b11], [3.0], 0, 16),
    "3d_subspaces": (3, [0b011, 0b101, 0b110], [2.5, 3.0, 2.8], 0, 12),
    "mixed": (3, [0b111, 0b100], [2.2, 3.5], 0, 10),
    "gridded": (3, [0b111], [2.4], 0b011, 14),
}


def make(case, m=96, seed=0, dtype=torch.float64):
    n, subspaces, radius, fixed, bins = CASES[case]
    g = torch.Generator().manual_seed(seed)
    x = torch.rand(2, m, n, generator=g, dtype=dtype)
    x[0, :3] = torch.tensor([1e-7, 1 - 1e-7, 0.5], dtype=dtype)[:, None].expand(3, n)  # torus seam
    k = torch.randn(len(subspaces), bins, generator=g, dtype=dtype) * 0.2
    return x, k, subspaces, radius, fixed


@pytest.mark.parametrize("case", CASES)
def test_forward_and_gradients_match_the_torch_reference(case):
    x, k, subspaces, radius, fixed = make(case)
    outs, grads = {}, {}
    for impl in ("torch", "c"):
        xi = x.clone().requires_grad_(True)
        ki = k.clone().requires_grad_(True)
        y = filter_layer(xi, ki, subspaces, radius, 1e-4, fixed, impl=impl)
        w = torch.linspace(-1, 1, y.numel(), dtype=y.dtype).reshape(y.shape)  # a generic upstream
        (y * w).sum().backward()
        outs[impl], grads[impl] = y.detach(), (xi.grad, ki.grad)
    moved = (outs["torch"] - x).abs().max()
    assert moved > 1e-3, "the layer barely moves the points: a vacuous comparison"
    assert (outs["c"] - outs["torch"]).abs().max() <= 1e-12
    assert (grads["c"][0] - grads["torch"][0]).abs().max() <= 1e-9
    assert (grads["c"][1] - grads["torch"][1]).abs().max() <= 1e-9 * max(1.0, grads["torch"][1].abs().max())


def test_gradcheck_float64():
    x, k, subspaces, radius, fixed = make("3d_subspaces", m=24, seed=3)
    x = x[:1].clamp(1e-3, 1 - 1e-3).clone().requires_grad_(True)  # finite differences stay in [0, 1)
    k = k.clone().requires_grad_(True)
    fn = lambda xx, kk: filter_layer(xx, kk, subspaces, radius, 1e-4, fixed, impl="c")  # noqa: E731
    assert torch.autograd.gradcheck(fn, (x, k), eps=1e-7, atol=1e-6, rtol=1e-5)


def test_float32_inputs_come_back_float32():
    x, k, subspaces, radius, fixed = make("2d", dtype=torch.float32)
    y = filter_layer(x, k, subspaces, radius, 1e-4, fixed, impl="c")
    assert y.dtype == torch.float32 and y.shape == x.shape
    assert float(y.max()) < 1.0 and float(y.min()) >= 0.0


def test_float64_values_that_round_to_one_in_float32_wrap_to_zero():
    y64 = torch.tensor([0.25, 1 - 1e-9, 1 - 2**-30, 0.0], dtype=torch.float64)
    assert float(y64.to(torch.float32)[1]) == 1.0  # the hazard this guards against
    y32 = to_torus_dtype(y64, torch.float32)
    assert y32.tolist() == [0.25, 0.0, 0.0, 0.0]


def test_bad_layer_is_a_typed_error():
    x, k, subspaces, radius, fixed = make("2d")
    with pytest.raises((FilterConfigError, ValueError)):
        filter_layer(x, k, [0b100], radius, 1e-4, fixed, impl="c")  # names a dimension >= n


def test_auto_is_the_c_layer_on_the_cpu_and_torch_elsewhere():
    from dpc_train.config import TrainConfig
    from dpc_train.filter import resolve_impl

    assert TrainConfig().impl == "auto", "the trainer's default is the fastest implementation"
    x, k, subspaces, radius, fixed = make("3d_subspaces")
    assert resolve_impl("auto", x) == "c"
    assert resolve_impl("auto", x.to("meta")) == "torch"  # any non-CPU device (CUDA)
    assert resolve_impl("auto", torch.rand(4, 65, dtype=torch.float64)) == "torch"  # past DPC_MAX_DIMS
    assert resolve_impl("torch", x) == "torch" and resolve_impl("c", x) == "c"
    auto = filter_layer(x, k, subspaces, radius, 1e-4, fixed, impl="auto")
    c = filter_layer(x, k, subspaces, radius, 1e-4, fixed, impl="c")
    assert torch.equal(auto, c)
