"""Runs the code blocks of README.md, docs/*.md (the manual) and docs/reports/*.md (the lab's
measurements) that a reader copies, on the installed package,
in a fresh copy of the repository's tracked files (so relative paths such as
models/bnot-2d.onnx resolve as they do for a reader).

Every fenced block needs a language (```text for output, pseudo-code and diagrams). A block in a
language a reader runs (bash, sh, python, c, cpp) needs one of these lines right before its fence:

    <!-- doc-test -->               run as written: bash with -euo pipefail, python with this
                                    interpreter; C/C++: a whole program, compiled and run
    <!-- doc-test: fragment -->     C/C++: the statements of a main function; compiled and run
                                    as `FRAGMENT_HEAD` + block + `return 0; }` (stdio.h,
                                    stdlib.h, stdint.h, string.h and dpc/dpc.h included)
    <!-- doc-test: loss MODEL -->   python: a [loss] source of the loss language (docs/training.md
                                    §3): compiled for MODEL's point count and dimensions and
                                    evaluated on a set MODEL generates
    <!-- doc-skip: REASON -->       not run; REASON says why (an install, a run of many minutes)

C is compiled with -std=c11, C++ with -std=c++17, both with -Wall -Wextra -Werror by gcc/g++ and
by clang/clang++, against the header and the library inside the installed dpc package
(dpc/include/dpc/dpc.h, dpc/lib/libdpc.so.N), and run in the checkout without DPC_MODEL_PATH
(that libdpc finds the package's dpc/models by itself). A block that fails fails the test with its output.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
FENCE = re.compile(r"^[ \t]*(```+)[ \t]*([^`\s]*)[^\n]*$")
MARK = re.compile(r"^[ \t]*<!-- doc-(test|skip)(?::[ \t]*(.*?))?[ \t]*-->[ \t]*$")
RUN_LANGS = {"bash": "bash", "sh": "bash", "shell": "bash", "python": "python", "py": "python"}
RUN_LANGS |= {"c": "c", "cpp": "cpp", "c++": "cpp", "cxx": "cpp"}
COMPILERS = {"c": (("gcc", "clang"), "-std=c11"), "cpp": (("g++", "clang++"), "-std=c++17")}
FRAGMENT_HEAD = (
    "#include <stdint.h>\n#include <stdio.h>\n#include <stdlib.h>\n#include <string.h>\n\n"
    '#include "dpc/dpc.h"\n\nint main(void) {\n'
)


@dataclass
class Block:
    doc: str
    line: int  # the fence's line, 1-based
    lang: str  # the fence's language, as written
    kind: str  # "bash", "python", "c", "cpp" or "" (not a language a reader runs)
    mark: str  # "test", "skip" or "" (no mark)
    arg: str  # the mark's argument: "fragment", "loss MODEL", a skip's reason
    code: str


def parse(doc: Path) -> list[Block]:
    name = doc.relative_to(REPO).as_posix() if doc.is_relative_to(REPO) else doc.name
    name = name.removeprefix("docs/")
    lines = doc.read_text(encoding="utf-8").split("\n")
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        ticks, lang = m.group(1), m.group(2).lower()
        end = next((j for j in range(i + 1, len(lines)) if lines[j].strip() == ticks), None)
        assert end is not None, f"{name}:{i + 1}: a fence that is never closed"
        indent = len(lines[i]) - len(lines[i].lstrip())
        code = "\n".join(ln[indent:] if ln[:indent].isspace() else ln for ln in lines[i + 1 : end]) + "\n"
        mk = MARK.match(lines[i - 1]) if i else None
        mark, arg = (mk.group(1), (mk.group(2) or "").strip()) if mk else ("", "")
        out.append(Block(name, i + 1, lang, RUN_LANGS.get(lang, ""), mark, arg, code))
        i = end + 1
    return out


def docs() -> list[Path]:
    """README, the manual (docs/*.md) and the lab's reports (docs/reports/*.md)."""
    manual, reports = sorted((REPO / "docs").glob("*.md")), sorted((REPO / "docs" / "reports").glob("*.md"))
    return [REPO / "README.md", *manual, *reports]


def all_blocks() -> list[Block]:
    return [b for d in docs() for b in parse(d)]


def run_params():
    return [pytest.param(b, id=f"{b.doc}:{b.line}") for b in all_blocks() if b.mark == "test"]


def problems(blocks: list[Block]) -> list[str]:
    """What breaks the rule of this file's docstring, one line per block."""
    bad = []
    for b in blocks:
        where = f"{b.doc}:{b.line}"
        if not b.lang:
            bad.append(f"{where}: a fence without a language (```text for output or pseudo-code)")
        elif b.kind and not b.mark:
            bad.append(f"{where}: ```{b.lang} is neither <!-- doc-test --> nor <!-- doc-skip: REASON -->")
        elif b.mark and not b.kind:
            bad.append(f"{where}: a doc-{b.mark} mark on ```{b.lang}, which is not run")
        elif b.mark == "skip" and len(b.arg) < 10:
            bad.append(f"{where}: doc-skip needs a reason")
        elif b.mark == "test" and b.arg:
            if b.arg == "fragment" and b.kind not in ("c", "cpp"):
                bad.append(f"{where}: 'fragment' is for C and C++ blocks")
            elif b.arg.startswith("loss ") and b.kind != "python":
                bad.append(f"{where}: 'loss MODEL' is for python blocks")
            elif b.arg != "fragment" and not re.fullmatch(r"loss [\w.-]+", b.arg):
                bad.append(f"{where}: unknown doc-test argument {b.arg!r}")
    return bad


def test_every_copyable_block_is_run_or_marked():
    """A block a reader copies is either run below or says why not; output and pseudo-code are
    ```text (or another non-code language), so nothing is unchecked by accident."""
    bad = problems(all_blocks())
    assert not bad, "\n".join(bad)


def test_the_checker_sees_unmarked_blocks(tmp_path):
    """The rule on a page with one block of each case: only the unmarked, unlabelled and
    wrongly marked ones are reported."""
    page = tmp_path / "page.md"
    page.write_text(
        "```bash\nls\n```\n<!-- doc-test -->\n```c\nint main(void) { return 0; }\n```\n"
        "<!-- doc-skip: a long run of many minutes -->\n```python\npass\n```\n```\nout\n```\n"
        "```text\nout\n```\n<!-- doc-test: fragment -->\n```python\npass\n```\n"
        "<!-- doc-skip: x -->\n  ```sh\n  ls\n  ```\n<!-- doc-test: loss bnot-2d -->\n```python\npass\n```\n",
        encoding="utf-8",
    )
    blocks = parse(page)
    assert [(b.line, b.kind, b.mark) for b in blocks] == [
        (1, "bash", ""),
        (5, "c", "test"),
        (9, "python", "skip"),
        (12, "", ""),
        (15, "", ""),
        (19, "python", "test"),
        (23, "bash", "skip"),
        (27, "python", "test"),
    ]
    assert blocks[6].code == "ls\n"
    assert [p.split(":")[1] for p in problems(blocks)] == ["1", "12", "19", "23"]


def test_the_docs_run_blocks_of_every_language():
    found = {(b.doc, b.kind) for b in all_blocks() if b.mark == "test"}
    for want in [("README.md", "bash"), ("README.md", "python"), ("README.md", "c"), ("training.md", "bash")]:
        assert want in found, want
    assert ("rendering.md", "python") in found and ("rendering.md", "cpp") in found
    assert ("reports/models.md", "python") in found


def test_every_report_says_it_is_measurements():
    """docs/reports/ holds the lab's output, not the manual: each page says so first, with the
    command that makes it and the machine it ran on."""
    pages = sorted((REPO / "docs" / "reports").glob("*.md"))
    assert len(pages) >= 5, pages
    for page in pages:
        head = page.read_text(encoding="utf-8").split("\n\n")[1]
        assert head.startswith("> Measurements, not the manual: made by `python "), (page.name, head[:80])
        assert "machine:" in head, (page.name, head[:200])


@pytest.fixture(scope="module")
def checkout(tmp_path_factory):
    """The files of the repository that git does not ignore, or the tree without build output."""
    dst = tmp_path_factory.mktemp("docs-checkout")
    try:
        files = (
            subprocess.run(
                ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                cwd=REPO,
                capture_output=True,
                check=True,
                timeout=60,
            )
            .stdout.decode()
            .split("\0")
        )
    except (OSError, subprocess.CalledProcessError):
        files = [
            str(p.relative_to(REPO))
            for p in REPO.rglob("*")
            if p.is_file() and p.relative_to(REPO).parts[0] not in ("build", "runs", ".git")
        ]
    for f in filter(None, files):
        src = REPO / f
        if src.is_file():
            (dst / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst / f)
    return dst


def installed_c_library() -> tuple[Path, Path]:
    """(include folder, libdpc.so.N) inside the installed dpc package."""
    import dpc._core

    pkg = Path(dpc._core.__file__).parent
    libs = sorted((pkg / "lib").glob("libdpc.so.*"))
    assert (pkg / "include" / "dpc" / "dpc.h").is_file() and libs, f"no dpc/include, dpc/lib in {pkg}"
    return pkg / "include", libs[0]


def check(r: subprocess.CompletedProcess, what: str):
    out = f"--- stdout\n{r.stdout[-4000:]}\n--- stderr\n{r.stderr[-4000:]}"
    assert r.returncode == 0, f"{what}: exit {r.returncode}\n{out}"


def run_compiled(b: Block, checkout: Path, tmp_path: Path):
    compilers, std = COMPILERS[b.kind]
    include, lib = installed_c_library()
    src = tmp_path / ("block.c" if b.kind == "c" else "block.cpp")
    src.write_text(FRAGMENT_HEAD + b.code + "return 0;\n}\n" if b.arg == "fragment" else b.code, encoding="utf-8")
    for cc in compilers:
        if shutil.which(cc) is None:
            pytest.fail(f"{cc} is not installed: the doc blocks are compiled by gcc and clang")
        exe = tmp_path / f"block-{cc}"
        flags = [std, "-Wall", "-Wextra", "-Werror", "-O1", f"-I{include}"]
        cmd = [cc, *flags, str(src), str(lib), f"-Wl,-rpath,{lib.parent}", "-lm", "-o", str(exe)]
        check(subprocess.run(cmd, capture_output=True, text=True, timeout=300), " ".join(cmd))
        # named models come from the package's dpc/models, which its libdpc finds beside itself
        env = {k: v for k, v in os.environ.items() if k != "DPC_MODEL_PATH"}
        r = subprocess.run([str(exe)], cwd=checkout, env=env, capture_output=True, text=True, timeout=600)
        check(r, exe.name)


def check_loss(code: str, name: str):
    """A [loss] source compiled for the model's point count and dimensions, evaluated on 2 of its
    sets: a finite number. In this process (torch imports once for all of them)."""
    torch = pytest.importorskip("torch")
    import dpc
    from dpc_train.lossprog import compile_source

    model = dpc.load(name)
    loss = compile_source(code, model.n_points, model.dims, origin=f"loss of {name}")
    v = float(loss(torch.from_numpy(model.generate_batch(2, seed=0)).to(torch.float64)))
    assert math.isfinite(v), v


@pytest.mark.parametrize("b", run_params())
def test_doc_block_runs(checkout, tmp_path, b: Block):
    if b.kind in COMPILERS:
        run_compiled(b, checkout, tmp_path)
        return
    if b.arg.startswith("loss "):
        check_loss(b.code, b.arg.split()[1])
        return
    cmd = ["bash", "-euo", "pipefail", "-c", b.code] if b.kind == "bash" else [sys.executable, "-c", b.code]
    check(subprocess.run(cmd, cwd=checkout, capture_output=True, text=True, timeout=1200), b.kind)


def test_the_all_extra_brings_every_extra():
    """`pip install ".[all]"` (README, Installing) is every other extra in one install."""
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    extras = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]["optional-dependencies"]
    (ref,) = extras["all"]
    name, listed = re.fullmatch(r"([\w.-]+)\[([\w,-]+)\]", ref).groups()
    assert name == "deep-point-correlation" and sorted(listed.split(",")) == sorted(set(extras) - {"all"})
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    assert 'pip install ".[all]"' in readme


@pytest.mark.parametrize("src", sorted(p.name for p in (REPO / "docs" / "examples").glob("*.c")))
def test_the_docs_example_programs_compile_cleanly(tmp_path, src):
    """docs/examples/*.c, which the pages link as whole programs (the mask tests run them): no
    warning under gcc or clang either."""
    include, lib = installed_c_library()
    for cc in COMPILERS["c"][0]:
        exe = tmp_path / f"{src}-{cc}"
        flags = ["-std=c11", "-Wall", "-Wextra", "-Werror", "-O1", f"-I{include}"]
        cmd = [cc, *flags, str(REPO / "docs" / "examples" / src), str(lib), "-lm", "-o", str(exe)]
        check(subprocess.run(cmd, capture_output=True, text=True, timeout=300), cc)
