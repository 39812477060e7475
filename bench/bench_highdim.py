"""High-dimensional generation: bnot-10d through libdpc, written to docs/performance.md.

    python bench/bench_highdim.py [--against REV] [--previous REV] [--max-m M]

bnot-10d is 40 layers over one 10-D subspace of radius one mean spacing: at m = 8,192 that is
0.41 of the torus on every axis, yet only about 3 points lie within it of each point. The
all-pairs scan visited all m; the neighbour prefilter (libdpc/src/cpu/cpu_near.h) finds the
points in reach, and two tiers of neighbour lists kept across layers (libdpc/src/cpu/cpu_lists.h)
spare most layers any scan; the kernel then visits exactly the listed points
(cpu_kernels.h: dpc_list_fn), with the bits of all pairs. Measured with bench/bench_generate.c
(Release, fastest ISA):
1. this tree at m = 1,024 ... --max-m (default 65,536) on one and two threads: wall medians;
2. revision REV (default 1e40f0e, the all-pairs scan) and this tree alternately, one thread,
   three rounds, m up to 8,192 (thread CPU time, which a busy machine disturbs less);
3. bnot-5d (5-D, radius 2 spacings: about 170 points in reach, so the lists are off and the
   prefilter runs every layer) the same way, to show what a denser subspace costs;
4. revision PREV (default c89e46c: one tier of lists, aligned blocks of candidates, a thread
   per loop) and this tree alternately on two threads (wall time), m = 8,192 ... 32,768.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from bench_generate import alternate, build_revision, run
from common import build, cpu_name, replace_section

import dpc

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "performance.md"


def fastest_isa() -> str:
    for isa in ("avx512", "avx2"):
        if dpc.isa_supported(isa):
            return isa
    return "scalar"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--against", default="1e40f0e", metavar="REV")
    ap.add_argument("--previous", default="c89e46c", metavar="REV")
    ap.add_argument("--max-m", type=int, default=65536)
    args = ap.parse_args()
    exe, old, prev = build("dpc_bench_generate"), build_revision(args.against), build_revision(args.previous)
    isa = fastest_isa()
    ten = ROOT / "models" / "bnot-10d.onnx"
    counts = [m for m in (1024, 2048, 4096, 8192, 16384, 32768, 65536) if m <= args.max_m]
    scaling = {t: {r["m"]: r["median_s"] for r in run(exe, ten, f"{isa}:{t}", counts)} for t in (1, 2)}
    lines = [
        f"Measured by `python bench/bench_highdim.py` on {cpu_name()}, ISA `{isa}`; medians of repeated runs "
        "after a warm-up.",
        "",
        "`bnot-10d` (40 layers, one 10-D subspace), wall time per set:",
        "",
        "| points | 1 thread | 2 threads | 2 threads: ms per 1,000 points |",
        "|---:|---:|---:|---:|",
    ]
    for m in counts:
        a, b = scaling[1][m], scaling[2][m]
        lines.append(f"| {m:,} | {a * 1e3:,.1f} ms | {b * 1e3:,.1f} ms | {b * 1e6 / m:.2f} |")
    ms = np.array(counts, float)
    slope = float(np.polyfit(np.log(ms), np.log([scaling[2][m] for m in counts]), 1)[0])
    lines += ["", f"Scaling exponent on two threads (slope of log time against log m): {slope:.2f}.", ""]
    small = [m for m in counts if m <= 8192]
    lines += [
        f"Against revision `{args.against}` (all pairs), one thread, thread CPU time, three alternating rounds:",
        "",
        f"| model | points | {args.against} | this tree | speed-up |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, ms_ in (("bnot-10d", small), ("bnot-5d", [1024, 8192])):
        a, b = alternate(old, exe, ROOT / "models" / f"{name}.onnx", isa, ms_)
        for m in ms_:
            ta, tb = a[m], b[m]
            lines.append(f"| `{name}` | {m:,} | {ta * 1e3:,.1f} ms | {tb * 1e3:,.1f} ms | {ta / tb:.1f}x |")
    mid = [m for m in (8192, 16384, 32768) if m <= args.max_m]
    lines += [
        "",
        f"Against revision `{args.previous}` (one tier of neighbour lists, aligned candidate blocks, a new "
        "thread per parallel loop), two threads, wall time, three alternating rounds:",
        "",
        f"| model | points | {args.previous} | this tree | speed-up |",
        "|---|---:|---:|---:|---:|",
    ]
    a, b = alternate(prev, exe, ten, f"{isa}:2", mid, key="median_s")
    for m in mid:
        lines.append(f"| `bnot-10d` | {m:,} | {a[m] * 1e3:,.1f} ms | {b[m] * 1e3:,.1f} ms | {a[m] / b[m]:.1f}x |")
    two = [t for t in (scaling[2].get(8192), b.get(8192)) if t is not None]
    if two:
        # both two-thread medians of this run (the scaling table's and the alternating rounds'):
        # on a shared host they can differ by a fifth, and the goal is met only if both are
        one = scaling[1][8192]
        goals = [
            ("<= 60 ms on 2 threads", max(two), 0.060, " and ".join(f"{t * 1e3:.0f} ms" for t in two)),
            ("<= 100 ms on 1 thread", one, 0.100, f"{one * 1e3:.0f} ms"),
        ]
        lines += ["", "| goal: 8,192 points through bnot-10d | measured | x goal | met |", "|---|---:|---:|---|"]
        for name, worst, limit, shown in goals:
            lines.append(f"| {name} | {shown} | {worst / limit:.2f} | {'yes' if worst <= limit else '**no**'} |")
        lines += ["", "(Two threads: the scaling table's median, then the alternating rounds'.)"]
    text = "\n".join(lines)
    print(text)
    replace_section(DOC, "bench_highdim", text)


if __name__ == "__main__":
    main()
