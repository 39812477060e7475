"""What the benchmarks (and the lab's studies, through lab.common) share: the repository root,
the CPU's description, builds of the benchmark programs, and the generated part of a docs page:
the text between `<!-- NAME:begin -->` and `<!-- NAME:end -->`, which a benchmark replaces with
what it measured (the rest of the page is written by hand).

A benchmark imports it as `common` (Python puts a script's folder first on its path); the lab,
run from the repository root, as `bench.common`."""

from __future__ import annotations

import platform
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BUILD = ROOT / "build" / "bench"


def replace_section(doc: Path, name: str, body: str) -> None:
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    text = doc.read_text()
    new = f"{begin}\n{body}\n{end}"
    doc.write_text(re.sub(re.escape(begin) + ".*?" + re.escape(end), lambda _: new, text, flags=re.S))


def cpu_name() -> str:
    """The CPU's model name, with family/model and whether it has AVX-512: cloud CPUs often name
    only the brand ("AMD EPYC"), and which generation it is decides the ISA paths measured."""
    try:
        info = dict(
            (k.strip(), v.strip())
            for k, v in (line.split(":", 1) for line in Path("/proc/cpuinfo").read_text().splitlines() if ":" in line)
        )
    except OSError:
        return platform.processor() or "unknown CPU"
    simd = "AVX-512" if "avx512f" in info.get("flags", "").split() else "no AVX-512"
    family, model = info.get("cpu family", "?"), info.get("model", "?")
    return f"{info.get('model name', 'unknown CPU')} (family {family} model {model}, {simd})"


def build(target: str, source: Path = ROOT, folder: Path = BUILD, *defines: str) -> Path:
    """The Release build of one benchmark program (bench/CMakeLists.txt) of the tree at source,
    in folder; defines: more -D options (e.g. -DDPC_VULKAN=ON)."""
    subprocess.run(
        [
            "cmake",
            "-S",
            str(source),
            "-B",
            str(folder),
            "-G",
            "Ninja",
            "-DCMAKE_BUILD_TYPE=Release",
            "-DDPC_BUILD_BENCH=ON",
            *defines,
        ],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    subprocess.run(["cmake", "--build", str(folder), "--target", target], check=True, stdout=subprocess.DEVNULL)
    return folder / "bench" / target
