#!/usr/bin/env python3
"""Train a dpc filter cascade: python training/train.py --config training/configs/NAME.toml"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from dpc_train.config import ConfigError, load_config  # noqa: E402
from dpc_train.trainer import Trainer, TrainingError  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
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
        tr = Trainer(cfg, run_dir=a.run_dir, resume=a.resume, force=a.force,
                     progress=not a.no_progress)
        summary = tr.run()
    except (ConfigError, TrainingError, ValueError, NotImplementedError, OSError) as e:
        print(f"train.py: error: {type(e).__name__}: {e}", file=sys.stderr)
        return 2
    print(json.dumps(summary, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
