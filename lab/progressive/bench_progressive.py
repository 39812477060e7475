"""Quality of every power-of-two prefix of progressive point sets (docs/progressive.md).

    python -m lab.progressive.bench_progressive           # 64 sets, m = 1,024 and 4,096: docs/reports/progressive.md
    python -m lab.progressive.bench_progressive --quick   # 16 sets, m = 1,024, prints only
    python -m lab.progressive.bench_progressive --quick --model runs/x.onnx    # another progressive model

For each m and each prefix n = 16, 32, ..., m, over the same sets: E_low below nu = 0.5 and 0.75
(exact, dpc.analysis.low_frequency_energy; white noise = 1), delta_min (minimum toroidal distance
/ that of the densest packing of n discs) and the relative variance of the Monte Carlo estimate
for a family of Gaussians and of half-planes (dpc.analysis.integration). Samplers: the
progressive model's first n points (progressive-2d, and progressive-2d-balanced: the same
cascade with each level balanced, dpc.balance), a dpc set made for n points (bnot-2d-stratified, not
progressive: the quality a prefix is held to), PMJ02BN and PMJ02 (dpc.baselines, from
Christensen et al. 2018), scrambled Sobol' (scipy) and white noise; every set of a sampler is one
seed. The goals of the progressive-dpc issue and of the trained progressive model are checked
and printed.
"""

from __future__ import annotations

import argparse
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import dpc
from dpc import baselines
from dpc.analysis.integration import integrands, relative_variance
from dpc.analysis.pcf import min_distance
from dpc.analysis.spectrum import low_frequency_energy
from lab.common import REPORTS, ROOT, cpu_name, replace_section
from lab.progressive.alternatives import levels_model, repulsion_layers  # the design study's cascades

DOC = REPORTS / "progressive.md"
PROGRESSIVE = "progressive-2d"
BALANCED = "progressive-2d-balanced"
SET_MODEL = "bnot-2d-stratified"
SAMPLERS = [
    "progressive dpc",
    "progressive dpc balanced",
    "progressive dpc (0,2)",
    "dpc set",
    "pmj02bn",
    "pmj02",
    "sobol",
    "white",
]
PROGRESSIVE_SAMPLERS = ["progressive dpc", "progressive dpc balanced"]  # the goals are checked for each
METRICS = [
    ("elow50", "E_low nu<0.5"),
    ("elow75", "E_low nu<0.75"),
    ("dmin", "delta_min"),
    ("gauss", "Gaussian rel. variance"),
    ("half", "half-plane rel. variance"),
    ("net", "elementary-interval occupancy (1: a (0,2)-net)"),
]
STRATIFIED_UP_TO = [0, 16, 64, 256, 1024, 4096]  # the stratified variant's trade-off curve
FAMILIES = {"gauss": integrands("gaussian", 16, seed=7), "half": integrands("heaviside", 16, seed=7)}


def prefixes(m: int) -> list[int]:
    return [1 << k for k in range(4, m.bit_length()) if 1 << k <= m]


def measure(sets: np.ndarray) -> dict[str, float]:
    return {
        "elow50": low_frequency_energy(sets, 0.5),
        "elow75": low_frequency_energy(sets, 0.75),
        "dmin": min_distance(sets).mean_ratio,
        "gauss": float(relative_variance(sets, FAMILIES["gauss"]).mean()),
        "half": float(relative_variance(sets, FAMILIES["half"]).mean()),
        "net": float(np.mean([baselines.net_occupancy(s) for s in sets])),
    }


def run(m: int, count: int, seed: int, model: str = PROGRESSIVE) -> dict:
    prog, plain = dpc.load(model, backend="cpu"), dpc.load(SET_MODEL, backend="cpu")
    t = time.perf_counter()
    prog_sets = prog.generate_batch(count, seed, m).astype(np.float64)
    full = {
        "progressive dpc": prog_sets,
        "progressive dpc balanced": dpc.load(BALANCED, backend="cpu").generate_batch(count, seed, m).astype(np.float64),
        "progressive dpc (0,2)": np.stack([dpc.stratify.stratify_02(x) for x in prog_sets]),
        "pmj02bn": baselines.generate("pmj02bn", m, 2, count, seed),
        "pmj02": baselines.generate("pmj02", m, 2, count, seed),
        "sobol": baselines.generate("sobol", m, 2, count, seed),
        "white": baselines.generate("white", m, 2, count, seed),
    }
    print(f"m = {m}: {count} sets of each sampler in {time.perf_counter() - t:.0f} s")
    res: dict = {}
    for n in prefixes(m):
        row = {name: measure(sets[:, :n]) for name, sets in full.items()}
        row["dpc set"] = measure(plain.generate_batch(count, seed, n).astype(np.float64))
        res[n] = row
        print(f"  n = {n:5d}: E_low<0.5 " + "  ".join(f"{s} {row[s]['elow50']:.4f}" for s in SAMPLERS))
    return res


