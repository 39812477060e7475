"""Export: model file via dpc.model_file, the onnx.reference oracle, and the standard-ops variant
in stock onnxruntime, each against the torch cascade."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import onnx
import pytest
import torch

from dpc.model_file import read_model
from dpc_train import export as EX
from dpc_train import trainer as TR
from dpc_train.config import config_from_dict, load_config
from onnx_reference import PointFilter

REPO = Path(__file__).resolve().parents[3]
TINY = REPO / "training" / "configs" / "tiny-test.toml"

GRIDDED_3D = {
    "pattern": {"name": "grid3d-test", "dims": 3, "points": 49, "grid_axes": [0, 1], "grid_shape": [7, 7]},
    "model": {
        "layers": 3,
        "unique_kernels": 2,
        "bins": 6,
        "subspaces": ["xyz", "z"],
        "radius": [2.0, 3.0],
        "init": "zero",
    },
    "loss": {"source": "def loss(X):\n    return l1(radspec(z(X), nu_max=2.0))\n"},
    "train": {"steps": 1, "batch": 1},
}


def torus_err(a, b):
    d = np.abs(np.asarray(a, np.float64) - np.asarray(b, np.float64))
    return np.minimum(d, 1 - d).max()


@pytest.fixture(scope="module")
def trained_tiny(tmp_path_factory):
    d = tmp_path_factory.mktemp("run")
    cfg = load_config(TINY)
    cfg.train.steps = 3
    TR.Trainer(cfg, d, progress=False).run()
    return d / TR.CHECKPOINT


@pytest.fixture(scope="module")
def gridded_ckpt(tmp_path_factory):
    d = tmp_path_factory.mktemp("grid")
    tr = TR.Trainer(config_from_dict(GRIDDED_3D), d, progress=False)
    with torch.no_grad():  # non-trivial kernels in both subspaces
        tr.model.theta.copy_(0.1 * torch.randn(tr.model.theta.shape, generator=torch.Generator().manual_seed(0)))
    TR.save_checkpoint(d / TR.CHECKPOINT, tr.state())
    return d / TR.CHECKPOINT


def torch_cascade(ckpt, x):
    model, _ = TR.cascade_from_checkpoint(TR.load_checkpoint(ckpt))
    with torch.no_grad():
        return model(torch.as_tensor(x, dtype=torch.float64)).numpy()


def inputs(ckpt, batch, m=None, seed=1):
    model, _ = TR.cascade_from_checkpoint(TR.load_checkpoint(ckpt))
    return model.input_points(batch, torch.Generator().manual_seed(seed), m=m).numpy()


def test_cli_export_and_metadata(trained_tiny, tmp_path):
    out = tmp_path / "tiny.onnx"
    res = subprocess.run(
        [sys.executable, str(REPO / "training" / "export.py"), str(trained_tiny), "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert res.returncode == 0, res.stderr
    spec = read_model(out)
    assert spec.dims == 2 and spec.n_points == 64 and len(spec.layers) == 4 and spec.name == "tiny-test"
    meta = spec.metadata
    assert meta["dpc.train.steps"] == "3"
    assert "eval_loss" in json.loads(meta["dpc.quality"])
    assert json.loads(meta["dpc.config"])["model"]["layers"] == 4
    assert meta["dpc.loss"].startswith("registered:radspec")
    assert meta["dpc.input"] == "uniform"  # the input points it was trained on
    st = TR.load_checkpoint(trained_tiny)
    for i, layer in enumerate(spec.layers):
        assert np.array_equal(layer.kernels, st["tables"][i].numpy())
    onnx.checker.check_model(onnx.load(str(out)))


@pytest.mark.parametrize("which", ["tiny", "gridded"])
def test_reference_evaluator_matches_torch(which, trained_tiny, gridded_ckpt, tmp_path):
    from onnx.reference import ReferenceEvaluator

    ckpt = trained_tiny if which == "tiny" else gridded_ckpt
    out = tmp_path / "m.onnx"
    EX.export(ckpt, out)
    sess = ReferenceEvaluator(str(out), new_ops=[PointFilter])
    for batch in (None, 3):
        x = inputs(ckpt, batch or 1)
        x = x[0] if batch is None else x
        (y,) = sess.run(None, {"points": x})
        ref = torch_cascade(ckpt, x)
        assert y.shape == x.shape and y.dtype == np.float32
        assert torus_err(y, ref) <= 1e-5
        assert torus_err(y, x) > 1e-3  # the model really moves points
        if which == "gridded":
            assert np.array_equal(y[..., :2], x[..., :2])


@pytest.mark.parametrize("which", ["tiny", "gridded"])
def test_standard_ops_in_onnxruntime_matches_torch(which, trained_tiny, gridded_ckpt, tmp_path):
    import onnxruntime as ort

    ckpt = trained_tiny if which == "tiny" else gridded_ckpt
    out = tmp_path / "m.onnx"
    ms = [None] if which == "gridded" else [None, 100]  # scale-aware: other point counts too
    for batched in (False, True):
        std = tmp_path / f"m_std_{batched}.onnx"
        EX.export(ckpt, out, standard_ops=str(std), batched=batched)
        proto = onnx.load(str(std))
        assert proto.ir_version <= 10 and all(n.domain == "" for n in proto.graph.node)
        sess = ort.InferenceSession(str(std), providers=["CPUExecutionProvider"])
        for m in ms:
            x = inputs(ckpt, 2, m=m)
            ref = torch_cascade(ckpt, x)
            if batched:
                (y,) = sess.run(None, {"points": x})
                assert torus_err(y, ref) <= 1e-5
            else:
                (y0,) = sess.run(None, {"points": x[0]})
                assert torus_err(y0, ref[0]) <= 1e-5


@pytest.mark.parametrize("which", ["tiny", "gridded"])
def test_libdpc_runs_exported_model_like_torch(which, trained_tiny, gridded_ckpt, tmp_path):
    """The exported file, loaded by libdpc (the compiled `dpc` package), filters like torch."""
    import dpc

    ckpt = trained_tiny if which == "tiny" else gridded_ckpt
    out = tmp_path / "m.onnx"
    EX.export(ckpt, out)
    model = dpc.load(out, isa="scalar", threads=1)
    for seed in (0, 7):
        x = dpc.uniform(seed, model.n_points, model.dims)
        if which == "gridded":  # format §5: gridded dims hold cell centres
            x = inputs(ckpt, 1)[0]
        y = model.filter(x)
        assert torus_err(y, torch_cascade(ckpt, x)) <= 1e-5
        if which == "tiny":
            assert np.array_equal(model.generate(seed), y)  # generate = filter(uniform(seed))


PROGRESSIVE = {
    "pattern": {"name": "progressive-test", "dims": 2, "points": 100},
    "model": {
        "layers": 3,
        "unique_kernels": 2,
        "bins": 8,
        "subspaces": ["xy"],
        "radius": [3.0],
        "init": "repulsion",
        "input": "stratified",
        "order": "progressive",
        "progressive_base": 8,
    },
    "loss": {"source": "def loss(X):\n    return l1(radspec(prefix(X, 32), nu_max=2.0))\n"},
    "train": {"steps": 2, "batch": 1},
}


def test_progressive_export_runs_in_libdpc_like_torch(tmp_path):
    """A progressive cascade (format §6): torch's level-by-level forward on the levels' inputs
    (seed + level * golden), each level then in its order, is what libdpc generates from the
    exported file, and the file says it is progressive; the standard-ops variant is refused."""
    import dpc
    from dpc_train.cascade import GOLDEN, progressive_levels

    tr = TR.Trainer(config_from_dict(PROGRESSIVE), tmp_path / "run", progress=False)
    tr.run()
    out = tmp_path / "p.onnx"
    EX.export(tmp_path / "run" / TR.CHECKPOINT, out)
    model = dpc.load(out, isa="scalar", threads=1)
    assert (model.order, model.progressive_base) == ("progressive", 8)
    for seed, m in [(0, 100), (5, 37)]:
        levels = progressive_levels(m, 8)
        x = np.concatenate([dpc.stratified((seed + j * GOLDEN) % (1 << 64), a, 2) for j, (_, a) in enumerate(levels)])
        with torch.no_grad():
            want = tr.model(torch.from_numpy(x.astype(np.float64))[None])[0].numpy()
        # libdpc's last step orders each level (§6); torch's forward keeps the input order
        assert torus_err(model.generate(seed, m), dpc.stratify.order_levels(want, 8)) <= 1e-5
    with pytest.raises(ValueError, match="progressive"):
        EX.export(tmp_path / "run" / TR.CHECKPOINT, tmp_path / "q.onnx", standard_ops=str(tmp_path / "q-std.onnx"))
