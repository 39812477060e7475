"""Cascade: depth interpolation of unique kernels, inits, gridded inputs, layer chaining."""

import math

import numpy as np
import pytest
import torch

from dpc_train.cascade import Cascade, CascadeSpec, parse_subspace, repulsion_kernel
from dpc_train.filter import FilterConfigError, filter_layer
from dpc_train.lossprog import build_loss


def test_depth_interpolation_is_piecewise_linear():
    sp = CascadeSpec(dims=2, n_points=64, layers=7, unique_kernels=3, bins=4)
    c = Cascade(sp)
    with torch.no_grad():
        c.theta.copy_(torch.arange(3 * 4, dtype=torch.float32).reshape(3, 1, 4))
    tab = c.tables()
    assert tab.shape == (7, 1, 4)
    th = c.theta.detach()
    # layer i sits at depth i·(l_u − 1)/(l − 1) = i/3 in unique-kernel units
    for i in range(7):
        p = i / 3
        lo = min(int(math.floor(p)), 1)
        f = p - lo
        assert torch.allclose(tab[i], (1 - f) * th[lo] + f * th[lo + 1], atol=1e-6)
    assert torch.equal(tab[0], th[0]) and torch.allclose(tab[-1], th[-1])
    # gradients reach every unique kernel
    tab.sum().backward()
    assert (c.theta.grad > 0).all()


def test_inits():
    sp = CascadeSpec(dims=2, n_points=64, layers=3, unique_kernels=2, bins=9, radius=[4.0])
    assert torch.count_nonzero(Cascade(sp).theta) == 0
    x = torch.rand(2, 64, 2)
    assert torch.equal(Cascade(sp)(x), x)  # zero kernels: identity cascade
    sp.init = "repulsion"
    c = Cascade(sp)
    k = repulsion_kernel(9, 4.0, sp.init_sigma, sp.init_amplitude)
    assert k[0] == -sp.init_amplitude and (k < 0).all()
    assert abs(k[2] + sp.init_amplitude * math.exp(-0.5 * (1.0 / sp.init_sigma) ** 2)) < 1e-12
    assert torch.allclose(c.theta[1, 0].double(), k, atol=1e-7)
    # repulsion spreads points: the minimum distance grows
    x = torch.rand(1, 64, 2, generator=torch.Generator().manual_seed(0), dtype=torch.float64)

    def dmin(p):
        d = p[0][None] - p[0][:, None]
        d = d - torch.floor(d + 0.5)
        return (d.norm(dim=-1) + 10 * torch.eye(64)).min()

    assert dmin(c(x)) > 2 * dmin(x)


def test_continuous_tables_end_at_zero_at_the_radius():
    """continuous = true: every layer's table ends at 0 (d = r), so a pair crossing r moves its
    points by nothing at r; the other bins train as before, the last gets no gradient."""
    sp = CascadeSpec(dims=2, n_points=64, layers=5, unique_kernels=2, bins=8, init="repulsion", continuous=True)
    c = Cascade(sp)
    tab = c.tables()
    assert torch.count_nonzero(tab[..., -1]) == 0 and (tab[..., :-1] < 0).all()
    open_tab = Cascade(CascadeSpec(dims=2, n_points=64, layers=5, unique_kernels=2, bins=8, init="repulsion")).tables()
    assert torch.equal(tab[..., :-1], open_tab[..., :-1]) and (open_tab[..., -1] < 0).all()
    tab.sum().backward()
    assert torch.count_nonzero(c.theta.grad[..., -1]) == 0 and (c.theta.grad[..., :-1] > 0).all()


