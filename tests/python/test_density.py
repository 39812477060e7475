"""Blue noise that follows a density: dpc.density.as_density and Model.generate_density
(docs/density.md): where the points go, their spacing, determinism and bad input."""

from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from scipy.spatial import cKDTree

import dpc
from dpc.density import MAX_CELLS, as_density, image_tone
from dpc.model_file import Layer, ModelSpec, write_model


@pytest.fixture(scope="module")
def model():
    return dpc.load("bnot-2d-stratified")


def cell_counts(p, shape):
    h, w = shape
    cx = np.minimum((p[:, 0].astype(np.float64) * w).astype(int), w - 1)
    cy = np.minimum((p[:, 1].astype(np.float64) * h).astype(int), h - 1)
    return np.bincount(cy * w + cx, minlength=h * w).reshape(h, w)


def window_count_variance(p, density, k, rng, windows=4000):
    """Mean squared count error over mean expected count, square windows holding ~k points
    (white noise drawn from the density gives about 1)."""
    m = len(p)
    h, w = density.shape
    mass = density / density.sum()
    sat = np.zeros((h + 1, w + 1))
    sat[1:, 1:] = mass.cumsum(0).cumsum(1)

    def F(x, y):  # mass of [0, x) x [0, y), bilinear within cells (exact for piecewise constant)
        gx, gy = x * w, y * h
        i, j = min(int(gx), w - 1), min(int(gy), h - 1)
        fx, fy = gx - i, gy - j
        a, b, c, d = sat[j, i], sat[j, i + 1], sat[j + 1, i], sat[j + 1, i + 1]
        return a * (1 - fx) * (1 - fy) + b * fx * (1 - fy) + c * (1 - fx) * fy + d * fx * fy

    tree = cKDTree(p)
    err, exp = [], []
    for c in rng.random((windows, 2)):
        rho = density[min(int(c[1] * h), h - 1), min(int(c[0] * w), w - 1)] / density.mean()
        a = np.sqrt(k / (m * rho))
        x0, y0 = c - a / 2
        if x0 < 0 or y0 < 0 or x0 + a > 1 or y0 + a > 1:
            continue
        e = m * (F(x0 + a, y0 + a) - F(x0, y0 + a) - F(x0 + a, y0) + F(x0, y0))
        idx = tree.query_ball_point(c, a / 2 * np.sqrt(2), p=2)
        q = p[idx]
        n = np.sum((q[:, 0] >= x0) & (q[:, 0] < x0 + a) & (q[:, 1] >= y0) & (q[:, 1] < y0 + a))
        err.append((n - e) ** 2)
        exp.append(e)
    return np.mean(err) / np.mean(exp)


def test_counts_follow_a_step_and_zero_cells_stay_empty(model):
    d = np.array([[1.0, 3.0], [0.0, 4.0]])
    p = model.generate_density(d, 8000, seed=3)
    assert p.shape == (8000, 2) and p.dtype == np.float32
    assert p.min() >= 0 and p.max() < 1
    c = cell_counts(p, d.shape)
    assert c[1, 0] == 0
    np.testing.assert_allclose(c.ravel()[[0, 1, 3]], [1000, 3000, 4000], rtol=0.03)


def test_a_smooth_density_is_followed_as_closely_as_blue_noise_follows_uniform(model):
    """The count error in windows of ~16 expected points: white noise 1; the goal 0.1."""
    y, x = (np.mgrid[0:128, 0:128] + 0.5) / 128
    ramp = 0.1 + x
    p = model.generate_density(ramp, 4096, seed=1)
    rng = np.random.default_rng(0)
    assert window_count_variance(p, ramp, 16, rng) < 0.12
    white = np.random.default_rng(1).random((40000, 2))  # rejection sampling of the ramp
    white = white[np.random.default_rng(2).random(40000) * 1.1 < 0.1 + white[:, 0]][:4096]
    assert 0.7 < window_count_variance(white, ramp, 16, rng) < 1.3  # the measure itself


