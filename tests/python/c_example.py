"""Compile one of docs/examples/*.c against a built libdpc (shared by the tests that run them)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def build(name: str, out_dir: Path, flags: tuple[str, ...] = ()) -> Path:
    """docs/examples/<name>.c compiled into out_dir; skips the test without a C compiler or a
    built libdpc. A plain (not sanitizer-instrumented) build: the Python package's, else any other."""
    libs = [
        p
        for p in sorted(ROOT.glob("build/py-*/libdpc/libdpc.so")) + sorted(ROOT.glob("build/**/libdpc/libdpc.so"))
        if "san" not in str(p.relative_to(ROOT))
    ]
    cc = shutil.which("cc")
    if not libs or cc is None:
        pytest.skip("needs a C compiler and a built libdpc (build/py-*/libdpc/libdpc.so)")
    lib, exe = libs[0].parent, out_dir / name
    src = ROOT / "docs" / "examples" / f"{name}.c"
    cmd = [cc, "-std=c11", "-O2", *flags, str(src), f"-I{ROOT / 'libdpc/include'}", f"-L{lib}", "-ldpc"]
    subprocess.run([*cmd, f"-Wl,-rpath,{lib}", "-o", str(exe)], check=True)
    return exe
