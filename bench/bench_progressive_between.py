"""Prefixes between the levels of a progressive set (docs/progressive.md, "Between the levels").

    python bench/bench_progressive_between.py     # 32 sets of 1,024 points: writes docs/progressive.md

A sampler reads a progressive table in order, so a renderer that stops at n samples, n not a
power of two, gets the first n points: the levels up to the largest power of two below n and
the first points of the next level, in the order the generator leaves them. This measures
E_low nu<0.5 of those prefixes (n = 1.5 * 2^k, and 1.25 and 1.75 * 2^k) over a dpc set made
for n (bnot-2d-stratified), for progressive-2d and progressive-2d-relaxed, set i from seed i.
"""

from __future__ import annotations

import argparse

import numpy as np
from bench_progressive import DOC, tree
from doc_sections import replace_section

import dpc
from dpc.analysis.spectrum import low_frequency_energy

MODELS = ["progressive-2d", "progressive-2d-relaxed"]
SET_MODEL = "bnot-2d-stratified"
PREFIXES = [20, 24, 28, 40, 48, 56, 80, 96, 112, 160, 192, 224, 320, 384, 448, 640, 768, 896]
LEVELS = [16, 32, 64, 128, 256, 512, 1024]


def run(count: int, m: int) -> dict[str, dict[int, float]]:
    plain = dpc.load(SET_MODEL, backend="cpu")
    ref = {
        n: low_frequency_energy(plain.generate_batch(count, 0, n).astype(np.float64), 0.5) for n in PREFIXES + LEVELS
    }
    out = {}
    for name in MODELS:
        sets = dpc.load(name, backend="cpu").generate_batch(count, 0, m).astype(np.float64)
        out[name] = {n: low_frequency_energy(sets[:, :n], 0.5) / ref[n] for n in PREFIXES + LEVELS if n <= m}
        print(name, " ".join(f"{n}:{r:.2f}" for n, r in sorted(out[name].items())))
    return out


def section(res: dict[str, dict[int, float]], count: int, m: int) -> str:
    ns = sorted(next(iter(res.values())))
    lines = [
        f"Measured by `python bench/bench_progressive_between.py` (tree {tree()}): {count} sets of {m:,} points "
        f"of each model, set i from seed i; E_low ν<0.5 of the first n points over a {SET_MODEL} set of n points "
        "(level sizes in bold).",
        "",
        "| prefix n | " + " | ".join(MODELS) + " |",
        "|---:|" + "---:|" * len(MODELS),
    ]
    for n in ns:
        label = f"**{n}**" if n in LEVELS else str(n)
        lines.append(f"| {label} | " + " | ".join(f"{res[name][n]:.2f}" for name in MODELS) + " |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sets", type=int, default=32)
    args = ap.parse_args()
    m = 1024
    res = run(args.sets, m)
    replace_section(DOC, "bench_progressive_between", section(res, args.sets, m))
    print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
