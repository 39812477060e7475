"""The backend choice from Python: ``dpc.load(..., backend="auto"|"cpu"|"vulkan")``, ``model.backend``
and ``model.device``; typed errors; and, where a Vulkan device exists (lavapipe in CI), the Vulkan
backend against the CPU backend on every test model. Tests that need a device skip, saying why,
when the package was built without the Vulkan backend or the machine has no device (they fail
instead when DPC_TEST_REQUIRE_VULKAN=1, as tests/run_all.sh sets after installing lavapipe)."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import numpy as np
import pytest

import dpc

DATA = Path(__file__).resolve().parents[1] / "data"
MODELS = ["model_2d", "model_3d_proj", "model_3d_mixed", "model_grid_3to1", "model_10d"]
TOL = 1e-4  # Vulkan vs CPU, float32 on both sides


def _torus_diff(a: np.ndarray, b: np.ndarray) -> float:
    d = np.abs(a.astype(np.float64) - b.astype(np.float64))
    return float(np.max(np.minimum(d, 1.0 - d)))


def _load_vulkan(path):
    """The model on the Vulkan backend, or a skip that says why there is none."""
    try:
        return dpc.load(path, backend="vulkan")
    except dpc.UnsupportedError as e:
        if os.environ.get("DPC_TEST_REQUIRE_VULKAN") == "1":  # run_all.sh installs lavapipe
            pytest.fail(f"DPC_TEST_REQUIRE_VULKAN=1 but the Vulkan backend cannot run: {e}")
        if "built without the Vulkan backend" in str(e):
            pytest.skip(f"this dpc package was built without the Vulkan backend: {e}")
        pytest.skip(f"no usable Vulkan device: {e}")


# ---- the choice (any build, any machine) ------------------------------------------------------


def test_cpu_backend_is_always_there():
    m = dpc.load(DATA / "model_2d.onnx", backend="cpu")
    assert m.backend == "cpu"
    assert m.device == "cpu"
    assert "backend='cpu'" in repr(m)
    assert np.array_equal(m.generate(3), dpc.load(DATA / "model_2d.onnx", backend="cpu", isa=m.isa).generate(3))


def test_auto_loads_and_says_what_it_chose():
    m = dpc.load(DATA / "model_2d.onnx")  # backend="auto" is the default
    assert m.backend in ("cpu", "vulkan")
    assert m.device == "cpu" if m.backend == "cpu" else m.device not in ("", "cpu")
    x = m.generate(0)
    assert x.shape == (1024, 2) and x.dtype == np.float32


def test_unknown_backend_is_an_invalid_argument():
    with pytest.raises(dpc.InvalidArgumentError, match="backend"):
        dpc.load(DATA / "model_2d.onnx", backend="gpu")
    with pytest.raises(ValueError):  # InvalidArgumentError is a ValueError too
        dpc.load(DATA / "model_2d.onnx", backend="Vulkan")


def test_explicit_vulkan_runs_or_raises_unsupported_with_the_reason():
    try:
        m = dpc.load(DATA / "model_2d.onnx", backend="vulkan")
    except dpc.UnsupportedError as e:
        msg = str(e)
        assert "Vulkan" in msg, msg
        assert "DPC_VULKAN" in msg or "device" in msg or "loader" in msg or "VK_" in msg, msg
        return
    assert m.backend == "vulkan"
    assert m.device and m.device != "cpu"


# ---- the Vulkan backend (skips without a device) ----------------------------------------------


@pytest.mark.parametrize("name", MODELS)
def test_vulkan_matches_cpu(name):
    path = DATA / f"{name}.onnx"
    vk = _load_vulkan(path)
    cpu = dpc.load(path, backend="cpu")
    counts = [None] if cpu.grid_axes else [None, 600 if cpu.dims >= 8 else 1500]
    for n in counts:
        for seed in (0, 5):
            a, b = cpu.generate(seed, n), vk.generate(seed, n)
            assert a.shape == b.shape and b.dtype == np.float32 and b.flags["C_CONTIGUOUS"]
            assert np.all((b >= 0) & (b < 1))
            assert _torus_diff(a, b) <= TOL, (name, n, seed)


def _written_model(tmp_path, name, dims, subspaces, radius, m, bins=24):
    """A 3-layer model with a smooth repulsive kernel (zero at distance 0 and at the radius)."""
    from dpc import model_file

    kernel = (-0.05 * np.sin(np.pi * np.linspace(0.0, 1.0, bins)))[None, :]
    kernels = np.repeat(kernel, len(subspaces), axis=0)
    layers = [model_file.Layer(subspaces, [radius] * len(subspaces), kernels) for _ in range(3)]
    path = tmp_path / f"{name}.onnx"
    model_file.write_model(model_file.ModelSpec(dims=dims, n_points=m, layers=layers, name=name), path)
    return path


@pytest.mark.parametrize(
    "name, dims, subspaces, radius, m",
    [
        ("grid-1d", 1, [0b1], 3.0, 2048),  # 1-D cell grid
        ("grid-4d", 4, [0b1111, 0b0011], 1.2, 4096),  # 4-D cell grid (G = 6, R = 1) and a 2-D one
        ("pairs-5d", 5, [0b11111, 0b00100], 1.5, 1024),  # all pairs, two vec4s per point; 1-D grid
        ("pairs-wide", 2, [0b11], 1e6, 512),  # radius clamped to 0.5: all pairs in 2-D
        ("pairs-split", 10, [0b1111111111], 1.0, 3000),  # all pairs over 8 partner ranges of 375
    ],
)
def test_vulkan_matches_cpu_on_other_geometries(tmp_path, name, dims, subspaces, radius, m):
    # Subspace shapes the committed test models lack: each grid dimension count 1 .. 4, and
    # all-pairs passes with more than one vec4 per point, a radius covering the torus, or a
    # partner split whose ranges are not a whole number of tiles (vk_engine.c pair_splits).
    path = _written_model(tmp_path, name, dims, subspaces, radius, m)
    vk = _load_vulkan(path)
    cpu = dpc.load(path, backend="cpu")
    for seed in (0, 9):
        a, b = cpu.generate(seed), vk.generate(seed)
        assert _torus_diff(a, dpc.uniform(seed, m, dims)) > 1e-4, "the model does not move points"
        assert _torus_diff(a, b) <= TOL, (name, seed)


def test_vulkan_filters_the_documented_inputs_and_batches_are_per_seed():
    vk = _load_vulkan(DATA / "model_3d_proj.onnx")
    x0 = dpc.uniform(11, vk.n_points, vk.dims)  # the exact input points of seed 11
    assert np.array_equal(vk.filter(x0), vk.generate(11))
    sets = vk.generate_batch(3, seed=11, n_points=500)
    assert sets.shape == (3, 500, 3)
    for c in range(3):
        assert np.array_equal(sets[c], vk.generate(11 + c, 500))


def test_vulkan_errors_are_typed():
    vk = _load_vulkan(DATA / "model_grid_3to1.onnx")
    with pytest.raises(dpc.InvalidArgumentError, match="gridded"):
        vk.generate(0, n_points=500)
    with pytest.raises(dpc.InvalidArgumentError):
        vk.filter(np.full((10, 3), 1.5, np.float32))


def test_vulkan_concurrent_calls_from_threads():
    # One model, several Python threads (the GIL is released while C runs): the model's mutex
    # serialises the device work; every thread gets its own seed's points.
    vk = _load_vulkan(DATA / "model_2d.onnx")
    expect = {s: vk.generate(s) for s in range(6)}
    got: dict[int, np.ndarray] = {}
    errors: list[BaseException] = []

    def work(s: int) -> None:
        try:
            got[s] = vk.generate(s)
        except BaseException as e:  # noqa: BLE001 (reported below)
            errors.append(e)

    threads = [threading.Thread(target=work, args=(s,)) for s in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for s in range(6):
        assert np.array_equal(got[s], expect[s]), s