def tradeoff(m: int, count: int, seed: int, model: str = PROGRESSIVE) -> dict[float, dict]:
    """The stratified variant with its first 0, 16, ..., m points (0,2)-stratified: over all
    power-of-two prefixes from 16, the worst E_low nu<0.5 relative to a dpc set of the same size,
    the mean elementary-interval occupancy, delta_min of the full set, and the full set's Gaussian
    variance relative to PMJ02BN's."""
    prog = dpc.load(model, backend="cpu").generate_batch(count, seed, m).astype(np.float64)
    plain = dpc.load(SET_MODEL, backend="cpu")
    ref = {n: low_frequency_energy(plain.generate_batch(count, seed, n).astype(np.float64), 0.5) for n in prefixes(m)}
    pmj = relative_variance(baselines.generate("pmj02bn", m, 2, count, seed), FAMILIES["gauss"]).mean()
    out = {}
    for t in [u for u in STRATIFIED_UP_TO if u <= m]:
        sets = np.stack([dpc.stratify.stratify_02(x, up_to=t) for x in prog]) if t else prog
        out[t] = {
            "elow": max(low_frequency_energy(sets[:, :n], 0.5) / ref[n] for n in prefixes(m)),
            "net": float(np.mean([baselines.net_occupancy(s[:n]) for s in sets for n in prefixes(m)])),
            "dmin": min_distance(sets).mean_ratio,
            "gauss": float(relative_variance(sets, FAMILIES["gauss"]).mean() / pmj),
        }
        print(f"  stratified up to {t:5d}: " + ", ".join(f"{k} {v:.3f}" for k, v in out[t].items()))
    return out


def prefix_goals(res: dict[int, dict], m: int, sampler: str, label: str) -> list[tuple[str, bool, str]]:
    """The prefix goals for one sampler's sets of m points (label: the goals' prefix): the first four
    from the progressive-dpc issue, the last two the trained progressive model's (every prefix from
    64 points within 2x a dpc set's E_low nu<0.5, the full set within 10 %)."""
    ns = sorted(res)
    r_dpc = [res[n][sampler]["elow50"] / res[n]["dpc set"]["elow50"] for n in ns]
    r_pmj = [res[n][sampler]["elow50"] / res[n]["pmj02bn"]["elow50"] for n in ns]
    r_var = [res[n][sampler]["gauss"] / res[n]["pmj02bn"]["gauss"] for n in ns]
    r_full = {k: res[m][sampler][k] / res[m]["dpc set"][k] for k in ("elow50", "elow75")}

    def worst(r: list[float], sizes: list[int] = ns) -> str:
        return f"worst x{max(r):.2f} at n = {sizes[int(np.argmax(r))]}"

    n64 = [n for n in ns if n >= 64]
    r_64 = r_dpc[len(ns) - len(n64) :]  # ns ascending

    full = f"x{r_full['elow50']:.2f} below nu = 0.5, x{r_full['elow75']:.2f} below 0.75"
    return [
        (f"{label}every prefix's E_low nu<0.5 <= 3 x a dpc set's", max(r_dpc) <= 3.0, worst(r_dpc)),
        (f"{label}every prefix's E_low nu<0.5 <= 0.1 x PMJ02BN's", max(r_pmj) <= 0.1, worst(r_pmj)),
        (f"{label}the full set within 1.2 x {SET_MODEL}'s E_low (both bands)", max(r_full.values()) <= 1.2, full),
        (f"{label}every prefix's Gaussian variance <= PMJ02BN's", max(r_var) <= 1.0, worst(r_var)),
        (
            f"{label}every prefix from 64 points: E_low nu<0.5 <= 2 x a dpc set's",
            max(r_64) <= 2.0,
            worst(r_64, n64),
        ),
        (f"{label}the full set within 1.1 x {SET_MODEL}'s E_low (both bands)", max(r_full.values()) <= 1.1, full),
    ]


def goals(results: dict[int, dict]) -> list[tuple[str, bool, str]]:
    return [
        g
        for m, res in results.items()
        for p in PROGRESSIVE_SAMPLERS
        for g in prefix_goals(res, m, p, f"{p}, m = {m}: ")
    ]


