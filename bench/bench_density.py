"""Density benchmark: dpc_generate_density against dpc_generate_n of the same model and count, on
one thread, per ISA path; writes the section "Density" of docs/performance.md.

    python bench/bench_density.py [--quick]

Model bnot-2d-stratified; densities on 256 x 256 cells: a ramp (0.1 + x), a Gaussian bump, a
1 : 16 step (one wall) and a photograph (walls everywhere). The uniform set and each density's set
alternate, round after round, so that a busy machine slows both alike; medians over the rounds. The
goal: a density set within 2x the time of a uniform set of the same size.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
from common import ROOT, cpu_name, replace_section

import dpc

MODEL = "bnot-2d-stratified"


def photo() -> np.ndarray:
    """Grace Hopper (matplotlib's sample photograph, public domain), 512 x 512 averaged to 256 x
    256, dark is dense: the density of the density study (lab/density/field.py), all edges."""
    import matplotlib.cbook as cbook
    from PIL import Image

    with Image.open(cbook.get_sample_data("grace_hopper.jpg", asfileobj=False)) as img:
        tone = dpc.density.image_tone(np.asarray(img.convert("RGB"))).astype(np.float64)
    return 1.0 - tone[44:556].reshape(256, 2, 256, 2).mean(axis=(1, 3))


def densities() -> dict[str, np.ndarray]:
    y, x = (np.mgrid[0:256, 0:256] + 0.5) / 256
    return {
        "ramp": 0.1 + x,
        "bump": 0.05 + np.exp(-((x - 0.5) ** 2 + (y - 0.5) ** 2) / (2 * 0.15**2)),
        "step 1 : 16": np.where(x < 0.5, 1.0, 16.0),
        "photograph": photo(),
    }


def timed(fn, *args) -> float:
    t0 = time.perf_counter()
    fn(*args)
    return time.perf_counter() - t0


def met(ratio: float) -> str:
    return "yes" if ratio <= 2.0 else "**no**"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer rounds, no 65,536-point rows")
    ap.add_argument("--out", default=str(ROOT / "docs" / "performance.md"))
    args = ap.parse_args()
    counts = [1024, 4096] + ([] if args.quick else [65536])
    rounds = 3 if args.quick else 9
    isas = [isa for isa in ("scalar", "avx2", "avx512") if dpc.isa_supported(isa)]
    grids = {name: dpc.density.as_density(d) for name, d in densities().items()}
    rows, checks = [], []
    for isa in isas:
        model = dpc.load(MODEL, isa=isa, threads=1)
        for m in counts:
            model.generate(0, m)  # warm up
            for d in grids.values():
                model.generate_density(d, m, 0)
            t = {"uniform": [], **{name: [] for name in grids}}
            for r in range(rounds):
                t["uniform"].append(timed(model.generate, r + 1, m))
                for name, d in grids.items():
                    t[name].append(timed(model.generate_density, d, m, r + 1))
            med = {k: float(np.median(v)) for k, v in t.items()}
            cells = [f"{med[name] * 1e3:.2f} ms ({med[name] / med['uniform']:.2f}x)" for name in grids]
            rows.append(f"| {isa} | {m:,} | {med['uniform'] * 1e3:.2f} ms | " + " | ".join(cells) + " |")
            print(rows[-1], flush=True)
            if isa == isas[-1]:
                worst = max(med[name] / med["uniform"] for name in grids)
                checks.append((m, worst))
    body = [
        f"Measured by `python bench/bench_density.py` on {cpu_name()}, {os.cpu_count()} logical CPUs; "
        f"`{MODEL}` on one thread, wall-time medians of {rounds} alternating rounds (uniform set, then each "
        "density's); in brackets the time over the uniform set's of the same count and ISA.",
        "",
        "| ISA | points | uniform (`generate`) | " + " | ".join(f"{n} (`generate_density`)" for n in grids) + " |",
        "|---|---:|---:|" + "---:|" * len(grids),
        *rows,
        "",
        "| goal | measured | met |",
        "|---|---:|---|",
        *[f"| {isas[-1]}, {m:,} points: densities <= 2x uniform | {w:.2f}x | {met(w)} |" for m, w in checks],
        "",
        f"Load average while measuring: {os.getloadavg()[0]:.2f} (1 min).",
    ]
    replace_section(Path(args.out), "bench_density", "\n".join(body))
    print(f"wrote the bench_density section of {args.out}")


if __name__ == "__main__":
    main()
