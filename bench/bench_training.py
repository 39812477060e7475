"""Training speed, two tables:

1. Layer kernels: libdpc's float64 forward + backward of one PointFilter layer (dpc._core
   layer_forward / layer_backward, what impl="c" calls) for the layer geometry of bnot-2d (2-D,
   rho = 4, cell grid), bnot-4d (4-D, rho = 2, all pairs) and bnot-10d (10-D, rho = 1, all pairs):
   batch 4, m = 1,024, uniform points, per ISA path (DPC_ISA). Reported as candidate pairs/s
   (ordered pairs i != j: m (m - 1) per set, whatever the search visits) and in-range pairs/s.
   1 thread: thread CPU time; 2 threads: wall time (and process CPU time).
2. Training steps/s of the real training step (forward through the 40-layer cascade, loss,
   backward, Adam) for bnot-2d, bnot-4d and bnot-10d at m = 1,024 (and bnot-2d at 4,096), with
   the pure-torch op (2-D only) and impl="c" on 1 and 2 threads. DPC_ISA=scalar rows are the
   kernels as they were before the vector paths (the scalar path is that code, bit for bit).

    python bench/bench_training.py            # prints the tables, writes the "Training" section of docs/performance.md
    python bench/bench_training.py --quick    # fewer repetitions, no scalar step rows

Medians of repeated runs after a warm-up. The load average is printed with the tables: on a busy
machine compare CPU times, not wall times. Needs torch (pip install .[train]).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import torch
from common import ROOT, cpu_name

import dpc
from dpc import _core
from dpc_train.config import load_config
from dpc_train.trainer import Trainer

VECTOR_ISAS = [isa for isa in ("avx2", "avx512") if dpc.isa_supported(isa)]

# name: (dims, subspace mask, rho) as in training/configs/<name>.toml
LAYERS = {"bnot-2d": (2, 0b11, 4.0), "bnot-4d": (4, 0b1111, 2.0), "bnot-10d": (10, (1 << 10) - 1, 1.0)}
BATCH, M, LAYER_COUNT = 4, 1024, 40


def rate(v: float) -> str:
    """Three significant digits without exponents."""
    return f"{v:,.0f}" if v >= 100 else f"{v:.1f}" if v >= 10 else f"{v:.2f}"


def in_range_pairs(x: np.ndarray, rho: float) -> int:
    """Ordered pairs with e < d < r of a batch [B, m, k] (e = 1e-4 h), by brute force."""
    _, m, k = x.shape
    h = m ** (-1.0 / k)
    r, e = min(rho * h, 0.5), 1e-4 * h
    total = 0
    for xs in x:
        d = xs[None, :, :] - xs[:, None, :]
        d -= np.rint(d)
        d2 = (d * d).sum(-1)
        total += int(((d2 < r * r) & (d2 > e * e)).sum())
    return total


def time_layer(name: str, isa: str, threads: int, reps: int) -> tuple[float, float, float, int]:
    """(median seconds, median CPU seconds, candidate pairs, in-range pairs) of one layer's
    forward + backward over the batch."""
    n, mask, rho = LAYERS[name]
    rng = np.random.default_rng(0)
    x = rng.random((BATCH, M, n))
    w = rng.normal(size=(1, 32)) * 0.05
    g = rng.normal(size=x.shape)
    os.environ["DPC_ISA"] = isa
    try:

        def call():
            _core.layer_forward(x, w, [mask], [rho], 1e-4, 0, threads)
            _core.layer_backward(x, w, [mask], [rho], 1e-4, 0, g, threads)

        call()
        walls, cpus = [], []
        clock = time.thread_time if threads == 1 else time.process_time
        for _ in range(reps):
            t0, c0 = time.perf_counter(), clock()
            call()
            walls.append(time.perf_counter() - t0)
            cpus.append(clock() - c0)
    finally:
        os.environ.pop("DPC_ISA", None)
    return statistics.median(walls), statistics.median(cpus), BATCH * M * (M - 1), in_range_pairs(x, rho)


def time_steps(
    config: str, m: int, impl: str, threads: int, steps: int, isa: str = "", torch_threads: int = 0
) -> tuple[float, float]:
    """(median wall, median process CPU) seconds per training step. The trainer gives torch and
    the C kernels `threads` each; torch_threads > 0 then overrides torch's."""
    cfg = load_config(ROOT / "training" / "configs" / f"{config}.toml")
    cfg.pattern.points = m
    cfg.train.impl = impl
    cfg.train.threads = threads
    if isa:
        os.environ["DPC_ISA"] = isa
    try:
        with tempfile.TemporaryDirectory() as run_dir:
            trainer = Trainer(cfg, run_dir=run_dir, progress=False)
            if torch_threads:
                torch.set_num_threads(torch_threads)
            trainer.train_step()  # warm-up
            walls, cpus = [], []
            for _ in range(steps):
                t0, c0 = time.perf_counter(), time.process_time()
                trainer.train_step()
                trainer.step += 1
                walls.append(time.perf_counter() - t0)
                cpus.append(time.process_time() - c0)
    finally:
        os.environ.pop("DPC_ISA", None)
    return statistics.median(walls), statistics.median(cpus)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=5, help="timed steps per case (default 5)")
    ap.add_argument("--reps", type=int, default=15, help="timed layer calls per case (default 15)")
    ap.add_argument("--quick", action="store_true", help="2 steps, 5 layer calls, no scalar step rows")
    ap.add_argument("--out", default=str(ROOT / "docs" / "performance.md"))
    args = ap.parse_args()
    if args.quick:
        args.steps, args.reps = 2, 5
    load = [os.getloadavg()[0]]
    isas = ["scalar"] + VECTOR_ISAS

    lines = [
        "## Training",
        "",
        "Measured by `python bench/bench_training.py`.",
        "",
        f"Machine: {cpu_name()}, {os.cpu_count()} logical CPUs, {platform.system()} {platform.machine()}; "
        f"torch {torch.__version__}.",
        "",
        "### Layer kernels",
        "",
        f"One PointFilter layer, forward + backward (`dpc._core.layer_forward` / `layer_backward`), "
        f"batch {BATCH}, m = {M:,}, 32 bins, uniform points, median of {args.reps} calls. Candidate pairs: "
        "m (m - 1) ordered pairs per set (what an all-pairs search would test), in-range pairs: those "
        "with e < d < r. 1 thread: thread CPU time; 2 threads: wall time (process CPU time in "
        "parentheses). `scalar` is the code before the vector paths, bit for bit; `x40` is the "
        "kernel time of one training step's 40 layers.",
        "",
        "| layer | search | in range / point | ISA | threads | ms (fwd+bwd) | M candidate pairs/s | M in-range "
        "pairs/s | x40 s |",
        "|---|---|---:|---|---:|---:|---:|---:|---:|",
    ]
    layer_t: dict = {}
    for name, (n, _, _) in LAYERS.items():
        for isa in isas:
            for threads in (1, 2):
                if isa == "scalar" and threads == 2:
                    continue
                wall, cpu, cand, inr = time_layer(name, isa, threads, args.reps)
                t = cpu if threads == 1 else wall
                layer_t[name, isa, threads] = t
                search = "grid" if n <= 3 else "all pairs"
                cpu_note = "" if threads == 1 else f" ({cpu * 1e3:.1f})"
                lines.append(
                    f"| {name} | {search} | {inr / (BATCH * M):.0f} | {isa} | {threads} | "
                    f"{t * 1e3:.2f}{cpu_note} | {rate(cand / t / 1e6)} | {rate(inr / t / 1e6)} | "
                    f"{LAYER_COUNT * t:.2f} |"
                )
                print(lines[-1], flush=True)
    load.append(os.getloadavg()[0])
    if VECTOR_ISAS:
        best = VECTOR_ISAS[-1]
        lines += [
            "",
            f"Speed-up of `{best}` over `scalar`, 1 thread: "
            + ", ".join(f"{name} {layer_t[name, 'scalar', 1] / layer_t[name, best, 1]:.1f}x" for name in LAYERS)
            + ".",
        ]

    lines += [
        "",
        "### Training steps",
        "",
        "Median seconds per training step (forward through the cascade, loss, backward, Adam) of the "
        "bnot-2d (40 layers, 32 bins, rho = 4, radial-spectrum loss), bnot-4d (rho = 2) and bnot-10d "
        "(rho = 1) configurations, batch 4, after one warm-up step; wall time, process CPU time "
        "in parentheses. The `scalar` rows (DPC_ISA=scalar) are the kernels before the vector paths.",
        "",
        "`threads` is `[train] threads` (torch's intra-op threads and the C kernels' threads); "
        "`2 / torch 1` keeps torch on one thread.",
        "",
        "| config | m | op | ISA | threads | s/step | steps/s |",
        "|---|---:|---|---|---:|---:|---:|",
    ]
    cases = [
        ("bnot-2d", 1024, "torch", 1, "", 0),
        ("bnot-2d", 1024, "c", 1, "scalar", 0),
        ("bnot-2d", 1024, "c", 1, "", 0),
        ("bnot-2d", 1024, "c", 2, "", 0),
        ("bnot-2d", 1024, "c", 2, "", 1),
        ("bnot-2d", 4096, "torch", 1, "", 0),
        ("bnot-2d", 4096, "c", 1, "", 0),
        ("bnot-2d", 4096, "c", 2, "", 0),
        ("bnot-4d", 1024, "c", 1, "scalar", 0),
        ("bnot-4d", 1024, "c", 1, "", 0),
        ("bnot-4d", 1024, "c", 2, "", 0),
        ("bnot-4d", 1024, "c", 2, "", 1),
        ("bnot-10d", 1024, "c", 1, "scalar", 0),
        ("bnot-10d", 1024, "c", 1, "", 0),
        ("bnot-10d", 1024, "c", 2, "", 0),
        ("bnot-10d", 1024, "c", 2, "", 1),
    ]
    best2d = 0.0
    step_t: dict = {}
    for config, m, impl, threads, isa, torch_threads in cases:
        if args.quick and isa == "scalar":
            continue
        slow = impl == "torch" or isa == "scalar"
        steps = max(2, args.steps // 2) if slow else args.steps
        wall, cpu = time_steps(config, m, impl, threads, steps, isa, torch_threads)
        step_t[config, m, impl, threads, isa, torch_threads] = wall
        if config == "bnot-2d" and m == 1024 and impl == "c" and not isa:
            best2d = max(best2d, 1 / wall)
        shown = isa or (("auto (" + (VECTOR_ISAS[-1] if VECTOR_ISAS else "scalar") + ")") if impl == "c" else "")
        shown_threads = f"{threads} / torch {torch_threads}" if torch_threads else f"{threads}"
        lines.append(
            f"| {config} | {m:,} | {impl} | {shown} | {shown_threads} | {wall:.3f} ({cpu:.3f}) | {1 / wall:.2f} |"
        )
        print(lines[-1], flush=True)
    load.append(os.getloadavg()[0])
    notes = []
    if not args.quick:
        notes.append(
            "Steps/s of `auto` over `scalar`, 1 thread: "
            + ", ".join(
                f"{c} {step_t[c, 1024, 'c', 1, 'scalar', 0] / step_t[c, 1024, 'c', 1, '', 0]:.1f}x"
                for c in ("bnot-2d", "bnot-4d", "bnot-10d")
            )
            + "."
        )
    slower = [
        c for c in ("bnot-2d", "bnot-4d", "bnot-10d") if step_t[c, 1024, "c", 2, "", 0] > step_t[c, 1024, "c", 1, "", 0]
    ]
    if slower:
        busy = max(load) > 1.0 + 0.25 * (os.cpu_count() or 1)  # beyond this benchmark's own thread
        notes.append(
            f"Two threads were slower than one here ({', '.join(slower)}): "
            + ("with other work on the machine the second thread finds no free core, and " if busy else "")
            + "torch's intra-op threads, which `[train] threads` sets too, cost more than they "
            "save on this step's small tensors (compare the `2 / torch 1` rows, which keep "
            "torch on one thread)."
        )
    lines += [""] + [" ".join(notes)] if notes else []
    lines += [
        "",
        f"Load average (1 min) at the start, between the tables and at the end: "
        f"{', '.join(f'{v:.2f}' for v in load)} on {os.cpu_count()} CPUs. Goal: >= 4 steps/s "
        f"for bnot-2d at m = 1,024 on this 2-core machine: best measured {best2d:.2f} steps/s (wall), "
        f"{'met' if best2d >= 4 else '**not met**'}.",
        "",
    ]
    section = "\n".join(lines)
    out = Path(args.out)
    old = out.read_text() if out.exists() else "# Performance\n"
    start = old.find("\n## Training")
    rest = ""
    if start >= 0:  # replace this section only, keep any section after it
        nxt = old.find("\n## ", start + 1)
        rest = old[nxt:] if nxt >= 0 else ""
        old = old[:start]
    out.write_text(old.rstrip("\n") + "\n\n" + section + rest)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