def timings(sizes: list[int], repeats: int = 5) -> dict[str, dict[int, float]]:
    """Median milliseconds of one generate() on one thread, per model and set size: the two
    progressive models, the first progressive-2d (fixed sigma = 1.1, the design study's row) and
    the dpc set model."""
    out: dict[str, dict[int, float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        models = {
            PROGRESSIVE: dpc.load(PROGRESSIVE, backend="cpu", threads=1),
            BALANCED: dpc.load(BALANCED, backend="cpu", threads=1),
            "first progressive-2d (sigma 1.1)": levels_model(
                repulsion_layers(0.3, 1.1, 4.125, 160), Path(tmp) / "first.onnx", threads=1
            ),
            SET_MODEL: dpc.load(SET_MODEL, backend="cpu", threads=1),
        }
        for label, model in models.items():
            out[label] = {}
            for m in sizes:
                model.generate(0, m)  # warm
                times = []
                for r in range(repeats):
                    t = time.perf_counter()
                    model.generate(r, m)
                    times.append(time.perf_counter() - t)
                out[label][m] = 1000 * float(np.median(times))
            print(f"  {label}: " + ", ".join(f"{out[label][m]:.0f} ms at {m}" for m in sizes))
    return out


def tree() -> str:
    try:
        git = ["git", "rev-parse", "--short", "HEAD"]
        return subprocess.run(git, cwd=ROOT, capture_output=True, text=True).stdout.strip()
    except OSError:
        return "?"


def section(
    results: dict[int, dict],
    checks,
    count: int,
    curve: dict[float, dict],
    curve_m: int,
    ms: dict[str, dict[int, float]],
) -> str:
    sizes = sorted(next(iter(ms.values())))
    lines = [
        f"Measured by `python -m lab.progressive.bench_progressive` (tree {tree()}) on {cpu_name()}: {count} sets of "
        "each "
        "sampler and size, set i from seed i. White noise has E_low = 1; delta_min = 1 is the densest packing.",
        "",
        "Goals:",
        "",
    ]
    lines += [f"- **{'met' if ok else 'missed'}**: {g} ({msg})" for g, ok, msg in checks]
    lines += [
        "",
        "### Generation time",
        "",
        "Median of 5 `generate` calls on one thread, milliseconds per set (shared machine: compare within the table).",
        "",
        "| model | " + " | ".join(f"m = {m:,}" for m in sizes) + " |",
        "|---|" + "---:|" * len(sizes),
    ]
    lines += [f"| {label} | " + " | ".join(f"{t[m]:.0f}" for m in sizes) + " |" for label, t in ms.items()]
    lines += [
        "",
        f"### The stratified variant's trade-off (m = {curve_m:,})",
        "",
        "`dpc.stratify.stratify_02(points, up_to)` on the progressive sets (their first `up_to` points "
        "made a (0,2)-sequence, the rest as they are): every prefix's E_low "
        "ν<0.5 over a dpc set's (the worst prefix), the elementary-interval occupancy averaged over "
        "prefixes and shapes (1: every prefix a (0,2)-net), the full set's δ_min and its Gaussian "
        "variance over PMJ02BN's.",
        "",
    ]
    lines += tradeoff_table(curve)
    lines += prefix_tables(results, SAMPLERS, METRICS, "###")
    return "\n".join(lines)


def tradeoff_table(curve: dict[float, dict]) -> list[str]:
    """The stratified variant's trade-off curve (tradeoff()) as a markdown table."""
    return [
        "| stratified up to | worst E_low ratio | occupancy | δ_min | Gaussian variance / PMJ02BN's |",
        "|---:|---:|---:|---:|---:|",
    ] + [f"| {t:g} | {r['elow']:.2f} | {r['net']:.3f} | {r['dmin']:.3f} | {r['gauss']:.2f} |" for t, r in curve.items()]


def prefix_tables(results: dict[int, dict], samplers: list[str], metrics, heading: str) -> list[str]:
    """One markdown table per m and metric: a row per prefix n, a column per sampler."""
    lines = []
    for m, res in results.items():
        for key, title in metrics:
            lines += ["", f"{heading} m = {m:,}: {title}", ""]
            lines += ["| prefix n | " + " | ".join(samplers) + " |", "|---:|" + "---:|" * len(samplers)]
            fmt = "{:.3f}" if key == "dmin" else "{:.3g}"
            for n in sorted(res):
                lines.append(f"| {n:,} | " + " | ".join(fmt.format(res[n][s][key]) for s in samplers) + " |")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sets", type=int, default=64)
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 4096])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="16 sets at m = 1,024; prints, does not write docs/")
    ap.add_argument("--model", default=PROGRESSIVE, help="another progressive model (name or .onnx); prints only")
    args = ap.parse_args()
    if args.quick:
        args.sets, args.sizes = 16, [1024]
    results = {m: run(m, args.sets, args.seed, args.model) for m in args.sizes}
    print(f"stratified variant, m = {args.sizes[0]}:")
    curve = tradeoff(args.sizes[0], args.sets, args.seed, args.model)
    checks = goals(results)
    print("generation time, one thread:")
    ms = timings(args.sizes)
    print("\nGoals:")
    for g, ok, msg in checks:
        print(f"  [{'met' if ok else 'MISSED'}] {g}: {msg}")
    if args.quick or args.model != PROGRESSIVE:
        return
    replace_section(DOC, "bench_progressive", section(results, checks, args.sets, curve, args.sizes[0], ms))
    print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
