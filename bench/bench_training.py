"""Training speed: steps/s of the real training step (forward through the cascade, loss,
backward, Adam) for the bnot-2d configuration (40 layers, batch 4, 2-D, rho = 4), at m = 1,024
and 4,096, with the pure-torch op and with libdpc's C kernels (impl="c"), on 1 and 2 threads.

    python bench/bench_training.py          # prints a table, writes the "Training" section of docs/performance.md

Median of timed steps after one warm-up step. Needs torch (pip install .[train]).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "training"))

import torch  # noqa: E402

from dpc_train.config import load_config  # noqa: E402
from dpc_train.trainer import Trainer  # noqa: E402


def time_steps(m: int, impl: str, threads: int, steps: int) -> float:
    cfg = load_config(ROOT / "training" / "configs" / "bnot-2d.toml")
    cfg.pattern.points = m
    cfg.train.impl = impl
    cfg.train.threads = threads
    with tempfile.TemporaryDirectory() as run_dir:
        trainer = Trainer(cfg, run_dir=run_dir, progress=False)
        trainer.train_step()  # warm-up
        times = []
        for _ in range(steps):
            t0 = time.perf_counter()
            trainer.train_step()
            trainer.step += 1
            times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=5, help="timed steps per case (default 5)")
    ap.add_argument("--out", default=str(ROOT / "docs" / "performance.md"))
    args = ap.parse_args()
    cases = [(1024, "torch", 1), (1024, "c", 1), (1024, "c", 2), (4096, "torch", 1), (4096, "c", 1), (4096, "c", 2)]
    lines = ["## Training", "",
             "Measured by `python bench/bench_training.py`: median seconds per training step of the "
             "bnot-2d configuration (40 layers, 10 unique kernels, 32 bins, rho = 4 spacings, batch 4, "
             "radial-spectrum loss up to nu = 4, Adam), after one warm-up step.", "",
             "| m | op | threads | s/step | steps/s |", "|---:|---|---:|---:|---:|"]
    best = 0.0
    for m, impl, threads in cases:
        steps = args.steps if impl == "c" else max(2, args.steps // 2)
        t = time_steps(m, impl, threads, steps)
        if m == 1024:
            best = max(best, 1 / t)
        lines.append(f"| {m:,} | {impl} | {threads} | {t:.3f} | {1 / t:.2f} |")
        print(lines[-1], flush=True)
    lines += ["", f"Load average while measuring: {os.getloadavg()[0]:.2f} (1 min) on {os.cpu_count()} CPUs. "
              f"Goal (issue 3): >= 4 steps/s at m = 1,024 on this 2-core machine: best measured "
              f"{best:.2f} steps/s, {'met' if best >= 4 else '**not met**'}.", ""]
    section = "\n".join(lines)
    out = Path(args.out)
    old = out.read_text() if out.exists() else "# Performance\n"
    if "\n## Training" in old:
        old = old[:old.index("\n## Training")]
    out.write_text(old.rstrip("\n") + "\n\n" + section)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