def test_points_keep_their_local_spacing(model):
    """Nearest-neighbour distance over the local hexagonal spacing, away from the square's edges."""
    y, x = (np.mgrid[0:64, 0:64] + 0.5) / 64
    bump = 0.05 + np.exp(-((x - 0.5) ** 2 + (y - 0.5) ** 2) / (2 * 0.2**2))
    m = 4096
    p = model.generate_density(bump, m, seed=2).astype(np.float64)
    rho = bump[(p[:, 1] * 64).astype(int), (p[:, 0] * 64).astype(int)] / bump.mean()
    nn = cKDTree(p).query(p, 2)[0][:, 1] / np.sqrt(2 / (np.sqrt(3) * m * rho))
    inner = np.all((p > 0.05) & (p < 0.95), axis=1)
    assert np.percentile(nn[inner], 1) > 0.6
    assert 0.8 < nn[inner].mean() < 0.95


def test_a_constant_density_is_as_blue_as_the_uniform_model(model):
    """Not today's bits (mirror edges instead of the torus, another order): the same quality."""
    m = 4096
    flat = model.generate_density(np.ones((8, 8)), m, seed=5).astype(np.float64)
    uni = model.generate(5, m).astype(np.float64)
    assert not np.array_equal(flat, uni)
    nn_flat = cKDTree(flat).query(flat, 2)[0][:, 1].mean()
    nn_uni = cKDTree(uni, boxsize=1).query(uni, 2)[0][:, 1].mean()
    assert abs(nn_flat / nn_uni - 1) < 0.03


def test_same_bits_for_threads_isas_and_runs():
    d = np.array([[0.5, 1, 2], [4, 0, 1]])
    ref = dpc.load("bnot-2d", isa="scalar", threads=1).generate_density(d, 3000, seed=9)
    for isa in ("scalar", "avx2", "avx512"):
        if not dpc.isa_supported(isa):
            continue
        for threads in (1, 2):
            got = dpc.load("bnot-2d", isa=isa, threads=threads).generate_density(d, 3000, seed=9)
            np.testing.assert_array_equal(got, ref, err_msg=f"{isa}, {threads} threads")
    other = dpc.load("bnot-2d").generate_density(d, 3000, seed=10)
    assert not np.array_equal(other, ref)


def test_callables_images_and_arrays_give_the_same_grid(tmp_path):
    grid = as_density(lambda x, y: 1 + x + 0 * y, resolution=4)
    np.testing.assert_allclose(grid, (1 + (np.arange(4) + 0.5) / 4)[None, :].repeat(4, 0) / 1.875, rtol=1e-6)
    assert as_density(lambda x, y: 2.0, resolution=3).shape == (3, 3)
    tone = np.array([[0, 64], [128, 255]], dtype=np.uint8)
    path = tmp_path / "t.png"
    Image.fromarray(tone).save(path)
    np.testing.assert_allclose(image_tone(path), tone / 255, atol=1e-6)
    np.testing.assert_allclose(as_density(path), tone / 255, atol=1e-6)  # bright is dense
    inv = as_density(path, invert=True, gamma=2.0)
    np.testing.assert_allclose(inv, (1 - tone / 255) ** 2, atol=1e-6)
    rgb = np.stack([tone] * 3, axis=-1)
    np.testing.assert_allclose(as_density(rgb), tone / 255, atol=1e-6)


@pytest.mark.parametrize(
    "bad, error",
    [
        (np.array([[1.0, -1.0]]), dpc.InvalidArgumentError),
        (np.array([[1.0, np.nan]]), dpc.InvalidArgumentError),
        (np.array([[1.0, np.inf]]), dpc.InvalidArgumentError),
        (np.zeros((3, 3)), dpc.InvalidArgumentError),
        (np.ones(5), dpc.InvalidArgumentError),
        (np.ones((0, 4)), dpc.InvalidArgumentError),
        (np.array([["a", "b"]]), dpc.InvalidArgumentError),
        (lambda x, y: np.ones(3), dpc.InvalidArgumentError),
        (np.broadcast_to(np.float32(1), (4097, 4096)), dpc.LimitError),
    ],
)
def test_bad_densities_raise_before_any_work(model, bad, error):
    with pytest.raises(error):
        model.generate_density(bad, 100)


