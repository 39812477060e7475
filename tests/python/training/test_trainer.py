"""Trainer: determinism, kill + resume, atomic checkpoints, NaN guard, config errors."""

import copy
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch

from dpc_train import trainer as TR
from dpc_train.config import ConfigError, config_from_dict, load_config

REPO = Path(__file__).resolve().parents[3]
TINY = REPO / "training" / "configs" / "tiny-test.toml"


def tiny(**train):
    cfg = load_config(TINY)
    for k, v in train.items():
        setattr(cfg.train, k, v)
    return cfg


def test_deterministic_per_seed(tmp_path):
    thetas = []
    for i, seed in enumerate((0, 0, 1)):
        tr = TR.Trainer(tiny(steps=6, seed=seed, checkpoint_every=3), tmp_path / f"r{i}", progress=False)
        tr.run()
        thetas.append(tr.model.theta.detach().clone())
    assert torch.equal(thetas[0], thetas[1])
    assert not torch.equal(thetas[0], thetas[2])
    run = tmp_path / "r0"
    assert (run / "loss.png").stat().st_size > 1000
    rows = (run / "loss.csv").read_text().splitlines()
    assert rows[0] == "step,loss,lr,wall_s" and len(rows) == 7
    st = TR.load_checkpoint(run / TR.CHECKPOINT)
    assert st["step"] == 6 and "eval_loss" in st["quality"]


def test_stratified_inputs_train_deterministically_and_export_their_kind(tmp_path):
    from dpc_train import export as EX

    thetas = []
    for i in range(2):
        cfg = tiny(steps=3, checkpoint_every=3)
        cfg.model.input = "stratified"
        tr = TR.Trainer(cfg, tmp_path / f"s{i}", progress=False)
        tr.run()
        thetas.append(tr.model.theta.detach().clone())
    assert torch.equal(thetas[0], thetas[1])
    uni = TR.Trainer(tiny(steps=3, checkpoint_every=3), tmp_path / "u", progress=False)
    uni.run()
    assert not torch.equal(thetas[0], uni.model.theta.detach()), "the inputs changed nothing"
    spec = EX.model_spec_from_checkpoint(TR.load_checkpoint(tmp_path / "s0" / TR.CHECKPOINT))
    assert spec.metadata["dpc.input"] == "stratified"


def test_kill_and_resume_matches_uninterrupted(tmp_path):
    steps = 40
    ref = TR.Trainer(tiny(steps=steps, checkpoint_every=5), tmp_path / "ref", progress=False)
    ref.run()

    cfg_path = tmp_path / "tiny.toml"
    cfg_path.write_text(TINY.read_text().replace("steps = 20", f"steps = {steps}"))
    run = tmp_path / "killed"
    cmd = [
        sys.executable,
        str(REPO / "training" / "train.py"),
        "--config",
        str(cfg_path),
        "--run-dir",
        str(run),
        "--no-progress",
    ]
    csv = run / "loss.csv"
    with subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) as proc:
        deadline = time.time() + 60
        while time.time() < deadline:
            if csv.exists() and len(csv.read_text().splitlines()) > 10:
                break
            time.sleep(0.02)
        assert proc.poll() is None, "the run finished before it could be killed"
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    st = TR.load_checkpoint(run / TR.CHECKPOINT)  # never corrupt
    killed_at = st["step"]
    assert 10 <= killed_at < steps and killed_at % 5 == 0
    # no leftover temp file is mistaken for a checkpoint; resuming continues from killed_at
    res = subprocess.run(cmd + ["--resume"], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    final = TR.load_checkpoint(run / TR.CHECKPOINT)
    assert final["step"] == steps
    assert torch.equal(final["model"]["theta"], ref.model.theta.detach())
    hist = final["history"]
    assert [h[0] for h in hist] == list(range(1, steps + 1))


def test_crash_during_checkpoint_keeps_previous(tmp_path, monkeypatch):
    tr = TR.Trainer(tiny(steps=4, checkpoint_every=2), tmp_path / "r", progress=False)
    tr.run()
    before = (tmp_path / "r" / TR.CHECKPOINT).read_bytes()

    def exploding_write(self, data):  # dies half-way through writing the temp file
        self.write_orig(data[: len(data) // 2])
        raise KeyboardInterrupt("simulated kill")

    import io

    class Boom(io.FileIO):
        write_orig = io.FileIO.write
        write = exploding_write

    real_fdopen = os.fdopen
    monkeypatch.setattr(TR.os, "fdopen", lambda fd, mode: Boom(fd, "wb") if "b" in mode else real_fdopen(fd, mode))
    with pytest.raises(KeyboardInterrupt):
        TR.save_checkpoint(tmp_path / "r" / TR.CHECKPOINT, {"junk": torch.zeros(1000)})
    monkeypatch.undo()
    assert (tmp_path / "r" / TR.CHECKPOINT).read_bytes() == before
    assert TR.load_checkpoint(tmp_path / "r" / TR.CHECKPOINT)["step"] == 4
    assert not list((tmp_path / "r").glob("*.tmp"))


def test_nan_guard(tmp_path):
    cfg = tiny(steps=5)
    cfg.loss = {"source": "def loss(X):\n    return (X.sum() * 0) / 0.0 * X.mean()\n"}
    tr = TR.Trainer(cfg, tmp_path / "r", progress=False)
    with pytest.raises(TR.TrainingDivergedError, match="loss is nan at step 0"):
        tr.run()


def test_existing_run_needs_resume_or_force(tmp_path):
    TR.Trainer(tiny(steps=2, checkpoint_every=1), tmp_path / "r", progress=False).run()
    with pytest.raises(TR.RunExistsError, match="--resume"):
        TR.Trainer(tiny(steps=2), tmp_path / "r", progress=False)
    assert (tmp_path / "r" / "quality.json").exists()  # the refused run touched nothing
    TR.Trainer(tiny(steps=2), tmp_path / "r", force=True, progress=False)
    # Started over: no quality.json of the old run to make the new one look finished.
    assert not (tmp_path / "r" / "quality.json").exists()


@pytest.mark.parametrize(
    "mutate, msg",
    [
        (lambda d: d["model"].update(layers=0), "layers"),
        (lambda d: d["model"].update(subspaces=["x!"]), "axis"),
        (lambda d: d["model"].update(radius=[1.0, 2.0]), "radius"),
        (lambda d: d["model"].update(bogus=1), "unknown keys"),
        (lambda d: d["train"].update(lr="fast"), "expected float"),
        (lambda d: d["train"].update(impl="cuda"), "impl"),
        (lambda d: d.pop("loss"), r"missing section \[loss\]"),
        (lambda d: d["pattern"].update(grid_axes=[0], grid_shape=[10]), "n_points"),
    ],
)
def test_bad_configs(mutate, msg):
    import tomllib

    d = tomllib.loads(TINY.read_text())
    d = copy.deepcopy(d)
    mutate(d)
    with pytest.raises(ConfigError, match=msg):
        config_from_dict(d)
