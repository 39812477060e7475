"""Trained progressive cascades: the level-by-level rule (docs/model-format.md §6, earlier levels
held in place) with kernels trained on losses over every prefix, against the hand-designed
progressive-2d.

    python -m lab.progressive.trained_levels                 # 500 steps per loss; docs/reports/progressive.md
    python -m lab.progressive.trained_levels --steps 100 --quick   # prints only

Each loss trains bnot-2d-stratified's architecture (40 layers from 10 unique kernels, radius 4
spacings, a Gaussian repulsion to start, stratified input) as a progressive cascade of base 16
with the product trainer (dpc_train, impl "c", 1 thread, batch 4, Adam 1e-3 to 1e-4), and
libdpc generates from the export. Losses, over the prefixes n = 16, 32, ..., 1,024 of each set:
* elow: the mean of log E_low nu<0.5 (the prefix goal's own measure);
* elow+shape: 0.3 x that, plus each prefix's radial spectrum against the BNOT target of its size
  (none at 32) in decades, below nu = 0.75 weighted 4x, up to nu = 2;
* elow+shape+hard-core: plus 100 x the mean squared shortfall of every prefix pair below 0.7 of
  the prefix's mean spacing.
Measured over 32 sets of 1,024 (seeds 0-31) against 32 bnot-2d-stratified sets of each size: every
prefix's E_low nu<0.5 over the set's, the full set's E_low nu<0.75 over the set's, delta_min of
the full sets and of their first 64 points.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

import dpc
from dpc.analysis.pcf import min_distance
from dpc.analysis.spectrum import low_frequency_energy
from lab.common import REPORTS, cpu_name, replace_section

DOC = REPORTS / "progressive.md"
M, SETS = 1024, 32
PREFIXES = [16 << k for k in range(7)]

ARCHITECTURE = """
[pattern]
name = "progressive-2d-trained"
dims = 2
points = 1024
description = "Progressive 2-D blue noise, trained level by level (a lab study)."

[model]
layers = 40
unique_kernels = 10
bins = 32
subspaces = ["xy"]
radius = [4.0]
init = "repulsion"
init_sigma = 1.0
init_amplitude = 0.2
input = "stratified"
order = "progressive"
progressive_base = 16

[train]
steps = 500
batch = 4
lr = 1e-3
lr_final = 1e-4
seed = 0
threads = 1
checkpoint_every = 100
eval_sets = 4
impl = "c"
"""

HELPERS = """
PREFIXES = [16, 32, 64, 128, 256, 512, 1024]
SHAPED = [16, 64, 128, 256, 512, 1024]
NU = 2.0
BNOT = {n: radial_target("bnot", n, 2, nu_max=NU) for n in SHAPED}
W = {n: lowband_weight(n, 2, nu_max=NU, nu_low=0.75, factor=4.0) for n in SHAPED}
def elow(X):
    return sum(torch.log(lowband_energy(prefix(X, n), 0.5)) for n in PREFIXES) / len(PREFIXES)
def shape(X):
    out = 0.0
    for n in SHAPED:
        d = (torch.log(radspec(prefix(X, n), nu_max=NU) + 1e-4) - torch.log(BNOT[n].to(X) + 1e-4)).abs()
        out = out + (d * W[n].to(d)).sum() / W[n].sum()
    return out / len(SHAPED)
def hard_core(X):
    out = 0.0
    for n in PREFIXES:
        P = prefix(X, n)
        d = P[:, :, None, :] - P[:, None, :, :]
        d = d - torch.round(d)
        r = torch.sqrt((d * d).sum(-1) + torch.eye(n, dtype=X.dtype) * 1e6 + 1e-12) * math.sqrt(n)
        out = out + (torch.relu(0.7 - r) ** 2).sum() / (X.shape[0] * n)
    return out / len(PREFIXES)
