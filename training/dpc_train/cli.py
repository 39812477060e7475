"""The training commands: ``dpc-train`` and ``dpc-export`` (console scripts of the
deep-point-correlation distribution; ``python training/train.py`` and
``python training/export.py`` in a checkout run the same functions)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def train_main(argv=None) -> int:
    """Train a dpc filter cascade: dpc-train --config training/configs/NAME.toml"""
    from .config import ConfigError, load_config
    from .trainer import Trainer, TrainingError

    ap = argparse.ArgumentParser(prog="dpc-train", description=train_main.__doc__)
    ap.add_argument("--config", required=True, help="TOML config (training/configs/*.toml)")
    ap.add_argument("--run-dir", help="run folder (default: [train] run_dir / pattern name)")
    ap.add_argument("--resume", action="store_true", help="continue from the run's checkpoint")
    ap.add_argument("--force", action="store_true", help="overwrite an existing run")
    ap.add_argument("--steps", type=int, help="override [train] steps")
    ap.add_argument("--device", help="override [train] device (cpu, cuda, cuda:1)")
    ap.add_argument("--no-progress", action="store_true", help="no progress bar")
    a = ap.parse_args(argv)
    try:
        cfg = load_config(a.config)
        if a.steps is not None:
            cfg.train.steps = a.steps
        if a.device:
            cfg.train.device = a.device
        tr = Trainer(cfg, run_dir=a.run_dir, resume=a.resume, force=a.force, progress=not a.no_progress)
        summary = tr.run()
    except (ConfigError, TrainingError, ValueError, NotImplementedError, OSError) as e:
        print(f"{ap.prog}: error: {type(e).__name__}: {e}", file=sys.stderr)
        return 2
    print(json.dumps(summary, indent=2))
    return 0


def export_main(argv=None) -> int:
    """Export a training checkpoint as a dpc model file:

    dpc-export runs/NAME/checkpoint.pt -o models/NAME.onnx [--standard-ops F.onnx]
    """
    from .export import export

    ap = argparse.ArgumentParser(
        prog="dpc-export", description=export_main.__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("checkpoint", help="runs/NAME/checkpoint.pt")
    ap.add_argument("-o", "--output", required=True, help="model file to write (.onnx)")
    ap.add_argument(
        "--standard-ops", metavar="FILE", help="also write a plain-ONNX variant (standard operators, dense all pairs)"
    )
    ap.add_argument("--batched", action="store_true", help="standard-ops variant takes [batch, m, n] instead of [m, n]")
    ap.add_argument("--name", help="pattern name stored in the model (default: config's)")
    a = ap.parse_args(argv)
    if not Path(a.checkpoint).is_file():
        print(f"{ap.prog}: error: checkpoint {a.checkpoint} not found", file=sys.stderr)
        return 2
    try:
        summary = export(a.checkpoint, a.output, standard_ops=a.standard_ops, name=a.name, batched=a.batched)
    except (ValueError, KeyError, OSError) as e:
        print(f"{ap.prog}: error: {type(e).__name__}: {e}", file=sys.stderr)
        return 2
    print(json.dumps(summary, indent=2))
    return 0


def _console(main) -> int:
    """A console script's entry: a clear message when the train extra is missing."""
    try:
        return main()
    except ModuleNotFoundError as e:
        if e.name in ("torch", "onnx"):
            print(
                f"{e.name} is not installed: the training commands need the train extra "
                "(pip install 'deep-point-correlation[train]'; CPU torch first, see docs/training.md)",
                file=sys.stderr,
            )
            return 2
        raise


def train() -> None:
    """Console script ``dpc-train``."""
    sys.exit(_console(train_main))


def export() -> None:
    """Console script ``dpc-export``."""
    sys.exit(_console(export_main))
