"""Generation benchmark for libdpc (single thread), written to docs/performance.md.

    python bench/bench_generate.py [--quick]

Builds libdpc and bench/bench_generate.c in build/bench (Release), then measures:
1. dpc_generate_n with models/repulsion-2d.onnx (2-D, 40 layers, rho = 3.2 spacings, about 32
   neighbours per point) at m = 1,024 / 16,384 / 262,144 / 1,048,576, on every ISA path the CPU
   has (scalar, AVX2, AVX-512);
2. the scaling exponent: least-squares slope of log(time) against log(m);
3. all-pairs throughput: a 2-D model whose radius covers the torus (every pair interacts),
   m = 4,096, 4 layers: m^2 * layers / time pair interactions per second;
4. the trained 2-D blue-noise models bnot-2d (rho = 4) and bnot-2d-wide (rho = 8) at m = 1,024
   and 65,536 on the fastest ISA;
5. the cascade against its arithmetic limit: bnot-2d at 1,024 and 65,536 points on the AVX2 and
   AVX-512 paths against (operations per neighbour pair x measured neighbours per point and layer
   / the core's peak rate of float vector operations, bench/bench_peak.c);
6. the progressive models (docs/progressive.md) at 1,024 and 65,536 points on the fastest ISA,
   against bnot-2d's time in the same run (goal for a progressive model: at most 1.5x).
Medians over repeated runs; ratios are taken within this one run.

    python bench/bench_generate.py --pmj-src PMJ_CPP

also builds bench/bench_pmj.cpp against a checkout of pmj-cpp (github.com/Andrew-Helmer/pmj-cpp)
and times bnot-2d beside its PMJ02BN at 1,024 and 65,536 points on each vector ISA: the section
"bnot-2d beside PMJ02BN" (goal: dpc at least 2.5x faster).

    python bench/bench_generate.py --against REV

also builds the benchmark from git revision REV (e.g. the commit before a kernel change) and
times both builds alternately, seven rounds, on every vector ISA the CPU has (repulsion-2d and
bnot-2d at 1,024 / 16,384 / 262,144 points): the section "Against REV" of docs/performance.md.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import subprocess
from pathlib import Path

import numpy as np
from common import BUILD, ROOT, build, cpu_name


def build_revision(rev: str) -> Path:
    """The benchmark program of git revision rev, built in build/bench-REV."""
    import tarfile
    import tempfile

    sha = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "--short", rev], check=True, capture_output=True, text=True
    ).stdout.strip()
    src, out = ROOT / "build" / f"src-{sha}", ROOT / "build" / f"bench-{sha}"
    if not (src / "CMakeLists.txt").is_file():
        with tempfile.TemporaryFile() as f:
            subprocess.run(["git", "-C", str(ROOT), "archive", sha], check=True, stdout=f)
            f.seek(0)
            with tarfile.open(fileobj=f) as t:
                t.extractall(src, filter="data")
    return build("dpc_bench_generate", src, out)


def against(rev: str, exe: Path, isas: list[str]) -> list[str]:
    """Both builds alternated, three rounds; the per-round medians' median of each."""
    old = build_revision(rev)
    counts = [1024, 16384, 262144]
    lines = [
        "",
        f"## Against {rev}",
        "",
        f"`python bench/bench_generate.py --against {rev}`: this tree and revision {rev} built alike and "
        "timed alternately (seven rounds, so that a burst of load on a shared host moves no median; medians "
        "of thread CPU time, which a busy machine disturbs less than wall time).",
        "",
        f"| model | ISA | points | {rev} | this tree | ratio |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for name in ("repulsion-2d", "bnot-2d"):
        model = ROOT / "models" / f"{name}.onnx"
        for isa in isas:
            a, b = alternate(old, exe, model, isa, counts, rounds=7)
            for m in counts:
                ta, tb = a[m], b[m]
                lines.append(f"| `{name}` | {isa} | {m:,} | {ta * 1e3:.2f} ms | {tb * 1e3:.2f} ms | {tb / ta:.2f}x |")
    return lines


def pmj_section(src: str, isas: list[str]) -> list[str]:
    """bnot-2d beside PMJ02BN (pmj-cpp, built from the checkout src in the bench's build folder),
    one process per vector ISA, each generator warmed up and timed in turn, seven rounds."""
    exe = build("dpc_bench_pmj", ROOT, BUILD, f"-DDPC_PMJ_SRC={Path(src).resolve()}")
    model = ROOT / "models" / "bnot-2d.onnx"
    lines = [
        "",
        "## bnot-2d beside PMJ02BN (pmj-cpp)",
        "",
        "`python bench/bench_generate.py --pmj-src PMJ_CPP`: Christensen et al. 2018's PMJ02BN as "
        "`pmj::GetPMJ02SamplesWithBlueNoise` of Andrew Helmer's pmj-cpp (github.com/Andrew-Helmer/pmj-cpp, "
        "MIT; its sources built by bench/CMakeLists.txt from the checkout given, never copied into this "
        "repository), and dpc_generate_n of bnot-2d, in one process (`bench/bench_pmj.cpp`): seven rounds, "
        "each generator warmed up and timed in turn; medians of thread CPU time. Goal: dpc at least 2.5x "
        "faster.",
        "",
        "| ISA | points | bnot-2d | PMJ02BN | PMJ02BN / bnot-2d | >= 2.5x |",
        "|---|---:|---:|---:|---:|---|",
    ]
    for isa in isas:
        out = subprocess.run(
            [str(exe), str(model), isa, "7", "1024", "65536"], check=True, capture_output=True, text=True
        ).stdout
        for r in (json.loads(line) for line in out.splitlines() if line.startswith("{")):
            t, p = r["dpc_cpu_median_s"], r["pmj02bn_cpu_median_s"]
            lines.append(
                f"| {isa} | {r['m']:,} | {t * 1e3:.2f} ms | {p * 1e3:.2f} ms | {p / t:.2f}x | "
                f"{'yes' if p >= 2.5 * t else '**no**'} |"
            )
    return lines


def alternate(
    old: Path, exe: Path, model: Path, isa: str, counts: list[int], key: str = "cpu_median_s", rounds: int = 3
) -> tuple[dict, dict]:
    """Thread CPU time (or, key="median_s", wall time: for several threads) per count of two
    builds run alternately, `rounds` rounds: the median of each build's per-round medians."""
    a = {m: [] for m in counts}
    b = {m: [] for m in counts}
    for _ in range(rounds):
        for r in run(old, model, isa, counts):
            a[r["m"]].append(r[key])
        for r in run(exe, model, isa, counts):
            b[r["m"]].append(r[key])
    return {m: float(np.median(a[m])) for m in counts}, {m: float(np.median(b[m])) for m in counts}


def all_pairs_model() -> Path:
    from dpc.model_file import Layer, ModelSpec, write_model

    path = BUILD / "all-pairs-2d.onnx"
    kernel = -0.01 * np.linspace(1.0, 0.0, 32)[None, :]
    layers = [Layer([0b11], [1e6], kernel) for _ in range(4)]  # radius clamps to 0.5: all pairs
    write_model(ModelSpec(dims=2, n_points=4096, layers=layers, name="all-pairs-2d"), path)
    return path


def run(exe: Path, model: Path, isa: str, counts: list[int]) -> list[dict]:
    out = subprocess.run(
        [str(exe), str(model), isa, *map(str, counts)], check=True, capture_output=True, text=True
    ).stdout
    return [json.loads(line) for line in out.splitlines() if line.strip()]


OPS_FIXED, OPS_PER_DIM = 26, 5
"""Float operations per neighbour pair of a k-D subspace in the canonical evaluation order
(docs/model-format.md §3), one lane each: per dimension the difference, rint, the wrapped
difference, its square's FMA and the sum's FMA (5k); the window's two comparisons, 1/sqrt (two
integer operations, six multiplications, two FMAs), sqrt (two multiplications, two FMAs), the bin
position (multiply, minimum), bin and fraction (two conversions, a minimum, a subtraction), two
table entries and the FMA between them, and g * y (26). 36 for 2-D."""


def neighbours(model: Path, m: int) -> float:
    """Mean number of other points in a layer's window (eps < d < r, on the torus) per point and
    layer, counted on the model's output set of m points (seed 1)."""
    from scipy.spatial import cKDTree  # noqa: PLC0415

    import dpc  # noqa: PLC0415
    from dpc.model_file import read_model  # noqa: PLC0415

    spec = read_model(model)
    x = np.asarray(dpc.load(str(model)).generate(seed=1, n_points=m), dtype=np.float64)
    tree = cKDTree(np.mod(x, 1.0), boxsize=1.0)
    h = m ** (-1.0 / spec.dims)
    counts = []
    for layer in spec.layers:
        r, e = min(float(layer.radius[0]) * h, 0.5), float(layer.eps) * h
        inside = tree.count_neighbors(tree, r) - tree.count_neighbors(tree, e)  # ordered pairs, self at e
        counts.append(inside / m)
    return float(np.mean(counts))


def peak_rates() -> dict:
    """{isa: (lanes, peak vector operations per second)} from bench_peak.c: the better of FMAs
    alone and FMAs beside additions."""
    exe = build("dpc_bench_peak")
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout
    rates = {}
    for line in out.splitlines():
        r = json.loads(line)
        rates[r["isa"]] = (r["lanes"], max(r["fma_ops_per_s"], r["mixed_ops_per_s"]), r)
    return rates


def limit_section(measured: dict) -> tuple[list[str], list[tuple[str, str, bool]]]:
    """The bnot-2d cascade on the vector paths against its arithmetic limit, and the goals;
    measured: {isa: run() rows of bnot-2d at 1,024 and 65,536 points}."""
    model = ROOT / "models" / "bnot-2d.onnx"
    from dpc.model_file import read_model  # noqa: PLC0415

    layers, k = len(read_model(model).layers), 2
    ops = OPS_FIXED + OPS_PER_DIM * k
    peaks = peak_rates()
    counts = [1024, 65536]
    nb = {m: neighbours(model, m) for m in counts}
    lines = [
        "",
        "## The cascade against its arithmetic limit (`bnot-2d`)",
        "",
        f"Limit per point and layer = operations per neighbour pair ({ops} for 2-D: the canonical order of "
        "[model-format.md §3](model-format.md#3-what-one-pointfilter-computes), counted in `bench_generate.py`) x "
        "measured neighbours per point and layer (points in the window eps < d < r of the output set) / the "
        "core's peak rate of float lane operations (`bench/bench_peak.c`: the better of independent FMAs alone "
        "and FMAs beside additions).",
        "",
        "| ISA | peak: FMAs alone | peak: FMAs + adds | lanes |",
        "|---|---:|---:|---:|",
    ]
    vec = [isa for isa in measured if isa in peaks]
    for isa in vec:
        lanes, _, r = peaks[isa]
        lines.append(
            f"| {isa} | {r['fma_ops_per_s'] / 1e9:.2f} G vector ops/s | {r['mixed_ops_per_s'] / 1e9:.2f} G | {lanes} |"
        )
    lines += [
        "",
        "| ISA | points | neighbours | limit per point and layer | limit | measured | x limit |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    checks = []
    goal_ms = {"avx512": 2.0, "avx2": 3.0}
    for isa in vec:
        lanes, peak, _ = peaks[isa]
        for r in measured[isa]:
            m = r["m"]
            per = ops * nb[m] / (lanes * peak)
            limit = per * m * layers
            t = r["cpu_median_s"]
            lines.append(
                f"| {isa} | {m:,} | {nb[m]:.1f} | {per * 1e9:.1f} ns | {limit * 1e3:.2f} ms | {t * 1e3:.2f} ms | "
                f"{t / limit:.1f}x |"
            )
            name = f"bnot-2d, {m:,} points, {isa}"
            checks.append((f"{name}: <= 2x the arithmetic limit", f"{t / limit:.1f}x", t <= 2 * limit))
            if isa in goal_ms:
                per_k = t * 1024 / m * 1e3
                checks.append(
                    (
                        f"{name}: <= {goal_ms[isa]:.1f} ms per 1,024 points",
                        f"{per_k:.2f} ms",
                        per_k <= goal_ms[isa],
                    )
                )
    lines += ["", "Thread CPU time (median); the limit is the time the arithmetic alone takes at the peak rate."]
    return lines, checks


PROGRESSIVE = ("progressive-2d", "progressive-2d-balanced")
PROGRESSIVE_GOAL = 1.5  # a progressive model's time over bnot-2d's


def progressive_section(exe: Path, isa: str, bnot: list[dict]) -> tuple[list[str], list[tuple[str, str, bool]]]:
    """The progressive models' generation (levels, the order within them) against bnot-2d's,
    measured in this run; progressive-2d-relaxed (about 1.2 s per 1,024 points) is left out."""
    from dpc.model_file import read_model

    lines = [
        "",
        f"## Progressive models ({isa})",
        "",
        "Made level by level, the earlier points held (docs/progressive.md), then each level put in its "
        f"order; the time over bnot-2d's at the same count in this run (goal: at most {PROGRESSIVE_GOAL}x).",
        "",
        "| model | layers | m = 1,024 | over bnot-2d | m = 65,536 | over bnot-2d |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    checks = []
    for name in PROGRESSIVE:
        path = ROOT / "models" / f"{name}.onnx"
        r = run(exe, path, isa, [1024, 65536])
        ratios = [r[k]["median_s"] / bnot[k]["median_s"] for k in range(2)]
        lines.append(
            f"| `{name}` | {len(read_model(path).layers)} | {r[0]['median_s'] * 1e3:.2f} ms | {ratios[0]:.2f}x"
            f" | {r[1]['median_s'] * 1e3:.1f} ms | {ratios[1]:.2f}x |"
        )
        for m, ratio in zip((1024, 65536), ratios):
            checks.append(
                (
                    f"{name}: <= {PROGRESSIVE_GOAL}x bnot-2d's time at {m:,} points ({isa})",
                    f"{ratio:.2f}x",
                    ratio <= PROGRESSIVE_GOAL,
                )
            )
    return lines, checks


def kept_section(previous: str, heading: str) -> list[str]:
    """The section of the previous page under the heading (a regex), kept until the next run that
    measures it; none if it has none."""
    kept = re.search(heading, previous)
    if not kept:
        return []
    end = previous.find("\n## ", kept.start() + 1)
    return previous[kept.start() : end if end >= 0 else None].rstrip("\n").split("\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="skip the 1,048,576-point runs")
    ap.add_argument("--out", default=str(ROOT / "docs" / "performance.md"))
    ap.add_argument("--against", metavar="REV", help="also time git revision REV's build, alternately")
    ap.add_argument("--pmj-src", metavar="PMJ_CPP", help="a pmj-cpp checkout: also time PMJ02BN beside bnot-2d")
    args = ap.parse_args()
    exe = build("dpc_bench_generate")
    counts = [1024, 16384, 262144] + ([] if args.quick else [1048576])
    import dpc  # noqa: PLC0415  (the installed package, for dpc.isa_supported)

    isas = [isa for isa in ("scalar", "avx2", "avx512") if dpc.isa_supported(isa)]
    model = ROOT / "models" / "repulsion-2d.onnx"
    rows = {isa: run(exe, model, isa, counts) for isa in isas}
    ap_model = all_pairs_model()
    pairs = {isa: run(exe, ap_model, isa, [4096])[0] for isa in isas}

    lines = [
        "# Performance",
        "",
        "Measured by `python bench/bench_generate.py` (single thread, Release build, medians of "
        "repeated runs; one run of the script gives every number and ratio below).",
        "",
        f"Machine: {cpu_name()}, {os.cpu_count()} logical CPUs, {platform.system()} {platform.machine()}.",
        "",
        "## Generation: 2-D, 40 layers, about 32 neighbours per point (`models/repulsion-2d.onnx`)",
        "",
        "| points m | "
        + " | ".join(f"{isa} median (CPU)" for isa in isas)
        + "".join(f" | {isa} speed-up" for isa in isas[1:])
        + " |",
        "|---:|" + "---:|" * (2 * len(isas) - 1),
    ]
    for k, m in enumerate(counts):
        cells = [f"{rows[isa][k]['median_s'] * 1e3:.2f} ms ({rows[isa][k]['cpu_median_s'] * 1e3:.2f})" for isa in isas]
        ratios = [f"{rows['scalar'][k]['median_s'] / rows[isa][k]['median_s']:.2f}x" for isa in isas[1:]]
        lines.append(f"| {m:,} | " + " | ".join(cells + ratios) + " |")
    lines += ["", "Scaling exponent (slope of log time against log m over the counts above):", ""]
    exps = {}
    for isa in isas:
        t = np.array([r["median_s"] for r in rows[isa]])
        exps[isa] = float(np.polyfit(np.log(counts), np.log(t), 1)[0])
        lines.append(f"- {isa}: {exps[isa]:.3f}")
    lines += [
        "",
        "## All-pairs throughput (radius covers the torus; m = 4,096, 4 layers)",
        "",
        "| ISA | median | pair interactions/s |",
        "|---|---:|---:|",
    ]
    rates = {}
    for isa in isas:
        r = pairs[isa]
        rates[isa] = 4096**2 * r["layers"] / r["median_s"]
        lines.append(f"| {isa} | {r['median_s'] * 1e3:.2f} ms | {rates[isa] / 1e9:.3f} G |")
    best = isas[-1]
    # The trained 2-D blue-noise models: the receptive field (rho, read from the file) sets the
    # neighbour count.
    from dpc.model_file import read_model

    lines += [
        "",
        f"## Trained 2-D blue-noise models ({best}, 40 layers)",
        "",
        "| model | rho (mean spacings) | m = 1,024 | m = 65,536 |",
        "|---|---:|---:|---:|",
    ]
    # bnot-2d on every vector path once: the best one's rows here, all of them for the limit
    bnot = ROOT / "models" / "bnot-2d.onnx"
    bnot_rows = {isa: run(exe, bnot, isa, [1024, 65536]) for isa in isas if isa != "scalar"}
    for name in ("bnot-2d", "bnot-2d-wide"):
        path = ROOT / "models" / f"{name}.onnx"
        rho = read_model(path).layers[0].radius[0]
        r = bnot_rows[best] if name == "bnot-2d" and best in bnot_rows else run(exe, path, best, [1024, 65536])
        lines.append(f"| `{name}` | {rho:g} | {r[0]['median_s'] * 1e3:.2f} ms | {r[1]['median_s'] * 1e3:.1f} ms |")
    limit_lines, limit_checks = limit_section(bnot_rows)
    lines += limit_lines
    progressive_lines, progressive_checks = progressive_section(
        exe, best, bnot_rows.get(best) or run(exe, bnot, best, [1024, 65536])
    )
    lines += progressive_lines
    lines += ["", f"Load average while measuring: {os.getloadavg()[0]:.2f} (1 min) on {os.cpu_count()} CPUs."]
    t1k = rows[best][0]["median_s"]
    checks = [(f"1,024 points <= 2 ms ({best})", f"{t1k * 1e3:.2f} ms", t1k <= 2e-3)]
    if 1048576 in counts:
        t1m = rows[best][counts.index(1048576)]["median_s"]
        checks.append((f"1,048,576 points <= 3 s ({best})", f"{t1m:.2f} s", t1m <= 3.0))
    checks.append((f"scaling exponent <= 1.1 ({best})", f"{exps[best]:.3f}", exps[best] <= 1.1))
    if "avx2" in rates:
        checks.append(
            (
                "all-pairs >= 0.5 G pair interactions/s per core with AVX2",
                f"{rates['avx2'] / 1e9:.3f} G/s",
                rates["avx2"] >= 0.5e9,
            )
        )
    checks += limit_checks + progressive_checks
    lines += ["", "## Against the speed targets", "", "| target | measured | met |", "|---|---:|---|"]
    lines += [f"| {name} | {value} | {'yes' if ok else '**no**'} |" for name, value, ok in checks]
    lines += [
        "",
        "Wall-clock medians; thread CPU time in parentheses (it differs from wall time only "
        "when the machine is busy). `auto` picks the last column's ISA on this CPU.",
    ]
    out = Path(args.out)
    previous = out.read_text() if out.exists() else ""
    if args.pmj_src:
        lines += pmj_section(args.pmj_src, [isa for isa in isas if isa != "scalar"])
    else:
        lines += kept_section(previous, r"\n## bnot-2d beside PMJ02BN")
    if args.against:
        lines += against(args.against, exe, isas[1:] or ["scalar"])
    else:
        lines += kept_section(previous, r"\n## Against (?!the )")
    lines.append("")
    text = "\n".join(lines)
    print(text)
    if previous:  # keep other sections (e.g. training speed) written by other benchmarks
        marker = "\n## Training"
        if marker in previous:
            text += previous[previous.index(marker) :]
    out.write_text(text)
    print(f"\nwrote {out}")


if __name__ == "__main__":
    main()