def test_models_without_a_plane_filter_are_refused(tmp_path):
    with pytest.raises(dpc.UnsupportedError, match="2-D"):
        dpc.load("bnot-3d").generate_density(np.ones((2, 2)), 100)
    with pytest.raises(dpc.UnsupportedError, match="progressive"):
        dpc.load("progressive-2d").generate_density(np.ones((2, 2)), 100)
    axes = ModelSpec(dims=2, n_points=256, layers=[Layer([1, 2], [2.0, 2.0], np.zeros((2, 8), np.float32))])
    write_model(axes, tmp_path / "axes.onnx")
    with pytest.raises(dpc.UnsupportedError, match="whole"):
        dpc.load(tmp_path / "axes.onnx").generate_density(np.ones((2, 2)), 100)


def test_the_limit_matches_the_library():
    assert MAX_CELLS == dpc._core.DENSITY_MAX_CELLS


@pytest.mark.parametrize("m", [64, 1024])
def test_strong_edges_keep_their_counts_at_small_counts(model, m):
    """A bright spot (3000 : 1) and a 1 : 16 step: the filters would spread the dense side into
    the sparse one; the walls keep each side's share (mean over seeds within 3 standard errors)."""
    y, x = (np.mgrid[0:128, 0:128] + 0.5) / 128
    spot = 1 + np.where((x - 0.5) ** 2 + (y - 0.5) ** 2 < 0.02**2, 3000.0, 0.0)
    step = np.where(x < 0.5, 1.0, 16.0)
    for d, region in ((spot, spot > 100), (step, x < 0.5)):
        share = []
        for seed in range(12):
            c = np.minimum((model.generate_density(d, m, seed=seed) * 128).astype(int), 127)
            share.append(region[c[:, 1], c[:, 0]].mean())
        want = d[region].sum() / d.sum()
        assert abs(np.mean(share) - want) < max(3 * np.std(share) / np.sqrt(12), 0.01), (np.mean(share), want)


@pytest.mark.parametrize("ratio", [8.0, 16.0])
def test_a_strong_edge_leaves_no_seam(model, ratio):
    """A 1 : 8 and a 1 : 16 step: the strips one local hexagonal spacing wide on either side of
    the edge hold their expected counts (a wall is a mirror: without it the sparse side lines up
    along the edge, 1.3-1.4 times its count)."""
    y, x = (np.mgrid[0:128, 0:128] + 0.5) / 128
    d = np.where(x < 0.5, 1.0, ratio)
    m, seeds = 4096, 6
    rho_lo, rho_hi = 2.0 / (1.0 + ratio), 2.0 * ratio / (1.0 + ratio)
    hex_lo, hex_hi = (np.sqrt(2.0 / (np.sqrt(3.0) * m * r)) for r in (rho_lo, rho_hi))
    lo = hi = 0
    for seed in range(seeds):
        p = model.generate_density(d, m, seed=seed).astype(np.float64)
        lo += np.sum((p[:, 0] >= 0.5 - hex_lo) & (p[:, 0] < 0.5))
        hi += np.sum((p[:, 0] >= 0.5) & (p[:, 0] < 0.5 + hex_hi))
    assert 0.85 < lo / (seeds * m * rho_lo * hex_lo) < 1.15
    assert 0.85 < hi / (seeds * m * rho_hi * hex_hi) < 1.15


