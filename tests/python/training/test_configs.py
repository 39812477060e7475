"""Every shipped training config (training/configs/*.toml) is valid and trains: a CI-sized
version of each (2 layers, batch 1, 1 step at the config's own point count, so its targets
still exist) runs through the trainer, and the loss program is finite."""

import math
from pathlib import Path

import pytest

from dpc_train import trainer as TR
from dpc_train.config import load_config

REPO = Path(__file__).resolve().parents[3]
CONFIGS = sorted((REPO / "training" / "configs").glob("*.toml"))
MODELS = REPO / "models"


def test_every_bundled_trained_model_has_its_config():
    import onnx

    for f in MODELS.glob("*.onnx"):
        meta = {p.key: p.value for p in onnx.load(str(f), load_external_data=False).metadata_props}
        if "dpc.train.steps" in meta:
            assert (REPO / "training" / "configs" / f"{f.stem}.toml").is_file(), f.name


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_config_trains_a_tiny_version(path, tmp_path):
    cfg = load_config(path)
    cfg.model.layers = 2
    if cfg.model.init == "model":  # a trained model's kernels need its own architecture
        cfg.model.init, cfg.model.init_model = "zero", ""
    cfg.model.unique_kernels = min(cfg.model.unique_kernels, 2)
    cfg.train.steps = 1
    cfg.train.batch = 1
    cfg.train.eval_sets = 1
    cfg.train.checkpoint_every = 1
    tr = TR.Trainer(cfg, tmp_path / "run", progress=False)
    tr.run()
    assert (tmp_path / "run" / "checkpoint.pt").is_file()
    hist = (tmp_path / "run" / "loss.csv").read_text().splitlines()
    assert len(hist) == 2 and math.isfinite(float(hist[1].split(",")[1]))
