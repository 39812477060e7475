"""Rules that keep the repository readable (tests/run_all.sh runs this file in its formatting stage):
no edits of the import path; every Python file under ruff and the formatter; no tracker numbers in
repository files; no duplicated code in the product tree; docs/architecture.md names the folders
the tree has. Nothing here imports dpc."""

from __future__ import annotations

import ast
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    tomllib = pytest.importorskip("tomli")

REPO = Path(__file__).resolve().parents[2]
# Files made by a program, not written by hand (their makers are the files to read).
GENERATED = {"libdpc/src/vulkan/vk_spirv.h", "libdpc/src/sampler/sampler_mask.c"}
# The product: what ships or builds what ships (not the tests, the lab or the benchmarks).
PRODUCT = ("libdpc", "python/dpc", "bindings", "training")
BINARY = {".onnx", ".png", ".jpg", ".exr", ".npz", ".npy", ".pdf", ".gz", ".zip", ".bin", ".spv", ".ico"}


def tracked(*folders: str) -> list[str]:
    """The repository's files (git's list; a walk of the tree outside a git checkout)."""
    try:
        out = subprocess.run(
            ["git", "-C", str(REPO), "ls-files", "-z", "--", *folders], capture_output=True, check=True, text=True
        ).stdout
        names = [n for n in out.split("\0") if n]
    except (OSError, subprocess.CalledProcessError):
        skip = {".git", "build", "runs", "__pycache__"}
        names = []
        for top in folders or (".",):
            for root, dirs, files in os.walk(REPO / top):
                dirs[:] = [d for d in dirs if d not in skip and not d.endswith(".egg-info")]
                names += [os.path.relpath(os.path.join(root, f), REPO) for f in files]
    return sorted(n for n in names if (REPO / n).is_file())


def python_files() -> list[str]:
    return [n for n in tracked() if n.endswith(".py")]


# ---- no edits of the import path --------------------------------------------------------------


def sys_path_uses(source: str) -> list[int]:
    """Lines that touch the interpreter's import path list: its attribute on the sys module (an
    insert, an assignment) or importing it from sys."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute) and node.attr == "path":
            if isinstance(node.value, ast.Name) and node.value.id == "sys":
                lines.append(node.lineno)
        elif isinstance(node, ast.ImportFrom) and node.module == "sys":
            lines += [node.lineno for a in node.names if a.name == "path"]
    return sorted(set(lines))


def test_the_sys_path_finder_sees_edits():
    attr = "sys" + ".path"  # built, so that no scanner finds an edit in this file
    assert sys_path_uses(f"import sys\n{attr}.insert(0, 'x')\n") == [2]
    assert sys_path_uses(f"import sys\n{attr} = []\n") == [2]
    assert sys_path_uses("from sys import " + "path\n") == [1]
    assert sys_path_uses(f"x = '{attr}'  # {attr} in a string\n") == []


def test_no_sys_path_edits():
    """Modules import each other as packages (lab.models.model_cards; pytest: pythonpath in
    pyproject.toml) or from a script's own folder; no file edits the import path."""
    hits = [f"{n}:{line}" for n in python_files() for line in sys_path_uses((REPO / n).read_text())]
    assert not hits, "import path edits: " + ", ".join(hits)


# ---- ruff and the formatter cover every Python file --------------------------------------------


def test_format_list_holds_every_python_file():
    """tests/format_files.sh py (the files the formatting stage runs ruff check and ruff format
    on) lists every Python file of the repository, and ruff's own configuration excludes none."""
    if shutil.which("bash") is None:
        pytest.skip("no bash")
    listed = subprocess.run(
        ["bash", str(REPO / "tests" / "format_files.sh"), "py"], capture_output=True, check=True, text=True
    ).stdout.split()
    missing = sorted(set(python_files()) - set(listed) - GENERATED)
    assert not missing, "not under ruff (add them to tests/format_files.sh): " + ", ".join(missing)
    ruff = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["ruff"]
    excluded = [e for e in ruff.get("exclude", []) + ruff.get("extend-exclude", []) if tracked(e)]
    assert not excluded, f"[tool.ruff] excludes tracked files: {excluded}"


# ---- no tracker numbers ---------------------------------------------------------------------

# A tracker's numbers mean nothing in the repository: name the feature instead. The patterns are
# written so that this file does not match them itself.
TRACKER = re.compile(
    r"\b[Ii]ssues?[ \t]+(?:#[ \t]?)?\d+"  # the word, then a number (with or without a number sign)
    r"|#\d+[ \t]+items?\b"  # a number sign, a number, then the word item
    r"|\b(?:PR|[Pp]ull [Rr]equest)[ \t]+#\d+"
)


def text_files() -> list[str]:
    return [n for n in tracked() if Path(n).suffix.lower() not in BINARY]


def tracker_hits(text: str) -> list[int]:
    return [i for i, line in enumerate(text.splitlines(), 1) if TRACKER.search(line)]


def test_the_tracker_pattern_sees_citations():
    word, a, b, c = "iss" + "ue", 12, 13, 14  # built, so that no scanner finds a citation in this file
    cited = (f"{word} #{a}", f"{word}s #{b} and {c}", f"#{c} item 2", f"({word} {c})", f"{word.title()} {c} item 3")
    for line in cited:
        assert tracker_hits(line) == [1], line
    for line in (f"## {c}. Items", f"an {word} with {c} points", "spp #" + "4", f"the {word}d 3 sets"):
        assert tracker_hits(line) == [], line


