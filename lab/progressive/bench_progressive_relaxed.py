"""Jointly relaxed progressive sets: every prefix against the goals (docs/progressive.md).

    python -m lab.progressive.bench_progressive_relaxed  # 64 sets, m = 1,024, 4,096: docs/reports/progressive.md
    python -m lab.progressive.bench_progressive_relaxed --quick  # 8 sets, m = 1,024, prints only

progressive-2d-relaxed's sets (libdpc: progressive-2d's levels, then the prefix relaxation of
docs/model-format.md §6.1, every point moving under the energy of every prefix 16 * 2^j at once),
measured prefix by prefix as bench_progressive.py measures the progressive samplers (its measures
and integrands, set i from seed i), beside progressive-2d's sets (the same levels, unrelaxed), a
dpc set made for each prefix size (bnot-2d-stratified), PMJ02BN, scrambled Sobol' and white
noise. Seconds per set: the median of one-thread generate calls, for both progressive models.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import dpc
from dpc import baselines
from lab.common import cpu_name, replace_section
from lab.progressive.bench_progressive import (
    DOC,
    PROGRESSIVE,
    SET_MODEL,
    measure,
    prefix_goals,
    prefix_tables,
    prefixes,
    tradeoff,
    tradeoff_table,
    tree,
)

RELAXED_MODEL = "progressive-2d-relaxed"
RELAXED = "progressive dpc, relaxed"
SAMPLERS = [RELAXED, "progressive dpc", "dpc set", "pmj02bn", "sobol", "white"]
METRICS = [
    ("elow50", "E_low ν<0.5"),
    ("elow75", "E_low ν<0.75"),
    ("dmin", "δ_min"),
    ("gauss", "Gaussian rel. variance"),
    ("half", "half-plane rel. variance"),
]


def _timed(model, seeds: range, m: int) -> tuple[np.ndarray, float]:
    sets, seconds = [], []
    for seed in seeds:
        t = time.perf_counter()
        sets.append(model.generate(seed, m))
        seconds.append(time.perf_counter() - t)
    return np.stack(sets).astype(np.float64), float(np.median(seconds))


def run(m: int, count: int, seed: int) -> tuple[dict, dict[str, float]]:
    seeds = range(seed, seed + count)
    relaxed, t_relaxed = _timed(dpc.load(RELAXED_MODEL, backend="cpu", threads=1), seeds, m)
    prog, t_prog = _timed(dpc.load(PROGRESSIVE, backend="cpu", threads=1), seeds, m)
    print(
        f"m = {m}: {count} sets, median {t_relaxed:.2f} s per relaxed set, {t_prog * 1e3:.0f} ms per progressive-2d set"
    )
    full = {RELAXED: relaxed, "progressive dpc": prog}
    full.update({name: baselines.generate(name, m, 2, count, seed) for name in ("pmj02bn", "sobol", "white")})
    plain = dpc.load(SET_MODEL, backend="cpu")
    res: dict = {}
    for n in prefixes(m):
        row = {name: measure(sets[:, :n]) for name, sets in full.items()}
        row["dpc set"] = measure(plain.generate_batch(count, seed, n).astype(np.float64))
        res[n] = row
        print(f"  n = {n:5d}: E_low<0.5 " + "  ".join(f"{s} {row[s]['elow50']:.5f}" for s in SAMPLERS))
    return res, {RELAXED_MODEL: t_relaxed, PROGRESSIVE: t_prog}


def goals(results: dict[int, dict]) -> list[tuple[str, bool, str]]:
    return [g for m, res in results.items() for g in prefix_goals(res, m, RELAXED, f"m = {m}: ")]


def section(
    results: dict[int, dict], checks, count: int, seconds: dict[int, dict[str, float]], curve: dict, curve_m: int
) -> str:
    lines = [
        f"Measured by `python -m lab.progressive.bench_progressive_relaxed` (tree {tree()}) on {cpu_name()}: {count} "
        "sets "
        f"of each sampler and size, set i from seed i; `{RELAXED_MODEL}`'s sets (libdpc), median seconds per set "
        "on one thread: "
        + ", ".join(
            f"{t[RELAXED_MODEL]:.2f} s at m = {m:,} ({PROGRESSIVE}: {t[PROGRESSIVE] * 1e3:.0f} ms)"
            for m, t in seconds.items()
        )
        + ".",
        "",
        "Goals (for the relaxed sets):",
        "",
    ]
    lines += [f"- **{'met' if ok else 'missed'}**: {g} ({msg})" for g, ok, msg in checks]
    lines += [
        "",
        f"#### The stratified variant of the relaxed sets (m = {curve_m:,})",
        "",
        "`dpc.stratify.stratify_02(points, up_to)` on the relaxed sets, measured as bench_progressive.py "
        "measures it on progressive-2d's: every prefix's E_low ν<0.5 over a dpc set's (the worst prefix), "
        "the elementary-interval occupancy averaged over prefixes and shapes (1: every prefix a (0,2)-net), "
        "the full set's δ_min and its Gaussian variance over PMJ02BN's.",
        "",
    ]
    lines += tradeoff_table(curve)
    lines += prefix_tables(results, SAMPLERS, METRICS, "####")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sets", type=int, default=64)
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 4096])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="8 sets at m = 1,024; prints, does not write docs/")
    args = ap.parse_args()
    if args.quick:
        args.sets, args.sizes = 8, [1024]
    results, seconds = {}, {}
    for m in args.sizes:
        results[m], seconds[m] = run(m, args.sets, args.seed)
    print(f"stratified variant of the relaxed sets, m = {args.sizes[0]}:")
    curve = tradeoff(args.sizes[0], args.sets, args.seed, RELAXED_MODEL)
    checks = goals(results)
    print("\nGoals (relaxed sets):")
    for g, ok, msg in checks:
        print(f"  [{'met' if ok else 'MISSED'}] {g}: {msg}")
    if args.quick:
        return
    replace_section(
        DOC, "bench_progressive_relaxed", section(results, checks, args.sets, seconds, curve, args.sizes[0])
    )
    print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