@pytest.mark.parametrize("kind", ["constant", "ramp"])
def test_the_count_holds_up_to_the_square_s_sides(model, kind):
    """The sides are glide mirrors: strips along the four sides a quarter of the local spacing
    wide, from the side inwards, hold their expected counts (plain mirrors held the points nearest
    a side in a row: the first strip empty, the next ones twice their count or more)."""
    d = np.ones((8, 8)) if kind == "constant" else 0.1 + (np.mgrid[0:64, 0:64][1] + 0.5) / 64
    rho = d / d.mean()
    m, seeds = 4096, 4
    strips, want = np.zeros(5), 0.0
    for seed in range(seeds):
        p = model.generate_density(d, m, seed=seed).astype(np.float64)
        c = np.minimum((p * len(d)).astype(int), len(d) - 1)
        h = 1.0 / np.sqrt(m * rho[c[:, 1], c[:, 0]])
        gap = np.minimum(np.minimum(p[:, 0], 1 - p[:, 0]), np.minimum(p[:, 1], 1 - p[:, 1])) / h
        strips += np.histogram(gap, bins=5, range=(0, 1.25))[0]
        want += sum(m * np.mean(side * 0.25 / np.sqrt(m * side)) for side in (rho[:, 0], rho[:, -1], rho[0], rho[-1]))
    assert np.all(np.abs(strips / want - 1) < 0.4), strips / want


@pytest.mark.parametrize("ratio", [8.0, 16.0])
def test_a_straight_wall_holds_no_row_beside_it(model, ratio):
    """A long straight wall is a glide mirror: on the dense side of a 1 : 8 and a 1 : 16 step,
    strips a quarter of the local spacing wide from the edge hold their expected counts (a plain
    mirror held none in the first and about 2.5 times in the second)."""
    y, x = (np.mgrid[0:128, 0:128] + 0.5) / 128
    d = np.where(x < 0.5, 1.0, ratio)
    m, seeds = 4096, 6
    rho = 2.0 * ratio / (1.0 + ratio)
    hexd = np.sqrt(2.0 / (np.sqrt(3.0) * m * rho))
    strips = np.zeros(4)
    for seed in range(seeds):
        p = model.generate_density(d, m, seed=seed).astype(np.float64)
        mid = (p[:, 1] > 0.1) & (p[:, 1] < 0.9)  # away from the corners with the sides
        strips += np.histogram((p[mid, 0] - 0.5) / hexd, bins=4, range=(0, 1))[0]
    strips /= seeds * 0.8 * m * rho * 0.25 * hexd
    assert np.all(np.abs(strips - 1) < 0.5), strips


def _parity_densities():
    y, x = (np.mgrid[0:64, 0:64] + 0.5) / 64
    return {
        "ramp with an 8x block": (0.3 + x + 0.5 * y) * np.where((x > 0.7) & (y < 0.3), 8.0, 1.0),
        "steep, no wall": np.exp(5.0 * x),  # neighbours within 4x, pairs in reach more than 2x apart
        "zero disc, 1:16 step": np.where((x - 0.3) ** 2 + (y - 0.5) ** 2 < 0.04, 0.0, np.where(x < 0.6, 1.0, 16.0)),
    }


@pytest.mark.parametrize("name", list(_parity_densities()))
@pytest.mark.parametrize("seed", [0, 4])
def test_libdpc_matches_the_float64_reference_of_the_definition(seed, name):
    """lab/density/reference.py writes docs/density.md's definition in float64 numpy; libdpc's
    float32 engine (mirror images at the sides and walls, harmonic or smaller pair spacing, steps
    stopped at walls) agrees to float rounding on the 4-layer test model."""
    from lab.density import reference

    d = _parity_densities()[name]
    path = Path(__file__).resolve().parents[2] / "tests" / "data" / "model_2d.onnx"
    want = reference.generate(path, d, 1500, seed=seed)
    got = dpc.load(path).generate_density(d, 1500, seed=seed).astype(np.float64)
    assert np.abs(got - want).max() < 1e-5
    assert np.abs(want - reference.input_points(dpc.load(path), d, seed, 1500)).max() > 1e-3  # it moved


def test_a_vulkan_model_follows_a_density_on_the_cpu_with_the_same_bits():
    try:
        gpu = dpc.load("bnot-2d", backend="vulkan")
    except dpc.UnsupportedError as e:
        pytest.skip(f"no Vulkan device: {e}")
    d = np.array([[1.0, 2.0], [3.0, 4.0]])
    np.testing.assert_array_equal(gpu.generate_density(d, 2000, 1), dpc.load("bnot-2d").generate_density(d, 2000, 1))