def test_no_tracker_numbers():
    hits = []
    for n in text_files():
        data = (REPO / n).read_bytes()
        if b"\0" in data:
            continue
        hits += [f"{n}:{line}" for line in tracker_hits(data.decode("utf-8", "replace"))]
    assert not hits, f"{len(hits)} tracker numbers (name the feature instead):\n" + "\n".join(hits)


# ---- no duplicated code in the product ------------------------------------------------------

# pybind11 registrations: py::arg lists and .def chains look alike by nature (one per binding);
# a line of them, or the end of a py::init<...> type list.
BINDING_LINE = re.compile(r"^\s*(?:\.def\(|mod\.def\(|mod\.attr\(|py::arg\(|\)\s*[,;]?\s*$|[\w:<>&*, ]+>\(\),?\s*$)")


def tool(module: str):
    """The duplicate-code tools: tests/run_all.sh installs them (pinned) and sets
    DPC_TEST_REQUIRE_TOOLS=1, so there a missing tool fails instead of skipping."""
    try:
        __import__(module)
    except ImportError:
        if os.environ.get("DPC_TEST_REQUIRE_TOOLS") == "1":
            raise
        pytest.skip(f"{module} is not installed (pip install lizard pylint)")


def product_files(pattern: str) -> list[str]:
    return [n for n in tracked(*PRODUCT) if re.search(pattern, n) and n not in GENERATED]


def binding_boilerplate(block: list[tuple[str, int, int]]) -> bool:
    """Every copy lies in the bindings and each of its lines registers a binding."""
    for name, first, last in block:
        if not name.startswith("bindings/"):
            return False
        lines = (REPO / name).read_text().splitlines()[first - 1 : last]
        if not all(BINDING_LINE.match(line) or "py::arg(" in line for line in lines):
            return False
    return True


def lizard_duplicates(files: list[str]) -> list[list[tuple[str, int, int]]]:
    """lizard's duplicate extension (C, C++ and Python): each block as its copies."""
    out = subprocess.run(
        [sys.executable, "-m", "lizard", "-Eduplicate", *files], cwd=REPO, capture_output=True, text=True
    ).stdout
    blocks, block = [], None
    for line in out[out.find("Duplicates") :].splitlines():
        if line.startswith("Duplicate block"):
            block = []
        elif line.startswith("^^^") and block is not None:
            blocks.append(block)
            block = None
        elif block is not None and (m := re.match(r"(\S+):(\d+) ~ (\d+)$", line.strip())):
            block.append((m[1], int(m[2]), int(m[3])))
    return blocks


def pylint_duplicates(files: list[str]) -> list[str]:
    """pylint's duplicate-code check (R0801) over the product's Python (4 similar lines or more;
    comments, docstrings, imports and signatures ignored)."""
    out = subprocess.run(
        [sys.executable, "-m", "pylint", "--rcfile=/dev/null", "--disable=all", "--enable=duplicate-code", *files],
        cwd=REPO,
        capture_output=True,
        text=True,
    ).stdout
    return ["\n".join(chunk.splitlines()[:3]) for chunk in out.split("R0801: ")[1:]]


def test_no_duplicate_code_in_the_product():
    """No pair of copied code in libdpc/, python/dpc/, bindings/, training/ (generated files and
    pybind11 registration lists aside): a rule written twice drifts."""
    tool("lizard")
    tool("pylint")
    blocks = [b for b in lizard_duplicates(product_files(r"\.(c|h|cpp|hpp|py)$")) if not binding_boilerplate(b)]
    found = [" = ".join(f"{n}:{a}-{b}" for n, a, b in block) for block in blocks]
    found += pylint_duplicates(product_files(r"\.py$"))
    assert not found, f"{len(found)} duplicated blocks:\n" + "\n".join(found)


def test_the_binding_rule_takes_only_registrations():
    assert BINDING_LINE.match('             py::arg("isa"), py::arg("threads"),')
    assert BINDING_LINE.match('        .def("info", &Model::info)')
    assert BINDING_LINE.match("                      py::object>(),")
    assert not BINDING_LINE.match("    const size_t st = ps->p->stride;")
    assert not BINDING_LINE.match("    std::vector<char> path(DPC_PATH_MAX);")


# ---- docs/architecture.md matches the tree --------------------------------------------------


def top_folders() -> set[str]:
    return {n.split("/")[0] for n in tracked() if "/" in n}


def architecture_paths() -> set[str]:
    """The folder paths the page names that start at a top-level folder (libdpc/src/cpu/), not
    install paths (share/dpc/) or folders named relative to another."""
    text = (REPO / "docs" / "architecture.md").read_text()
    tops = top_folders()
    return {p for p in re.findall(r"(?<![\w./-])(\.?[\w-]+(?:/[\w.-]+)*/)", text) if p.split("/")[0] in tops}


def test_architecture_names_only_folders_that_exist():
    missing = sorted(p for p in architecture_paths() if not (REPO / p).is_dir())
    assert not missing, "docs/architecture.md names folders the tree does not have: " + ", ".join(missing)


def test_architecture_names_every_top_folder_and_every_libdpc_layer():
    named = architecture_paths()
    want = {f"{t}/" for t in top_folders()}
    want |= {f"libdpc/src/{d.name}/" for d in (REPO / "libdpc" / "src").iterdir() if d.is_dir() and tracked(str(d))}
    missing = sorted(want - named)
    assert not missing, "folders docs/architecture.md does not name: " + ", ".join(missing)