def test_max_attraction_keeps_an_isolated_pair_apart():
    """max_attraction = a: table values at distance d (spacings) are at most a * d, so two points
    alone in each other's radius close at most 2a of their gap per layer; without the limit a
    kernel with g(d) = d / 2 makes them meet (the bnot-10d close pairs)."""
    b, rho = 9, 0.6  # two points: h = 2^-1/2 and r = rho h < 1/2 (the table's distances unclipped)
    d = torch.arange(b, dtype=torch.float64) * (rho / (b - 1))
    for limit, want in ((0.0, 0.0), (0.25, 0.5)):
        sp = CascadeSpec(dims=2, n_points=2, layers=2, unique_kernels=1, bins=b, radius=[rho], max_attraction=limit)
        c = Cascade(sp)
        with torch.no_grad():
            c.theta.copy_((d / 2).float()[None, None])  # g(d) = d / 2: an isolated pair meets
        tab = c.tables().detach()
        if limit:
            assert torch.all(tab <= limit * d.float() + 1e-7)
        h = 2**-0.5
        x = torch.tensor([[[0.5, 0.5], [0.5 + 0.4 * h, 0.5]]], dtype=torch.float64)  # 0.4 spacings apart
        y = filter_layer(x, tab[0].double(), sp.masks, sp.radius, sp.eps)
        gap = float((y[0, 1, 0] - y[0, 0, 0]) / h)
        assert gap == pytest.approx(want * 0.4, abs=1e-6), (limit, gap)
    with pytest.raises(FilterConfigError, match="max_attraction"):
        CascadeSpec(dims=2, n_points=64, max_attraction=-1.0)


def test_cascade_chains_filter_layers_and_grid_inputs():
    sp = CascadeSpec(
        dims=3,
        n_points=12,
        layers=3,
        unique_kernels=2,
        bins=5,
        subspaces=["xyz", "z"],
        radius=[2.0, 3.0],
        grid_axes=[0, 1],
        grid_shape=[4, 3],
    )
    c = Cascade(sp)
    with torch.no_grad():
        c.theta.normal_(0, 0.1, generator=torch.Generator().manual_seed(1))
    x = c.input_points(2, torch.Generator().manual_seed(2), dtype=torch.float64)
    # format §5: first grid axis varies fastest, cell centres
    assert torch.allclose(x[0, :, 0], torch.tensor([0.125, 0.375, 0.625, 0.875] * 3, dtype=torch.float64))
    assert torch.allclose(x[0, :, 1], torch.tensor([1 / 6] * 4 + [0.5] * 4 + [5 / 6] * 4, dtype=torch.float64))
    y = x
    for t in c.tables().double():
        y = filter_layer(y, t, sp.masks, sp.radius, sp.eps, fixed=0b011)
    assert torch.equal(c(x), y)
    assert torch.equal(c(x)[..., :2], x[..., :2])
    with pytest.raises(FilterConfigError, match="trained point count"):
        c.input_points(1, torch.Generator(), m=20)


@pytest.mark.parametrize(
    "kw, msg",
    [
        (dict(unique_kernels=5, layers=4), "unique_kernels"),
        (dict(bins=1), "bins"),
        (dict(grid_axes=[0], grid_shape=[5]), "n_points"),
        (dict(init="ones"), "init"),
        (dict(subspaces=["xy", "yx"], radius=[1.0, 1.0]), "distinct"),
        (dict(input="sobol"), "input"),
        (dict(input="stratified", grid_axes=[0], grid_shape=[64]), "grid axes"),
    ],
)
def test_bad_specs(kw, msg):
    base = dict(dims=2, n_points=64)
    base.update(kw)
    with pytest.raises(FilterConfigError, match=msg):
        CascadeSpec(**base)


def test_parse_subspace():
    assert parse_subspace("xz", 3) == 0b101 and parse_subspace([1], 2) == 2
    assert parse_subspace(3, 2) == 3
    with pytest.raises(FilterConfigError):
        parse_subspace("z", 2)


def test_loss_file_route(tmp_path):
    (tmp_path / "my_loss.py").write_text(
        "S = step_radial(M, 2, nu_max=2.0, nu0=0.5)\ndef loss(X):\n    return l2(radspec(X, nu_max=2.0), S)\n"
    )
    fn, src = build_loss({"file": "my_loss.py"}, 64, 2, base_dir=tmp_path)
    assert "step_radial" in src
    assert torch.isfinite(fn(torch.rand(2, 64, 2))) and fn(torch.rand(2, 64, 2)) > 0


