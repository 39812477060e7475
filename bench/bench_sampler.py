"""Sampler benchmark (dpc_sampler_*, one thread), written to docs/performance.md#sampler.

    python bench/bench_sampler.py

Builds bench/bench_sampler.c in build/bench (Release) and measures, with bnot-2d-stratified:
dpc_sampler_create for (samples per pixel, dimensions) = (1, 16), (4, 16), (16, 16), (64, 16),
(256, 16), (64, 64), (1024, 16); lookups in a renderer-style loop (256 x 256 pixels, every sample
index up to 64, 8 dimensions): ns per dpc_sampler_get_2d / _get_1d value, median of 11 passes,
with the default options (every slot a net where spp is a power of two >= 2) and for get_2d with
net_dims = 1 (the sets' lookup path in dimensions 1-7), and get_2d of dimension 0 alone (the net slot where spp is
a power of two); the table memory. Goals of the sampler issue: 64 spp x 16 dimensions built in <= 1 s, <= 10 ns per 2-D
value.
"""

from __future__ import annotations

import json
import subprocess

from common import ROOT, build, cpu_name

CASES = ["1:16", "4:16", "16:16", "64:16", "256:16", "64:64", "1024:16"]
MODEL = ROOT / "models" / "bnot-2d-stratified.onnx"


def main() -> None:
    exe = build("dpc_bench_sampler")
    out = subprocess.run([str(exe), str(MODEL), *CASES], check=True, capture_output=True, text=True).stdout
    rows = [json.loads(line) for line in out.splitlines() if line.strip()]
    cpu = cpu_name()
    lines = [
        "## Sampler",
        "",
        f"`python bench/bench_sampler.py` on {cpu}, one thread, `bnot-2d-stratified`. Construction: "
        "`dpc_sampler_create` (the model's cascade on the scalar path for every table that is not a net, then the "
        "projections' ranks, and the nets where spp is a power of two >= 2: by default every slot's), "
        "median over repeats. Lookups: ns per value in a renderer-style loop "
        "(256 x 256 pixels, sample indices up to 64, 8 dimensions), median of 11 passes, with the "
        'default options; "get_2d, sets" with `net_dims = 1` (dimensions 1-7 on the sets\' path, '
        "which the default takes at 1 spp and counts that are not powers of two); the last column is "
        "get_2d of dimension 0 alone "
        "(the net slot, or at 1 spp the shifted set). Below 64 spp the default's nets are screen-ordered: "
        "a lookup hashes the pixel's Morton code in its tile digit by digit (eight 64-bit hashes), "
        "where a per-pixel net takes one.",
        "",
        "| spp | dimensions | create (ms) | get_2d (ns) | get_1d (ns) | get_2d, sets (ns) | get_2d, dimension 0 (ns) "
        "| tables (bytes) |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['spp']} | {r['dims']} | {r['create_ms']:.2f} | {r['get_2d_ns']:.2f} | "
            f"{r['get_1d_ns']:.2f} | {r['get_2d_sets_ns']:.2f} | {r['get_2d_dim0_ns']:.2f} | {r['table_bytes']:,} |"
        )
        print(
            f"spp {r['spp']:4d} x {r['dims']:3d} dims: create {r['create_ms']:9.2f} ms, get_2d {r['get_2d_ns']:6.2f} "
            "ns, "
            f"get_1d {r['get_1d_ns']:6.2f} ns, get_2d sets {r['get_2d_sets_ns']:6.2f} ns, "
            f"get_2d of dimension 0 {r['get_2d_dim0_ns']:6.2f} ns"
        )
    main_case = next(r for r in rows if (r["spp"], r["dims"]) == (64, 16))
    worst_2d = max(max(r["get_2d_ns"], r["get_2d_sets_ns"], r["get_2d_dim0_ns"]) for r in rows)
    goals = [
        ("64 spp x 16 dimensions built in <= 1 s", main_case["create_ms"] <= 1000, f"{main_case['create_ms']:.1f} ms"),
        (
            "<= 10 ns per 2-D value (every case: all 8 dimensions, default and sets, and dimension 0 alone)",
            worst_2d <= 10,
            f"worst {worst_2d:.2f} ns",
        ),
    ]
    lines += ["", "| goal | met | measured |", "|---|---|---|"]
    for g, ok, m in goals:
        lines.append(f"| {g} | {'yes' if ok else '**no**'} | {m} |")
        print(f"[{'met' if ok else 'MISSED'}] {g}: {m}")
    section = "\n".join(lines) + "\n"
    doc = ROOT / "docs" / "performance.md"
    text = doc.read_text()
    start = text.find("## Sampler")
    if start >= 0:
        end = text.find("\n## ", start + 1)
        text = text[:start] + section + (text[end + 1 :] if end >= 0 else "")
    else:
        text = text.rstrip("\n") + "\n\n" + section
    doc.write_text(text)
    print(f"wrote {doc}")


if __name__ == "__main__":
    main()
