"""Prefixes between the levels of a progressive set (docs/progressive.md, "Between the levels").

    python -m lab.progressive.bench_progressive_between   # 64 sets of 1,024 points: writes docs/reports/progressive.md

A sampler reads a progressive table in order, so a renderer that stops at n samples, n not a
power of two, gets the first n points: the levels up to the largest power of two below n and
the first points of the next level. The generator puts each level's points in the order that
fills the emptiest place first (docs/model-format.md §6, ``dpc.stratify.order_levels``). This
measures the prefixes at n = 1.25, 1.5 and 1.75 * 2^k and at the level sizes, for
progressive-2d and progressive-2d-relaxed as generated and with each level's points in a random
order (what the generator gave before the order, a control: the same sets), and for PMJ02BN,
scrambled Sobol' and white noise at the same n: E_low nu<0.5 over a dpc set made for n
(bnot-2d-stratified) and the Gaussian integrands' relative variance (16 integrands, as
bench_progressive.py). Set i from seed i. Also the order's share of progressive-2d's generation
time on one thread.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import dpc
from dpc import baselines
from dpc.analysis.integration import relative_variance
from dpc.analysis.spectrum import low_frequency_energy
from lab.common import cpu_name, replace_section
from lab.progressive.bench_progressive import DOC, FAMILIES, tree

MODELS = ["progressive-2d", "progressive-2d-relaxed"]
SET_MODEL = "bnot-2d-stratified"
BASE = 16
PREFIXES = [20, 24, 28, 40, 48, 56, 80, 96, 112, 160, 192, 224, 320, 384, 448, 640, 768, 896]
LEVELS = [16, 32, 64, 128, 256, 512, 1024]


def shuffled_levels(sets: np.ndarray, seed: int) -> np.ndarray:
    """Each set's levels (the first BASE points, then blocks doubling the count) in a random order."""
    rng = np.random.default_rng(seed)
    out = sets.copy()
    for s in out:
        n = BASE
        s[:n] = s[:n][rng.permutation(n)]
        while n < len(s):
            a = min(n, len(s) - n)
            s[n : n + a] = s[n : n + a][rng.permutation(a)]
            n += a
    return out


def run(count: int, m: int) -> tuple[list[str], dict[str, dict[int, tuple[float, float]]]]:
    ns = sorted(PREFIXES + LEVELS)
    plain = dpc.load(SET_MODEL, backend="cpu")
    ref = {n: low_frequency_energy(plain.generate_batch(count, 0, n).astype(np.float64), 0.5) for n in ns}
    samplers: dict[str, np.ndarray] = {}
    for name in MODELS:
        sets = dpc.load(name, backend="cpu").generate_batch(count, 0, m).astype(np.float64)
        samplers[name] = sets
        samplers[f"{name}, levels shuffled"] = shuffled_levels(sets, 1)
    for name in ("pmj02bn", "sobol", "white"):
        samplers[name] = baselines.generate(name, m, 2, count, 0)
    out: dict[str, dict[int, tuple[float, float]]] = {}
    for name, sets in samplers.items():
        out[name] = {
            n: (
                low_frequency_energy(sets[:, :n], 0.5) / ref[n],
                float(relative_variance(sets[:, :n], FAMILIES["gauss"]).mean()),
            )
            for n in ns
        }
        between = [out[name][n][0] for n in PREFIXES]
        print(f"{name:36s} between the levels: E_low / dpc set's {min(between):6.1f} .. {max(between):6.1f}")
    return list(samplers), out


def timings(sizes=(1024, 16384, 65536), repeats: int = 3) -> dict[int, tuple[float, float]]:
    """Median seconds, on one thread, of progressive-2d's generate (which includes the order) and
    of dpc.stratify.order_levels alone on its output, per set size."""
    model = dpc.load("progressive-2d", backend="cpu", threads=1)
    out = {}
    for m in sizes:
        gen, order = [], []
        for r in range(repeats):
            t = time.perf_counter()
            x = model.generate(r, m)
            gen.append(time.perf_counter() - t)
            t = time.perf_counter()
            dpc.stratify.order_levels(x)
            order.append(time.perf_counter() - t)
        out[m] = (float(np.median(gen)), float(np.median(order)))
        print(f"m = {m:6d}: generate {out[m][0] * 1e3:8.1f} ms, of which the order {out[m][1] * 1e3:6.1f} ms")
    return out


def section(names: list[str], res: dict, count: int, m: int, times: dict[int, tuple[float, float]]) -> str:
    ns = sorted(next(iter(res.values())))
    cols = " | ".join(names)
    head = ["| prefix n | " + cols + " |", "|---:|" + "---:|" * len(names)]

    def table(k: int, fmt: str) -> list[str]:
        rows = []
        for n in ns:
            label = f"**{n}**" if n in LEVELS else str(n)
            rows.append(f"| {label} | " + " | ".join(format(res[name][n][k], fmt) for name in names) + " |")
        return rows

    def worst(name: str, k: int = 0) -> float:
        return max(res[name][n][k] / res["pmj02bn"][n][k] for n in PREFIXES)

    lines = [
        f"Measured by `python -m lab.progressive.bench_progressive_between` (tree {tree()}): {count} sets of {m:,} "
        "points "
        f'of each sampler, set i from seed i; level sizes in bold. "levels shuffled": the same sets with each '
        "level's points in a random order (the generator's order before `order_levels`).",
        "",
        "Between the levels (n = 1.25, 1.5, 1.75 · 2^k), the worst ratio to PMJ02BN at the same n: "
        + "; ".join(
            f"{name} ×{worst(name):.2f} (E_low), ×{worst(name, 1):.2f} (Gaussian variance)" for name in names[:4]
        )
        + ".",
        "",
        "The order's cost, on one thread of "
        + cpu_name()
        + " (median of 3): "
        + "; ".join(
            f"{m:,} points: {o * 1e3:.1f} ms of progressive-2d's {g * 1e3:.0f} ms ({100 * o / g:.1f} %)"
            for m, (g, o) in times.items()
        )
        + ".",
        "",
        f"#### E_low ν<0.5 of the first n points over a {SET_MODEL} set of n points",
        "",
        *head,
        *table(0, ".1f"),
        "",
        "#### Gaussian rel. variance of the first n points",
        "",
        *head,
        *table(1, ".2e"),
    ]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sets", type=int, default=64)
    args = ap.parse_args()
    m = 1024
    names, res = run(args.sets, m)
    times = timings()
    replace_section(DOC, "bench_progressive_between", section(names, res, args.sets, m, times))
    print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
