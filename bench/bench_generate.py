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
   and 65,536 on the fastest ISA.
Medians over repeated runs; ratios are taken within this one run.

    python bench/bench_generate.py --against REV

also builds the benchmark from git revision REV (e.g. the commit before a kernel change) and
times both builds alternately, three rounds, on every vector ISA the CPU has (repulsion-2d and
bnot-2d at 1,024 / 16,384 / 262,144 points): the section "Against REV" of docs/performance.md.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
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
        "timed alternately (three rounds; medians of thread CPU time, which a busy machine disturbs less "
        "than wall time).",
        "",
        f"| model | ISA | points | {rev} | this tree | ratio |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for name in ("repulsion-2d", "bnot-2d"):
        model = ROOT / "models" / f"{name}.onnx"
        for isa in isas:
            a, b = alternate(old, exe, model, isa, counts)
            for m in counts:
                ta, tb = a[m], b[m]
                lines.append(f"| `{name}` | {isa} | {m:,} | {ta * 1e3:.2f} ms | {tb * 1e3:.2f} ms | {tb / ta:.2f}x |")
    return lines


def alternate(
    old: Path, exe: Path, model: Path, isa: str, counts: list[int], key: str = "cpu_median_s"
) -> tuple[dict, dict]:
    """Thread CPU time (or, key="median_s", wall time: for several threads) per count of two
    builds run alternately, three rounds: the median of each build's per-round medians."""
    a = {m: [] for m in counts}
    b = {m: [] for m in counts}
    for _ in range(3):
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="skip the 1,048,576-point runs")
    ap.add_argument("--out", default=str(ROOT / "docs" / "performance.md"))
    ap.add_argument("--against", metavar="REV", help="also time git revision REV's build, alternately")
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
    for name in ("bnot-2d", "bnot-2d-wide"):
        path = ROOT / "models" / f"{name}.onnx"
        rho = read_model(path).layers[0].radius[0]
        r = run(exe, path, best, [1024, 65536])
        lines.append(f"| `{name}` | {rho:g} | {r[0]['median_s'] * 1e3:.2f} ms | {r[1]['median_s'] * 1e3:.1f} ms |")
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
    lines += ["", "## Against the speed targets", "", "| target | measured | met |", "|---|---:|---|"]
    lines += [f"| {name} | {value} | {'yes' if ok else '**no**'} |" for name, value, ok in checks]
    lines += [
        "",
        "Wall-clock medians; thread CPU time in parentheses (it differs from wall time only "
        "when the machine is busy). `auto` picks the last column's ISA on this CPU.",
    ]
    out = Path(args.out)
    previous = out.read_text() if out.exists() else ""
    if args.against:
        lines += against(args.against, exe, isas[1:] or ["scalar"])
    elif "\n## Against " in previous:  # keep the last comparison until the next one
        start = previous.index("\n## Against ")
        end = previous.find("\n## ", start + 1)
        lines += previous[start : end if end >= 0 else None].rstrip("\n").split("\n")
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
