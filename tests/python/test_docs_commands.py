"""Runs every command block of README.md and docs/*.md marked with a line `<!-- doc-test -->`
right before its fence, on the installed package, in a fresh copy of the repository's tracked
files (so relative paths such as models/bnot-2d.onnx resolve as they do for a reader):
```bash blocks with bash -euo pipefail, ```python blocks with this interpreter. A block that
fails fails the test with its output. The marked blocks are the ones a reader runs as written;
the rest show output, placeholders or long runs."""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
MARK = re.compile(r"^<!-- doc-test -->\n```(bash|python)\n(.*?)^```$", re.MULTILINE | re.DOTALL)


def blocks():
    out = []
    for doc in [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]:
        for mt in MARK.finditer(doc.read_text(encoding="utf-8")):
            line = doc.read_text(encoding="utf-8")[: mt.start()].count("\n") + 1
            out.append(pytest.param(mt.group(1), mt.group(2), id=f"{doc.name}:{line}"))
    return out


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


def test_the_docs_mark_blocks():
    found = {p.id.split(":")[0] for p in blocks()}
    assert {"README.md", "training.md"} <= found, found


@pytest.mark.parametrize("lang, code", blocks())
def test_doc_block_runs(checkout, lang, code):
    cmd = ["bash", "-euo", "pipefail", "-c", code] if lang == "bash" else [sys.executable, "-c", code]
    r = subprocess.run(cmd, cwd=checkout, capture_output=True, text=True, timeout=1200)
    assert r.returncode == 0, f"exit {r.returncode}\n--- stdout\n{r.stdout[-4000:]}\n--- stderr\n{r.stderr[-4000:]}"
