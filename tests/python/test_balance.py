"""The output balance (docs/model-format.md §5.1): dpc.balance and the generator of a model with
metadata dpc.balance, against the float64 transcription in reference_cascade.py; its effect on a
blue-noise set (torus-scale power to rounding, the rest untouched); the radius rule; bad input;
the training config and export."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import dpc
import reference_cascade as rc
from cpu_isa import VECTOR_ISAS
from dpc import analysis

DATA = Path(__file__).resolve().parents[1] / "data"


def low_power(x: np.ndarray, k: int) -> np.ndarray:
    """|sum_j exp(-2 pi i q.x_j)|^2 / m at the frequencies 0 < |q| <= k (one half-space)."""
    return analysis.power_spectrum_direct(np.asarray(x, np.float64), rc.balance_frequencies(k, x.shape[1]))


def test_frequencies_of_the_radius():
    assert len(rc.balance_frequencies(1, 2)) == 2  # (0, 1), (1, 0)
    assert len(rc.balance_frequencies(3, 2)) == 14  # 28 lattice points with 0 < |q| <= 3, halved
    assert len(rc.balance_frequencies(1, 10)) == 10


@pytest.mark.parametrize("m,dims,radius", [(1024, 2, 3), (4096, 2, 5), (4096, 3, 2), (300, 1, 4)])
def test_balance_matches_the_float64_reference(m, dims, radius):
    x = dpc.stratified(11, m, dims)
    got = dpc.balance(x, radius)
    want = rc.balance(x, radius)
    assert got.dtype == np.float32 and got.shape == x.shape
    assert np.all((got >= 0) & (got < 1))
    assert rc.torus_diff(got, want).max() < 1e-6
    assert rc.torus_diff(got, x).max() > 1e-5  # it moved the points: not a vacuous comparison
    assert np.array_equal(got, dpc.balance(x, radius))  # deterministic
    assert low_power(got, min(radius, 3)).max() < 1e-6 * low_power(x, min(radius, 3)).max()


def test_blue_noise_set_keeps_its_spectrum_and_distances():
    x = dpc.load("bnot-2d-stratified").generate_batch(8, seed=0).astype(np.float64)
    y = np.stack([dpc.balance(s, 3) for s in x]).astype(np.float64)
    assert low_power(x.reshape(-1, 2)[:1024], 3).max() > 1e-5
    for s, t in zip(x, y):
        assert low_power(t, 3).max() < 1e-9
        assert np.hypot(*rc.torus_diff(s, t).T).max() < 0.1 / 32  # under 10 % of the mean spacing
    ex = analysis.radial_spectrum(x, nu_max=1.0)
    ey = analysis.radial_spectrum(y, nu_max=1.0)
    assert abs(ey.low_frequency_energy(0.75) - ex.low_frequency_energy(0.75)) < 0.05 * ex.low_frequency_energy(0.75)
    assert abs(analysis.min_distance(y).mean_ratio - analysis.min_distance(x).mean_ratio) < 0.01


def test_radius_shrinks_with_the_set():
    x = dpc.uniform(3, 15, 2)
    assert np.array_equal(dpc.balance(x, 3), x)  # (4 * 1)^2 > 15: no frequency
    x = dpc.stratified(3, 64, 2)
    y = dpc.balance(x, 3)  # K = 2: (12)^2 > 64
    assert low_power(y, 2).max() < 1e-3 * low_power(x, 2).max()
    assert np.array_equal(dpc.balance(x, 0), x)
    np.testing.assert_allclose(y, rc.balance(x, 3), atol=1e-6)


def test_bad_input_raises_typed_errors():
    x = dpc.uniform(1, 256, 2)
    for bad in (np.zeros((0, 2)), np.zeros(5), np.zeros((2, 2, 2))):
        with pytest.raises(dpc.InvalidArgumentError):
            dpc.balance(bad, 3)
    for v in (1.0, -0.1, np.nan):
        y = x.copy()
        y[3, 1] = v
        with pytest.raises(dpc.InvalidArgumentError, match=r"\[0, 1\)"):
            dpc.balance(y, 3)
    for r in (-1, 33, 2.5, "3"):
        with pytest.raises(dpc.InvalidArgumentError):
            dpc.balance(x, r)
    with pytest.raises(dpc.LimitError, match="frequencies"):
        dpc.balance(np.full((140608, 3), 0.5, np.float32), 13)


# ---- models ------------------------------------------------------------------------------------


def test_balanced_model_is_its_cascade_then_the_balance():
    m = dpc.load(DATA / "model_2d_balanced.onnx")
    plain = dpc.load(DATA / "model_2d.onnx")
    assert m.balance == 3 and plain.balance == 0
    ref = rc.load_reference(DATA / "model_2d_balanced.onnx")
    for seed in (0, 2**64 - 1):
        got = m.generate(seed)
        assert np.array_equal(got, dpc.balance(plain.generate(seed), 3))
        want = rc.balance(rc.generate(ref, seed), 3)
        assert rc.torus_diff(got, want).max() < 1e-5
        x0 = rc.initial_points(ref, seed, 1024)
        assert np.array_equal(m.filter(x0), plain.generate(seed))  # filter: the cascade alone
    for isa in VECTOR_ISAS:
        other = dpc.load(DATA / "model_2d_balanced.onnx", isa=isa, threads=2)
        assert np.array_equal(other.generate_batch(3, seed=5, n_points=700), m.generate_batch(3, seed=5, n_points=700))


def test_blue_2d_generates_balanced_sets():
    m = dpc.load("blue-2d")
    assert m.balance == 3 and m.metadata["dpc.balance"] == "3"
    for n in (1024, 4096):
        x = m.generate(seed=1, n_points=n)
        assert low_power(x, 3).max() < 1e-9


@pytest.mark.parametrize(
    "value,why",
    [("0", "1..32"), ("33", "1..32"), ("x", "1..32"), ("-1", "1..32"), ("3", "grid axes")],
)
def test_bad_balance_metadata_is_a_format_error(tmp_path, value, why):
    onnx = pytest.importorskip("onnx")
    base = "model_grid_3to1" if why == "grid axes" else "model_2d"  # progressive models take it: test_progressive.py
    proto = onnx.load(str(DATA / f"{base}.onnx"))
    e = proto.metadata_props.add()
    e.key, e.value = "dpc.balance", value
    path = tmp_path / "bad.onnx"
    onnx.save_model(proto, str(path))
    with pytest.raises(dpc.ModelFormatError, match=why):
        dpc.load(path)


def test_training_config_and_export():
    pytest.importorskip("torch")
    from dpc_train.cascade import CascadeSpec, FilterConfigError

    assert CascadeSpec(dims=2, n_points=64, layers=1, unique_kernels=1, balance=3).balance == 3
    progressive = CascadeSpec(dims=2, n_points=64, layers=1, unique_kernels=1, balance=2, order="progressive")
    assert progressive.balance == 2  # balanced levels (format §6)
    for bad in (dict(balance=-1), dict(balance=33), dict(balance=True)):
        with pytest.raises(FilterConfigError):
            CascadeSpec(dims=2, n_points=64, layers=1, unique_kernels=1, **bad)
    with pytest.raises(FilterConfigError):
        CascadeSpec(
            dims=3,
            n_points=64,
            layers=1,
            unique_kernels=1,
            subspaces=["z"],
            radius=[2.0],
            grid_axes=[0, 1],
            grid_shape=[8, 8],
            balance=1,
        )
