"""Loss-language blocks vs independent numpy computations, and the targets vs the authors' data."""

import math

import numpy as np
import pytest
import torch

from dpc_train import losses as L
from dpc_train import targets as T
from dpc_train.lossprog import LossConfigError, build_loss


def np_power(X, freqs):
    """Direct DFT, one frequency at a time: |Σ_k e^{2πi<q,x_k>}|²/m averaged over sets."""
    X = np.asarray(X, dtype=np.float64)
    out = []
    for q in freqs:
        s = np.exp(2j * np.pi * (X @ np.asarray(q, dtype=np.float64))).sum(-1)
        out.append((np.abs(s) ** 2 / X.shape[1]).mean())
    return np.array(out)


def test_spec_2d_matches_direct_dft():
    X = torch.rand(3, 50, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
    K = 6
    P = L.spec(X, K=K).numpy()
    freqs = [(a, b) for a in range(-K, K + 1) for b in range(-K, K + 1)]
    ref = np_power(X.numpy(), freqs).reshape(2 * K + 1, 2 * K + 1)
    ref[K, K] = 0
    assert np.abs(P - ref).max() < 1e-10


def test_spec_1d_and_3d_match_direct_dft():
    g = torch.Generator().manual_seed(1)
    X1 = torch.rand(2, 40, 1, dtype=torch.float64, generator=g)
    ref1 = np_power(X1.numpy(), [(q,) for q in range(-9, 10)])
    ref1[9] = 0
    assert np.abs(L.spec(X1, K=9).numpy() - ref1).max() < 1e-10
    X3 = torch.rand(2, 30, 3, dtype=torch.float64, generator=g)
    K = 2
    freqs = [(a, b, c) for a in range(-K, K + 1) for b in range(-K, K + 1) for c in range(-K, K + 1)]
    ref3 = np_power(X3.numpy(), freqs).reshape(5, 5, 5)
    ref3[2, 2, 2] = 0
    assert np.abs(L.spec(X3, K=K).numpy() - ref3).max() < 1e-10


def test_radspec_2d_is_floor_binned_radial_mean():
    X = torch.rand(2, 64, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(2))
    rs = L.radspec(X, nu_max=1.0).numpy()  # R = 8
    R = len(rs) - 1
    sums, cnt = np.zeros(R + 1), np.zeros(R + 1)
    for a in range(-R, R + 1):
        for b in range(-R, R + 1):
            rho = int(math.floor(math.hypot(a, b) + 1e-9))
            if rho <= R and (a, b) != (0, 0):
                sums[rho] += np_power(X.numpy(), [(a, b)])[0]
                cnt[rho] += 1
    ref = sums / np.maximum(cnt, 1)
    assert np.abs(rs - ref).max() < 1e-10


def test_radspec_3d_monte_carlo_uses_snapped_integer_frequencies():
    X = torch.rand(2, 100, 3, dtype=torch.float64, generator=torch.Generator().manual_seed(3))
    rs = L.radspec(X, nu_max=1.0, directions=8, generator=torch.Generator().manual_seed(9))
    # rebuild the same directions independently and evaluate by direct DFT
    g = torch.Generator().manual_seed(9)
    nb = len(rs)
    dirs = torch.randn(nb, 8, 3, generator=g, dtype=torch.float64)
    dirs = (dirs / dirs.norm(dim=-1, keepdim=True)).numpy()
    for rho in range(1, nb):
        qs = np.round(dirs[rho] * (rho + 0.5))
        vals = [0.0 if not q.any() else np_power(X.numpy(), [q])[0] for q in qs]
        assert abs(rs[rho].item() - np.mean(vals)) < 1e-10
        assert np.allclose(np.floor(np.linalg.norm(qs, axis=1) + 0.5), rho + 0, atol=1)


def test_white_noise_is_flat_at_one():
    X = torch.rand(16, 256, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(4))
    rs = L.radspec(X, nu_max=4.0)
    assert abs(rs[16:].mean().item() - 1.0) < 0.02
    X3 = torch.rand(8, 256, 3, dtype=torch.float64, generator=torch.Generator().manual_seed(5))
    rs3 = L.radspec(X3, nu_max=2.0, directions=64, generator=torch.Generator().manual_seed(0))
    assert abs(rs3[2:].mean().item() - 1.0) < 0.05


def test_bnot_point_sets_reproduce_bnot_radial_target():
    """The authors' 10 BNOT sets (m = 1,024) vs their radial target, ν ∈ (0, 4]."""
    X = T.load_point_sets("pcf-bnot-d2-n1024")
    assert X.shape == (10, 1024, 2)
    rs = L.radspec(X, nu_max=4.0)
    tgt = T.radial_target("bnot", 1024, 2, nu_max=4.0)
    d = (rs - tgt)[1:].abs()
    assert d.mean() < 0.02  # measured: 0.014
    rel = d / tgt[1:]
    assert rel.median() < 0.03  # measured: 0.019
    assert abs(int(rs.argmax()) - int(tgt.argmax())) <= 1  # peak at ν ≈ 1.03-1.06
    assert (rs.max() / tgt.max() - 1).abs() < 0.01  # measured: 0.007
    assert ((rs / tgt - 1)[28:40]).abs().max() < 0.06  # measured: 0.055
    # the low band agrees in absolute terms (both ≈ 0)
    assert d[: int(0.5 * 32)].max() < 0.01


def test_bnot_lowband_energy_matches_design_numbers():
    X = torch.cat([T.load_point_sets("pcf-bnot-d2-n256"), T.load_point_sets("test-pcf-bnot-d2-n256")])
    assert abs(L.lowband_energy(X, 0.5).item() - 0.0024) < 1e-4
    assert abs(L.lowband_energy(X, 0.75).item() - 0.026) < 1e-3


def test_jitter_analytic_spectrum():
    N = 16
    g = torch.Generator().manual_seed(6)
    cells = torch.stack(torch.meshgrid(torch.arange(N), torch.arange(N), indexing="ij"), -1)
    cells = cells.reshape(-1, 2).double()
    X = (cells[None] + torch.rand(400, N * N, 2, generator=g, dtype=torch.float64)) / N
    K = 24
    P = L.spec(X, K=K)
    A = T.jitter_spectrum(N * N, K)
    # 400 realisations: each P(q) is ≈ exponential with std ≈ mean, so ~5 % noise per frequency
    assert (P - A).abs().mean() < 0.05
    assert (P - A).mean().abs() < 0.005
    rs, ra = L.radspec(X, nu_max=1.5), T.jitter_radial(N * N, nu_max=1.5)
    assert (rs - ra)[1:].abs().max() < 0.1
    # and the authors' jitter radial file is the same analytic profile
    f = T.load_radial_file("jitter", 2, 1024)
    ours = T.jitter_radial(1024, nu_max=4.0)
    assert np.abs(f[1 : len(ours)] - ours[1:].numpy()).mean() < 0.02


def test_ddom_matches_direct_sum():
    X = torch.rand(2, 20, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(7))
    nc = 8
    H = L.ddom(X, nc=nc).numpy()
    sig = 2.0 / nc
    c = (np.arange(nc) + 0.5) / nc - 0.5
    ref = np.zeros((nc, nc))
    for s in X.numpy():
        for i in range(20):
            for j in range(20):
                if i == j:
                    continue
                d = s[j] - s[i]
                d = d - np.floor(d + 0.5)
                ex = c - d[0]
                ex -= np.floor(ex + 0.5)
                ey = c - d[1]
                ey -= np.floor(ey + 0.5)
                gx = np.exp(-0.5 * (ex / sig) ** 2) / (np.sqrt(2 * np.pi) * sig)
                gy = np.exp(-0.5 * (ey / sig) ** 2) / (np.sqrt(2 * np.pi) * sig)
                ref += np.outer(gx, gy)
    ref /= 2 * 20 * 19
    assert np.abs(H - ref).max() < 1e-10


def test_raddom_is_one_for_uniform_and_matches_histogram():
    X = torch.rand(8, 512, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(8))
    g = L.raddom(X, r_max=2.5, nbins=25, sigma=0.05)
    r = L.pcf_radii(2.5, 25)
    assert (g[r > 0.5] - 1).abs().mean() < 0.05
    # blue noise has an empty core
    B = T.load_point_sets("pcf-bnot-d2-n1024")
    gb = L.raddom(B, r_max=2.5, nbins=25, sigma=0.05)
    assert gb[r < 0.5].max() < 0.05 and gb.max() > 1.2
    # independent numpy evaluation on one small set
    s = X[0, :100].numpy()
    h = 100**-0.5
    d = s[None] - s[:, None]
    d = d - np.floor(d + 0.5)
    dist = np.sqrt((d**2).sum(-1))[~np.eye(100, dtype=bool)] / h
    rr = np.arange(1, 11) * 0.25
    ref = np.exp(-0.5 * ((rr[None] - dist[:, None]) / 0.05) ** 2).sum(0) / (np.sqrt(2 * np.pi) * 0.05)
    ref /= 100 * 99 * 2 * np.pi * rr * h * h
    got = L.raddom(X[0, :100], r_max=2.5, nbins=10, sigma=0.05).numpy()
    assert np.abs(got - ref).max() < 1e-9


def test_eq5_white_noise_is_one_and_gradients_flow():
    F = T.integrand_spectrum("font", 20)
    assert abs(F.sum().item() - 1) < 1e-12 and F[20, 20] == 0
    X = torch.rand(32, 256, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(9))
    assert abs(T.eq5_variance(X, F).item() - 1.0) < 0.1
    Xg = X[:2].clone().requires_grad_()
    T.eq5_variance(Xg, F).backward()
    assert torch.isfinite(Xg.grad).all() and Xg.grad.abs().max() > 0


def test_spec_gradcheck():
    X = torch.rand(2, 6, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(10))
    X.requires_grad_()
    assert torch.autograd.gradcheck(lambda x: L.radspec(x, nu_max=1.5), (X,))
    assert torch.autograd.gradcheck(lambda x: L.raddom(x, r_max=2.0, nbins=6, sigma=0.2), (X,))


def test_targets_and_metrics():
    s = T.step_radial(1024, 2, nu_max=4.0, nu0=0.8)
    assert s[1:25].abs().max() == 0 and s[26:].min() == 1
    t = T.radial_target("bnot", 1024, 2, nu_max=4.0)
    assert t[0] == 0 and len(t) == L.radial_bins(1024, 2, 4.0) == 129
    with pytest.raises(L.LossError):
        T.radial_target("bnot", 1024, 2, nu_max=100.0)
    with pytest.raises(L.LossError, match="shape mismatch"):
        L.l1(torch.zeros(3), torch.zeros(4))
    a, b = torch.tensor([1.0, 2.0]), torch.tensor([0.0, 4.0])
    assert L.l1(a, b).item() == 1.5 and L.l2(a, b).item() == 2.5
    assert L.l1(a, b, weight=torch.tensor([3.0, 1.0])).item() == pytest.approx(5 / 4)
    assert L.log_l1(a, b, eps=1.0).item() == pytest.approx(0.5 * (math.log(2) + math.log(5 / 3)))


def test_loss_programs():
    src = "T0 = radial_target('bnot', M, 2, nu_max=2)\ndef loss(X):\n    return l1(radspec(xy(X), nu_max=2) - T0)\n"
    fn, text = build_loss({"source": src}, 256, 2)
    X = T.load_point_sets("pcf-bnot-d2-n256")
    assert text == src and fn(X).item() < 0.1 < fn(torch.rand(4, 256, 2)).item()
    reg, _ = build_loss({"name": "radspec", "params": {"target": "bnot", "low_factor": 10}}, 256, 2)
    assert reg(X).item() < reg(torch.rand(4, 256, 2)).item()
    with pytest.raises(LossConfigError, match="unknown loss"):
        build_loss({"name": "nope"}, 256, 2)
    with pytest.raises(LossConfigError, match="loss\\(X\\)"):
        build_loss({"source": "x = 1"}, 256, 2)
    with pytest.raises(LossConfigError, match="exactly one"):
        build_loss({}, 256, 2)


def test_registered_radspec_uses_every_dimension():
    """[loss] name = "radspec" without axes: the radial spectrum of all n dimensions (5 here), not
    of the first 4; past the 26 axis letters it asks for axes instead of dropping dimensions."""
    X = torch.rand(2, 64, 5, generator=torch.Generator().manual_seed(1), dtype=torch.float64)
    params = {"target": "step", "nu_max": 1.0}
    values = []
    for axes in (None, "xyzwa", "xyzw"):
        fn, _ = build_loss({"name": "radspec", "params": dict(params, **({"axes": axes} if axes else {}))}, 64, 5)
        torch.manual_seed(3)  # the Monte Carlo directions of k >= 3
        values.append(float(fn(X)))
    assert values[0] == values[1] != values[2]
    with pytest.raises(LossConfigError, match="axis letters"):
        build_loss({"name": "radspec", "params": params}, 64, 30)


@pytest.mark.parametrize("name", ["bnot", "jitter"])
def test_2d_spectrum_files_radially_average_to_the_radial_files(name):
    """The authors' 2-D spectra, cropped by spectrum2d_target and floor-binned like radspec,
    give their radial files: pins the centring, the DC handling and the binning convention."""
    K = 128
    S = T.spectrum2d_target(name, 1024, K)
    assert S[K, K] == 0
    q = torch.arange(-K, K + 1, dtype=torch.float64)
    idx = torch.floor(torch.sqrt(q[:, None] ** 2 + q[None, :] ** 2) + 1e-9).long().reshape(-1)
    ok = idx <= K
    rad = torch.zeros(K + 1, dtype=torch.float64).index_add(0, idx[ok], S.reshape(-1)[ok])
    rad /= torch.bincount(idx[ok], minlength=K + 1)
    tgt = T.radial_target(name, 1024, 2, nu_max=4.0)[: K + 1]
    assert (rad - tgt)[1:].abs().max() < 1e-6


def test_radial_target_sources_and_2d_spectrum_radials():
    import numpy as np

    from dpc_train import targets as T

    step_file = T.radial_target("step", 1024, 2, nu_max=4.0, source="file")
    raw = T.load_radial_file("step", 2, 1024)
    assert torch.equal(step_file, torch.from_numpy(raw[: len(step_file)]))
    assert not torch.equal(step_file, T.radial_target("step", 1024, 2, nu_max=4.0))  # analytic ν0 = 0.8
    with pytest.raises(T.LossError):
        T.radial_target("bnot", 1024, 2, source="analytic")
    with pytest.raises(T.LossError):
        T.radial_target("bnot", 1024, 2, source="nope")
    # ring means of the stored 2-D spectrum, by an independent numpy loop
    g = T.spectrum2d_radial("pink", 1024, nu_max=1.0)
    a = np.load(T.data_dir() / "spectra" / "pink-powspec-d2-n1024.npy").astype(np.float64)
    c = a.shape[0] // 2
    for b in (1, 7, 20, len(g) - 1):
        vals = [
            a[c + i, c + j] for i in range(-b - 1, b + 2) for j in range(-b - 1, b + 2) if b <= np.hypot(i, j) < b + 1
        ]
        assert abs(float(g[b]) - np.mean(vals)) < 1e-9
    assert g[0] == 0
    with pytest.raises(T.LossError):
        T.spectrum2d_radial("green", 1024, nu_max=4.0)  # stored only to ν ≈ 1.97


def test_prefix_keeps_the_first_points_and_its_gradient():
    X = torch.rand(2, 20, 2, dtype=torch.float64, requires_grad=True)
    assert torch.equal(L.prefix(X, 8), X[:, :8])
    assert L.prefix(X[0], 5).shape == (1, 5, 2)
    with pytest.raises(L.LossError):
        L.prefix(X, 21)
    with pytest.raises(L.LossError):
        L.prefix(X, 0)
    # a loss over prefixes, as a progressive pattern's: gradient reaches only the points it sees
    assert torch.autograd.gradcheck(lambda x: L.radspec(L.prefix(x, 12), nu_max=1.5).sum(), (X,))
    L.radspec(L.prefix(X, 12), nu_max=1.5).sum().backward()
    assert torch.all(X.grad[:, 12:] == 0) and torch.any(X.grad[:, :12] != 0)