def test_neighbour_cache_gives_the_fresh_search_result():
    from dpc_train.filter import NeighbourCache, _restrict, find_pairs

    sp = CascadeSpec(
        dims=2, n_points=1024, layers=12, unique_kernels=3, bins=16, radius=[3.0], init="repulsion", init_amplitude=0.2
    )
    c = Cascade(sp).double()
    x = c.input_points(2, torch.Generator().manual_seed(3), dtype=torch.float64)
    outs = {}
    for skin in (None, 0.5):
        th = c.theta.detach().clone().requires_grad_()
        c.theta = torch.nn.Parameter(th)
        y = c(x, skin=skin)
        (y * torch.arange(y.numel(), dtype=y.dtype).reshape(y.shape).cos()).sum().backward()
        outs[skin] = (y.detach(), c.theta.grad.clone())
    assert (outs[None][0] - outs[0.5][0]).abs().max() < 1e-12
    assert (outs[None][1] - outs[0.5][1]).abs().max() < 1e-9
    # the cache is reused, and after moves below skin/2 it still holds every pair within r
    cache = NeighbourCache([3], [3.0], skin=1.0)
    h = 1024**-0.5
    cache.candidates(x)
    g = torch.Generator().manual_seed(4)
    move = torch.randn(x.shape, generator=g, dtype=torch.float64)
    move = move / move.norm(dim=-1, keepdim=True) * (0.49 * h)
    x2 = (x + move) % 1.0
    cands = cache.candidates(x2)
    assert cache.builds == 1
    got = set(zip(*[t.tolist() for t in _restrict(x2, [0, 1], *cands[0], 3.0 * h, 1e-4 * h)]))
    ref = set(zip(*[t.tolist() for t in find_pairs(x2, [0, 1], 3.0 * h, 1e-4 * h)]))
    assert got == ref
    cache.candidates((x + 2 * move) % 1.0)  # moved 0.98 h > skin/2: rebuilt
    assert cache.builds == 2


def test_stratified_training_inputs_are_libdpcs():
    """[model] input = "stratified": the batch is dpc.stratified of seeds drawn from the step's
    generator, so training sees exactly what dpc.load(..., input="stratified") will feed."""
    import dpc

    sp = CascadeSpec(dims=2, n_points=64, layers=2, unique_kernels=1, bins=4, input="stratified")
    x = Cascade(sp).input_points(3, torch.Generator().manual_seed(5), dtype=torch.float64)
    seeds = torch.randint(0, 1 << 62, (3,), generator=torch.Generator().manual_seed(5)).tolist()
    for b, s in enumerate(seeds):
        assert torch.equal(x[b], torch.from_numpy(dpc.stratified(s, 64, 2)).double())
    cells = (x[0] * 8).floor().long()
    assert len({(int(i), int(j)) for i, j in cells}) == 64  # one point in each of the 8 x 8 cells


def test_init_from_a_model_reproduces_its_tables():
    """init = "model": the unique kernels are solved from the file's per-layer tables, so the
    cascade starts as exactly that model (bnot-2d-stratified: 40 layers from 10 kernels)."""
    import dpc
    from dpc.model_file import read_model

    spec = CascadeSpec(
        dims=2, n_points=1024, layers=40, unique_kernels=10, bins=32, init="model", init_model="bnot-2d-stratified"
    )
    tables = Cascade(spec).tables().detach().numpy()
    want = np.stack([L.kernels for L in read_model(dpc.model_path("bnot-2d-stratified")).layers])
    assert np.abs(tables - want).max() < 1e-6
    with pytest.raises(FilterConfigError, match="architecture"):
        Cascade(CascadeSpec(dims=2, n_points=64, layers=8, unique_kernels=2, init="model", init_model="bnot-2d"))
    with pytest.raises(FilterConfigError, match="init_model"):
        CascadeSpec(dims=2, n_points=64, init="model")
    assert np.count_nonzero(Cascade(spec, initialise=False).tables().detach().numpy()) == 0


def test_progressive_levels_and_forward_hold_earlier_levels():
    from dpc_train.cascade import progressive_levels

    assert progressive_levels(100, 16) == [(0, 16), (16, 16), (32, 32), (64, 36)]
    assert progressive_levels(10, 16) == [(0, 10)]
    spec = CascadeSpec(
        dims=2,
        n_points=64,
        layers=3,
        unique_kernels=2,
        bins=8,
        radius=[3.0],
        init="repulsion",
        order="progressive",
        progressive_base=16,
    )
    model = Cascade(spec)
    x = torch.rand(2, 64, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
    with torch.no_grad():
        y = model(x)
        first = model(x[:, :32])
    assert torch.equal(y[:, :32], first)  # the set of 32 is the prefix of the set of 64
    assert not torch.equal(y[:, 32:], x[:, 32:])  # the last level moved