"""

LOSSES = {
    "elow": "def loss(X):\n    return elow(X)",
    "elow+shape": "def loss(X):\n    return 0.3 * elow(X) + shape(X)",
    "elow+shape+hard-core": "def loss(X):\n    return 0.3 * elow(X) + shape(X) + 100 * hard_core(X)",
}


def config_text(loss: str) -> str:
    source = HELPERS + LOSSES[loss]
    return ARCHITECTURE + f'\n[loss]\nsource = """\n{source}\n"""\n'


def train(loss: str, steps: int, folder: Path) -> tuple[Path, float]:
    """Train one loss; (exported model, seconds of training)."""
    from dpc_train.cli import export_main, train_main

    cfg = folder / f"{loss}.toml"
    cfg.write_text(config_text(loss))
    run = folder / f"run-{loss}"
    t = time.perf_counter()
    argv = ["--config", str(cfg), "--run-dir", str(run), "--force", "--no-progress", "--steps", str(steps)]
    if train_main(argv) != 0:
        raise SystemExit(f"training {loss} failed")
    seconds = time.perf_counter() - t
    out = folder / f"{loss}.onnx"
    if export_main([str(run / "checkpoint.pt"), "-o", str(out)]) != 0:
        raise SystemExit(f"exporting {loss} failed")
    return out, seconds


def references() -> tuple[dict[int, float], float]:
    """E_low nu<0.5 of SETS bnot-2d-stratified sets of each prefix size, and nu<0.75 of the full ones."""
    plain = dpc.load("bnot-2d-stratified", backend="cpu")
    reference = {n: low_frequency_energy(plain.generate_batch(SETS, 1000, n).astype(np.float64), 0.5) for n in PREFIXES}
    return reference, low_frequency_energy(plain.generate_batch(SETS, 1000, M).astype(np.float64), 0.75)


def quality(sets: np.ndarray, reference: dict[int, float], reference75: float) -> dict:
    """Each prefix's E_low nu<0.5 over a set's, the full set's nu<0.75 over a set's, delta_min."""
    sets = sets.astype(np.float64)
    return {
        "ratios": [low_frequency_energy(sets[:, :n], 0.5) / reference[n] for n in PREFIXES],
        "full75": low_frequency_energy(sets, 0.75) / reference75,
        "dmin": min_distance(sets).mean_ratio,
        "dmin64": min_distance(sets[:, :64]).mean_ratio,
    }


def publish(lines: list[str], section: str, quick: bool) -> None:
    """Print a study's lines and, unless quick, write them to its section of the report."""
    body = "\n".join(lines)
    print(body)
    if not quick:
        replace_section(DOC, section, body)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--steps", type=int, default=500)
    ap.add_argument("--quick", action="store_true", help="prints, does not write docs/")
    a = ap.parse_args()
    reference, reference75 = references()

    def measure(model) -> dict:
        return quality(dpc.load(model, backend="cpu").generate_batch(SETS, 0, M), reference, reference75)

    rows = [("progressive-2d (hand-designed, 160 layers)", measure("progressive-2d"), None)]
    with tempfile.TemporaryDirectory() as tmp:
        for loss in LOSSES:
            model, seconds = train(loss, a.steps, Path(tmp))
            rows.append((f"trained, loss {loss}", measure(str(model)), seconds))
            print(rows[-1][0], rows[-1][1], flush=True)
    head = "| cascade | " + " | ".join(f"{n:,}" for n in PREFIXES) + " | full ν<0.75 | δ_min | δ_min of 64 | training |"
    lines = [
        f"Measured by `python -m lab.progressive.trained_levels --steps {a.steps}` on {cpu_name()}: {SETS} sets of"
        f" {M:,} points; each prefix's E_low ν<0.5 over that of {SETS} bnot-2d-stratified sets of its size, the full"
        " set's E_low ν<0.75 over theirs, δ_min (1: the densest packing).",
        "",
        head,
        "|---" + "|---:" * (len(PREFIXES) + 4) + "|",
    ]
    for name, r, seconds in rows:
        cells = " | ".join(f"{v:.2f}" for v in r["ratios"])
        took = f"{seconds:.0f} s" if seconds is not None else "–"
        lines.append(f"| {name} | {cells} | {r['full75']:.2f} | {r['dmin']:.3f} | {r['dmin64']:.3f} | {took} |")
    publish(lines, "trained_levels", a.quick)


if __name__ == "__main__":
    main()
