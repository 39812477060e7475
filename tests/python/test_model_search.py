"""One model search: dpc.load finds names with libdpc's dpc_model_find (the folders of
$DPC_MODEL_PATH, then the package's models, regular files only: a FIFO named like a model is
passed over, never opened), refuses a NUL and wrong types, and dpc.available_models() lists what
that search finds."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import dpc
from dpc import _core

_LOAD = "import sys, dpc; m = dpc.load(sys.argv[1]); print(m.path)"


def _load_in_child(spec: str, env: dict) -> subprocess.CompletedProcess:
    # a child process with a timeout: a load that blocks on a FIFO fails the test instead of hanging it
    return subprocess.run([sys.executable, "-c", _LOAD, spec], env=env, capture_output=True, text=True, timeout=60)


def test_the_package_libdpc_knows_the_bundled_models():
    folder = Path(_core.model_dir())
    assert (folder / "bnot-2d.onnx").is_file()
    assert dpc.model_path("bnot-2d") == folder / "bnot-2d.onnx"


def test_a_fifo_named_like_a_model_on_dpc_model_path_is_passed_over(tmp_path):
    os.mkfifo(tmp_path / "bnot-2d.onnx")
    env = dict(os.environ, DPC_MODEL_PATH=str(tmp_path))
    r = _load_in_child("bnot-2d", env)
    assert r.returncode == 0, r.stderr[-2000:]
    assert Path(r.stdout.strip()) == Path(_core.model_dir()) / "bnot-2d.onnx"
    r = _load_in_child(str(tmp_path / "bnot-2d.onnx"), env)  # as a path: refused at once
    assert r.returncode != 0 and "ModelIOError" in r.stderr and "a FIFO" in r.stderr, r.stderr[-2000:]


def test_dpc_model_path_comes_first_and_available_models_agrees(tmp_path, monkeypatch):
    shutil.copy(dpc.model_path("blue-2d"), tmp_path / "bnot-2d.onnx")  # shadows the bundled bnot-2d
    shutil.copy(dpc.model_path("blue-2d"), tmp_path / "mine.onnx")
    os.mkfifo(tmp_path / "fifo-model.onnx")
    (tmp_path / "folder.onnx").mkdir()
    (tmp_path / ".hidden.onnx").write_bytes(b"")
    monkeypatch.setenv("DPC_MODEL_PATH", f"/nonexistent:{tmp_path}")
    assert dpc.model_path("bnot-2d") == tmp_path / "bnot-2d.onnx"
    assert dpc.load("bnot-2d").name == dpc.load("blue-2d").name
    names = dpc.available_models()
    assert "mine" in names and "bnot-2d" in names
    assert "fifo-model" not in names and "folder" not in names and ".hidden" not in names
    for name in names:  # every listed name is found by the search
        assert dpc.model_path(name).is_file()
    with pytest.raises(dpc.ModelNotFoundError, match="bundled: .*mine"):
        dpc.load("fifo-model")


@pytest.mark.parametrize("spec", ["bnot-2d\x00", "bnot-2d\x00/etc/passwd", b"bnot\x00-2d", Path("a\x00b.onnx")])
def test_a_nul_in_a_name_or_path_is_refused(spec):
    with pytest.raises(dpc.InvalidArgumentError, match="NUL"):
        dpc.load(spec)
    with pytest.raises(dpc.InvalidArgumentError, match="NUL"):
        _core.find_model("bnot-2d\x00x")


@pytest.mark.parametrize("spec", [123, None, 2.5, ["bnot-2d"], object()])
def test_wrong_types_are_invalid_arguments_naming_what_is_accepted(spec):
    with pytest.raises(dpc.InvalidArgumentError, match=r"bundled name .*str or os\.PathLike") as e:
        dpc.load(spec)
    assert isinstance(e.value, ValueError)


def test_unknown_names_list_the_bundled_models():
    for spec in ("no-such-model", "x y", "white"):
        with pytest.raises(dpc.ModelNotFoundError, match="bundled: blue-10d, blue-2d"):
            dpc.load(spec)


def test_paths_are_loaded_as_they_are(tmp_path, monkeypatch):
    shutil.copy(dpc.model_path("blue-2d"), tmp_path / "copy.onnx")
    assert dpc.load(tmp_path / "copy.onnx").path == tmp_path / "copy.onnx"
    assert dpc.load(str(tmp_path / "copy.onnx")).dims == 2
    monkeypatch.chdir(tmp_path)
    shutil.copy(dpc.model_path("blue-2d"), tmp_path / "bnot-2d")  # a regular file in the working folder wins
    assert dpc.model_path("bnot-2d") == Path("bnot-2d")
    with pytest.raises(dpc.ModelIOError, match="missing.onnx"):
        dpc.load("missing.onnx")
