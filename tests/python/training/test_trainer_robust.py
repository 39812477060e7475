"""Trainer robustness: hyper-parameters are validated, divergence without NaN (a loss
that jumps and stays, collapsed points, an overflow inside torch) stops the run with the last
good checkpoint intact and named, and stale temporary files go on resume."""

import math
import os

import pytest
import torch

from dpc_train import trainer as TR
from dpc_train.config import ConfigError, config_from_dict, load_config
from test_trainer import TINY


def cfg_with(train=None, model=None):
    d = load_config(TINY).to_dict()
    d["train"].update(train or {})
    d["model"].update(model or {})
    return config_from_dict(d, str(TINY))


@pytest.mark.parametrize(
    "section, key, value",
    [
        ("train", "lr", math.inf),
        ("train", "lr", math.nan),
        ("train", "lr", 0.0),
        ("train", "lr", -1e-3),
        ("train", "lr_final", math.inf),
        ("train", "lr_final", 0.0),
        ("train", "diverge_factor", math.nan),
        ("train", "diverge_factor", 0.5),
        ("train", "diverge_patience", 0),
        ("train", "eval_sets", 0),
        ("train", "seed", -1),
        ("model", "eps", math.nan),
        ("model", "eps", -1.0),
        ("model", "init_sigma", 0.0),
        ("model", "init_amplitude", math.inf),
        ("model", "radius", [math.inf]),
        ("model", "radius", [0.0]),
    ],
)
def test_hyper_parameters_must_be_finite_and_positive(section, key, value):
    with pytest.raises(ConfigError, match=key):
        cfg_with(**{section: {key: value}})


def _good_run(tmp_path, steps=10):
    """A healthy run with checkpoints at steps 5 and 10."""
    tr = TR.Trainer(cfg_with({"steps": steps, "checkpoint_every": 5}), tmp_path, progress=False)
    tr.run()
    st = TR.load_checkpoint(tmp_path / TR.CHECKPOINT)
    return st["step"], st["model"]["theta"].clone(), (tmp_path / TR.CHECKPOINT).read_bytes()


@pytest.mark.parametrize("lr", [1e30, 1e38])
def test_divergence_stops_with_the_last_good_checkpoint_intact(tmp_path, lr):
    step, theta, raw = _good_run(tmp_path)
    assert step == 10
    tr = TR.Trainer(cfg_with({"steps": 40, "checkpoint_every": 5}), tmp_path, resume=True, progress=False)
    for g in tr.opt.param_groups:  # the run blows up after its good checkpoint
        g["lr"] = lr
    with pytest.raises(TR.TrainingDivergedError) as e:
        tr.run()
    msg = str(e.value)
    assert f"{tmp_path / TR.CHECKPOINT} (step 10)" in msg, msg
    assert (tmp_path / TR.CHECKPOINT).read_bytes() == raw, "the good checkpoint was overwritten"
    assert not [f for f in os.listdir(tmp_path) if f.endswith(".tmp")]


@pytest.mark.parametrize(
    "lr, expect",
    [
        (1e30, "points collapsed"),  # loss 0.39 -> 63.5 and stays, all points coincide, no NaN
        (1e38, "optimiser failed"),  # an overflow inside torch (RuntimeError)
    ],
)
def test_divergence_before_any_checkpoint_says_there_is_none(tmp_path, lr, expect):
    tr = TR.Trainer(cfg_with({"steps": 40, "checkpoint_every": 5, "lr": lr}), tmp_path, progress=False)
    with pytest.raises(TR.TrainingDivergedError) as e:
        tr.run()
    assert expect in str(e.value) and "No checkpoint was written" in str(e.value), str(e.value)
    assert not (tmp_path / TR.CHECKPOINT).exists()


def test_a_loss_jump_that_stays_stops_the_run(tmp_path):
    step, _, raw = _good_run(tmp_path)
    cfg = cfg_with({"steps": 60, "checkpoint_every": 5, "diverge_patience": 3})
    tr = TR.Trainer(cfg, tmp_path, resume=True, progress=False)
    base_loss = tr.loss_fn

    def jumped(y):  # from step 20 on the loss is 100x what it was: a jump without NaN
        out = base_loss(y)
        return out * 100.0 if tr.step >= 20 else out

    tr.loss_fn = jumped
    with pytest.raises(TR.TrainingDivergedError, match="the loss jumped") as e:
        tr.run()
    assert "(step 20)" in str(e.value), str(e.value)
    # the checkpoint of step 20 was written before the jump; none after it
    assert TR.load_checkpoint(tmp_path / TR.CHECKPOINT)["step"] == 20
    assert tr.step == 23  # patience 3: steps 21, 22, 23 above the threshold


def test_a_transient_jump_delays_the_checkpoint_but_does_not_stop(tmp_path):
    cfg = cfg_with({"steps": 30, "checkpoint_every": 5, "diverge_patience": 5})
    tr = TR.Trainer(cfg, tmp_path, progress=False)
    base_loss = tr.loss_fn

    def blip(y):  # steps 14 and 15 (0-based 13, 14) look diverged, then it recovers
        out = base_loss(y)
        return out * 100.0 if tr.step in (13, 14) else out

    tr.loss_fn = blip
    tr.run()
    st = TR.load_checkpoint(tmp_path / TR.CHECKPOINT)
    assert st["step"] == 30


def test_collapsed_detects_coinciding_points():
    g = torch.Generator().manual_seed(0)
    y = torch.rand(1, 1024, 2, generator=g)
    assert not TR.collapsed(y)
    y[0, :200] = 0.5  # 20% of the points on one spot
    assert TR.collapsed(y)
    assert TR.collapsed(torch.full((1, 64, 2), 0.25))


def test_resume_removes_stale_temporaries_and_keeps_other_files(tmp_path):
    _good_run(tmp_path)
    stale = [tmp_path / ".checkpoint.pt.abc123.tmp", tmp_path / ".loss.csv.x1.tmp"]
    for f in stale:
        f.write_bytes(b"half a checkpoint")
    mine = tmp_path / "notes.tmp"
    mine.write_text("not the trainer's")
    tr = TR.Trainer(cfg_with({"steps": 12, "checkpoint_every": 5}), tmp_path, resume=True, progress=False)
    assert sorted(tr.removed_temporaries) == sorted(stale)
    assert not any(f.exists() for f in stale)
    assert mine.exists()
    tr.run()
    assert TR.load_checkpoint(tmp_path / TR.CHECKPOINT)["step"] == 12


def test_negative_losses_do_not_look_like_a_jump(tmp_path):
    """Mask losses are below zero: a steady run must not be stopped as diverged."""
    cfg = cfg_with({"steps": 40, "checkpoint_every": 5, "diverge_patience": 3})
    tr = TR.Trainer(cfg, tmp_path, progress=False)
    base_loss = tr.loss_fn
    tr.loss_fn = lambda y: base_loss(y) - 5.0  # same gradients, loss around -4.6
    tr.run()
    assert TR.load_checkpoint(tmp_path / TR.CHECKPOINT)["step"] == 40
    tr2 = TR.Trainer(
        cfg_with({"steps": 60, "checkpoint_every": 5, "diverge_patience": 3}), tmp_path, resume=True, progress=False
    )
    tr2.loss_fn = lambda y: base_loss(y) - 5.0 + (100.0 if tr2.step >= 45 else 0.0)
    with pytest.raises(TR.TrainingDivergedError, match="the loss jumped"):
        tr2.run()
    assert TR.load_checkpoint(tmp_path / TR.CHECKPOINT)["step"] == 45
