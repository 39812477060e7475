"""The Python API over libdpc: array contracts, batches, typed exceptions carrying the C message,
metadata, ISA and thread options, and the GIL being released while C runs."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import pytest

import dpc
from cpu_isa import HAVE_AVX2, HAVE_AVX512, VECTOR_ISAS  # noqa: E402,F401

DATA = Path(__file__).resolve().parents[1] / "data"
M2D = DATA / "model_2d.onnx"
GRID = DATA / "model_grid_3to1.onnx"
M10 = DATA / "model_10d.onnx"


def _is_c_float32(a: np.ndarray, shape) -> bool:
    return (
        isinstance(a, np.ndarray)
        and a.dtype == np.float32
        and a.shape == tuple(shape)
        and a.flags["C_CONTIGUOUS"]
        and a.flags["WRITEABLE"]
    )


# ---- arrays ---------------------------------------------------------------------------------


def test_generate_shapes_dtypes_contiguity():
    m = dpc.load(M2D)
    assert (m.dims, m.n_points, m.layers) == (2, 1024, 4)
    x = m.generate(0)
    assert _is_c_float32(x, (1024, 2))
    assert np.all((x >= 0) & (x < 1))
    assert _is_c_float32(m.generate(3, 100), (100, 2))
    b = m.generate_batch(3, seed=5)
    assert _is_c_float32(b, (3, 1024, 2))
    assert _is_c_float32(m.generate_batch(2, seed=5, n_points=50), (2, 50, 2))
    u = dpc.uniform(1, 7, 3)
    assert _is_c_float32(u, (7, 3))
    assert np.all((u >= 0) & (u < 1))


def test_filter_returns_a_new_array_and_accepts_any_layout():
    m = dpc.load(M2D)
    x = dpc.uniform(4, 1024, 2)
    keep = x.copy()
    y = m.filter(x)
    assert _is_c_float32(y, (1024, 2))
    assert np.array_equal(x, keep), "filter must not modify its argument"
    assert np.array_equal(y, m.generate(4)), "generate(seed) is filter(uniform(seed))"
    # Fortran order, float64 and lists are converted
    assert np.array_equal(m.filter(np.asfortranarray(x)), y)
    assert np.array_equal(m.filter(x.astype(np.float64)), y)
    assert np.array_equal(m.filter(x[:10].tolist()), m.filter(x[:10]))
    with pytest.raises(dpc.InvalidArgumentError):
        m.filter(np.zeros((10, 3), np.float32))
    with pytest.raises(dpc.InvalidArgumentError):
        m.filter(np.zeros(10, np.float32))


@pytest.mark.parametrize("scale", [1e3, 1e37])
def test_steps_past_a_period_and_overflowing_ones_stay_in_the_torus(tmp_path, scale):
    """Kernels so strong that points step several periods (1e3), or overflow to inf and NaN
    (1e37): every coordinate still ends in [0, 1) (the rare path of the layer's wrap; an
    overflowed one at 0), the same bits on every ISA path and thread count."""
    from dpc.model_file import Layer, ModelSpec, write_model

    rng = np.random.default_rng(3)
    layers = [Layer([0b11], [4.0], scale * rng.standard_normal((1, 32))) for _ in range(6)]
    path = tmp_path / "strong.onnx"
    write_model(ModelSpec(dims=2, n_points=1024, layers=layers, name="strong"), path)
    want = dpc.load(str(path), isa="scalar", threads=1).generate(seed=1, n_points=4096)
    assert np.isfinite(want).all() and (want >= 0).all() and (want < 1).all()
    assert (want != 0).any() if scale < 1e10 else (want == 0).all()
    for isa in ["scalar", *VECTOR_ISAS]:
        got = dpc.load(str(path), isa=isa, threads=2).generate(seed=1, n_points=4096)
        assert np.array_equal(got, want), isa


def test_same_seed_same_bits_and_seeds_differ():
    m = dpc.load(M2D)
    assert np.array_equal(m.generate(9), m.generate(9))
    assert not np.array_equal(m.generate(9), m.generate(10))
    # seeds are 0 .. 2^64 - 1, as in the CLI: nothing wraps silently
    assert not np.array_equal(m.generate(2**64 - 1), m.generate(0))
    for bad in (-1, 2**64, 2**64 + 3):
        with pytest.raises(dpc.InvalidArgumentError):
            m.generate(bad)
        with pytest.raises(dpc.InvalidArgumentError):
            dpc.uniform(bad, 5, 2)


@pytest.mark.parametrize("path,n", [(M2D, None), (M2D, 300), (GRID, None), (M10, 200)])
def test_batch_set_c_is_generate_of_seed_plus_c(path, n):
    m = dpc.load(path, threads=2)
    for seed in (0, 2**64 - 2):  # the second wraps to 0, 1 within the batch
        b = m.generate_batch(4, seed=seed, n_points=n)
        for c in range(4):
            assert np.array_equal(b[c], m.generate((seed + c) % 2**64, n)), f"set {c}, seed {seed}"


# ---- errors ---------------------------------------------------------------------------------


def test_missing_file_is_model_io_error(tmp_path):
    path = tmp_path / "absent.onnx"
    with pytest.raises(dpc.ModelIOError) as e:
        dpc.load(path)
    assert isinstance(e.value, OSError) and isinstance(e.value, dpc.DpcError)
    assert "absent.onnx" in str(e.value), "the C message names the file"


def test_garbage_file_is_model_format_error(tmp_path):
    path = tmp_path / "garbage.onnx"
    path.write_bytes(b"\x08\x07 this is not a protobuf model \xff\xff\xff")
    with pytest.raises(dpc.ModelFormatError) as e:
        dpc.load(path)
    assert isinstance(e.value, ValueError)
    assert str(e.value).strip(), "the exception carries the C message"


def test_truncated_file_is_model_format_error(tmp_path):
    path = tmp_path / "truncated.onnx"
    path.write_bytes(M2D.read_bytes()[:700])
    with pytest.raises(dpc.ModelFormatError, match=r"\S"):
        dpc.load(path)


def test_unknown_operator_version_is_unsupported():
    path = DATA / "malformed" / "opset_dpc_v2.onnx"
    with pytest.raises(dpc.UnsupportedError) as e:
        dpc.load(path)
    msg = str(e.value).replace(str(path), "")
    assert "2" in msg and "1" in msg, f"the message names both versions: {msg}"


def test_bad_point_counts():
    m = dpc.load(M2D)
    for bad in (0, -5):
        with pytest.raises(dpc.InvalidArgumentError):
            m.generate(0, bad)
    with pytest.raises((dpc.LimitError, dpc.InvalidArgumentError)) as e:
        m.generate(0, 2**26 + 1)
    assert str(e.value).strip()
    with pytest.raises(dpc.InvalidArgumentError):
        m.generate_batch(0, seed=1)


def test_gridded_model_rejects_other_counts():
    m = dpc.load(GRID)
    assert m.grid_axes == (0, 1) and m.grid_shape == (32, 32) and m.n_points == 1024
    with pytest.raises(dpc.DpcError) as e:
        m.generate(0, 1000)
    assert "1024" in str(e.value) or "grid" in str(e.value).lower(), str(e.value)
    with pytest.raises(dpc.DpcError):
        m.generate_batch(2, seed=0, n_points=512)
    assert m.generate(0, 1024).shape == (1024, 3)


def test_bad_options():
    with pytest.raises(dpc.InvalidArgumentError):
        dpc.load(M2D, isa="sse9")
    with pytest.raises(dpc.InvalidArgumentError):
        dpc.load(M2D, threads=-1)


def test_non_finite_points_are_rejected():
    m = dpc.load(M2D)
    x = dpc.uniform(0, 64, 2)
    x[3, 1] = np.nan
    with pytest.raises(dpc.InvalidArgumentError, match=r"\S"):
        m.filter(x)


# ---- metadata and options -------------------------------------------------------------------


def test_metadata_dict():
    m = dpc.load(M2D)
    assert m.metadata == {
        "dpc.name": "test-2d",
        "dpc.description": "Test model: 2-D repulsion/attraction cascade, one subspace.",
        "dpc.loss": "none (analytic test kernels)",
        "test.kernels": "tests/data/make_models.py",
        "dpc.format_version": "1",
        "dpc.dims": "2",
        "dpc.n_points": "1024",
    }
    assert m.name == "test-2d"
    assert "test-2d" in repr(m)
    g = dpc.load(GRID)
    assert g.metadata["dpc.grid_axes"] == "0,1" and g.metadata["dpc.grid_shape"] == "32,32"


def test_scalar_and_vector_isas_agree():
    if not VECTOR_ISAS:
        pytest.skip("this CPU runs only the scalar path (dpc.isa_supported): nothing to compare")
    for path, n in ((M2D, None), (M2D, 3000), (GRID, None), (DATA / "model_3d_mixed.onnx", None)):
        s = dpc.load(path, isa="scalar")
        assert s.isa == "scalar"
        for isa in VECTOR_ISAS:
            v = dpc.load(path, isa=isa)
            assert v.isa == isa
            for seed in (0, 1):
                a, b = s.generate(seed, n), v.generate(seed, n)
                assert np.array_equal(a, b), f"{path.name}: scalar and {isa} give other bits (dpc.h: the same)"


@pytest.mark.parametrize("isa,have", [("avx2", HAVE_AVX2), ("avx512", HAVE_AVX512)])
def test_vector_isa_request_matches_the_cpu(isa, have):
    if have:
        assert dpc.load(M2D, isa=isa).isa == isa
    else:
        with pytest.raises(dpc.UnsupportedError):
            dpc.load(M2D, isa=isa)


@pytest.mark.parametrize("path,n", [(M2D, None), (M2D, 5000), (DATA / "model_3d_proj.onnx", None), (GRID, None)])
def test_thread_count_does_not_change_bits(path, n):
    one = dpc.load(path, threads=1)
    eight = dpc.load(path, threads=8)
    assert (one.threads, eight.threads) == (1, 8)
    for seed in (0, 7):
        assert np.array_equal(one.generate(seed, n), eight.generate(seed, n))
    assert np.array_equal(one.generate_batch(3, seed=2, n_points=n), eight.generate_batch(3, seed=2, n_points=n))


# ---- the GIL --------------------------------------------------------------------------------


def test_gil_is_released_while_c_runs():
    """A Python thread keeps counting while the main thread is inside one long generate call.
    With the GIL held for the whole call the counter could not move; released, it moves a lot."""
    m = dpc.load(M2D, threads=1)
    m.generate(0, 4096)  # warm up
    # A call long enough to tell (>= 0.2 s) on however fast a machine: double the count until then.
    n = 1 << 16
    while n < (1 << 23):
        t0 = time.perf_counter()
        m.generate(0, n)
        if time.perf_counter() - t0 >= 0.2:
            break
        n *= 2
    counter = [0]
    stop = threading.Event()
    started = threading.Event()

    def count():
        started.set()
        while not stop.is_set():
            counter[0] += 1

    t = threading.Thread(target=count, daemon=True)
    t.start()
    started.wait()
    time.sleep(0.05)
    c0 = counter[0]
    t0 = time.perf_counter()
    m.generate(1, n)
    elapsed = time.perf_counter() - t0
    c1 = counter[0]
    stop.set()
    t.join()
    assert elapsed > 0.05, f"the call took only {elapsed:.3f} s: too short to tell"
    # Held GIL (checked with a C regex call that keeps it for 2.7 s): about 6e3 increments per
    # second slip through around the call. Released: the thread counts during the whole call,
    # about 5e5 per second on a 2-core machine.
    rate = (c1 - c0) / elapsed
    assert c1 - c0 > 50000 and rate > 5e4, f"counter advanced {c1 - c0} times during a {elapsed:.3f} s generate call"


def test_stratified_input_points_and_the_load_option():
    """docs/model-format.md §5: one point per cell of the largest g^n <= m grid (the leftover
    points in distinct cells), at the uniform numbers' offsets, in random order; a model loaded
    with input="stratified" filters exactly these points."""
    for m, n in [(1024, 2), (1000, 2), (3000, 3), (5, 64)]:
        x = dpc.stratified(4, m, n)
        assert x.shape == (m, n) and x.dtype == np.float32 and np.all((x >= 0) & (x < 1))
        g = 1
        while (g + 1) ** n <= m:
            g += 1
        cells = (np.minimum((x * g).astype(np.int64), g - 1) * g ** np.arange(n)).sum(axis=1)
        counts = np.bincount(cells, minlength=g**n)
        assert set(np.unique(counts)) <= {m // g**n, m // g**n + 1}, (m, n)
        np.testing.assert_allclose(x * g - np.floor(x * g), dpc.uniform(4, m, n), atol=2e-5)
    np.testing.assert_array_equal(dpc.stratified(4, 5, 64), dpc.uniform(4, 5, 64))  # no grid fits
    assert dpc.load("bnot-2d").input == "uniform"  # auto: the bundled models were trained on uniform points
    model = dpc.load("bnot-2d", input="stratified")
    assert model.input == "stratified"
    np.testing.assert_array_equal(model.generate(9), model.filter(dpc.stratified(9, model.n_points, 2)))
    batch = model.generate_batch(2, seed=9, n_points=700)
    np.testing.assert_array_equal(batch[1], model.generate(10, 700))
    with pytest.raises(dpc.InvalidArgumentError, match="input"):
        dpc.load("bnot-2d", input="sobol")
    with pytest.raises(dpc.InvalidArgumentError, match="grid"):
        dpc.load("dither-32", input="stratified")


def test_input_auto_follows_the_files_dpc_input(tmp_path):
    """input="auto" (default) is what the model was trained on: metadata dpc.input, uniform
    without it; a bad value or stratified with grid axes is a format error."""
    from dpc import model_file as mf

    layers = [mf.Layer([0b11], [3.0], -0.02 * np.ones((1, 8), dtype=np.float32))]
    paths = {}
    for tag, meta, grid in [
        ("none", {}, False),
        ("strat", {"dpc.input": "stratified"}, False),
        ("bad", {"dpc.input": "sobol"}, False),
        ("grid", {"dpc.input": "stratified"}, True),
    ]:
        ls = [mf.Layer([0b10], [3.0], -0.02 * np.ones((1, 8), dtype=np.float32), fixed=0b01)] if grid else layers
        spec = mf.ModelSpec(
            dims=2,
            n_points=64,
            layers=ls,
            name=tag,
            metadata=meta,
            **(dict(grid_axes=[0], grid_shape=[64]) if grid else {}),
        )
        paths[tag] = tmp_path / f"{tag}.onnx"
        mf.write_model(spec, paths[tag])
    assert dpc.load(paths["none"]).input == "uniform"
    strat = dpc.load(paths["strat"])
    assert strat.input == "stratified"
    np.testing.assert_array_equal(strat.generate(3), strat.filter(dpc.stratified(3, 64, 2)))
    assert dpc.load(paths["strat"], input="uniform").input == "uniform"
    with pytest.raises(dpc.ModelFormatError, match="dpc.input"):
        dpc.load(paths["bad"])
    with pytest.raises(dpc.ModelFormatError, match="grid"):
        dpc.load(paths["grid"])
