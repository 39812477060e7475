"""dpc_train is an installed package (pip install '.[train]'): the dpc-train and dpc-export
commands, python training/train.py in a checkout, public dpc APIs only, package data through
importlib.resources."""

from __future__ import annotations

import ast
import subprocess
import sys
from importlib import resources
from pathlib import Path

import dpc
import dpc_train
from dpc.model_file import read_model

REPO = Path(__file__).resolve().parents[3]
TINY = REPO / "training" / "configs" / "tiny-test.toml"


def _script(name: str) -> str:
    exe = Path(sys.executable).with_name(name)
    assert exe.is_file(), f"the {name} console script is not installed beside {sys.executable}"
    return str(exe)


def test_installed_beside_dpc():
    assert Path(dpc_train.__file__).parents[1] == Path(dpc.__file__).parents[1], dpc_train.__file__


def test_sources_use_public_dpc_apis_only():
    """No sys.path edits, no file-path imports, no private dpc modules (dpc._core, dpc._model)."""
    files = [f for f in resources.files("dpc_train").iterdir() if f.name.endswith(".py")]
    assert len(files) >= 8
    for f in files:
        tree = ast.parse(f.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and node.attr == "path" and getattr(node.value, "id", "") == "sys":
                raise AssertionError(f"{f.name}: sys.path")
            if isinstance(node, ast.Attribute) and node.attr in ("spec_from_file_location", "module_from_spec"):
                raise AssertionError(f"{f.name}: a file-path import")
            mods = []
            if isinstance(node, ast.ImportFrom) and node.module:
                mods = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            for mod in mods:
                parts = mod.split(".")
                assert not (parts[0] == "dpc" and any(p.startswith("_") for p in parts[1:])), f"{f.name}: {mod}"


def test_package_data_through_importlib_resources():
    from dpc_train import targets

    d = targets.data_dir()
    assert d.is_dir() and (d / "spectra").is_dir()
    assert d == Path(str(resources.files("dpc") / "data" / "deepsampling"))
    assert targets.radial_target("bnot", 1024, 2, 4.0).shape[0] > 100


def test_console_scripts_train_and_export(tmp_path):
    run = tmp_path / "run"
    r = subprocess.run(
        [_script("dpc-train"), "--config", str(TINY), "--run-dir", str(run), "--steps", "2", "--no-progress"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr
    out = tmp_path / "tiny.onnx"
    r = subprocess.run(
        [_script("dpc-export"), str(run / "checkpoint.pt"), "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr
    assert read_model(out).name == "tiny-test" and dpc.load(out).layers == 4
    r = subprocess.run(
        [_script("dpc-train"), "--config", str(tmp_path / "missing.toml")], capture_output=True, text=True, cwd=tmp_path
    )
    assert r.returncode == 2 and r.stderr.startswith("dpc-train: error: ConfigError"), r.stderr


def test_checkout_scripts_run_the_same_commands(tmp_path):
    for script, prog in (("train.py", "dpc-train"), ("export.py", "dpc-export")):
        r = subprocess.run(
            [sys.executable, str(REPO / "training" / script), "--help"], capture_output=True, text=True, cwd=tmp_path
        )
        assert r.returncode == 0 and r.stdout.startswith(f"usage: {prog}"), r.stdout + r.stderr
