"""One source of truth: the version (dpc.h, CMake, pyproject, Python), the enums
(exported by the binding from dpc.h), the default thread count (C, Python, CLI, TOML)."""

from __future__ import annotations

import importlib.metadata
import inspect
import re
from pathlib import Path

import pytest
import tomllib

import dpc
from dpc import _core, cli

REPO = Path(__file__).resolve().parents[2]
HEADER = REPO / "libdpc" / "include" / "dpc" / "dpc.h"


def _header_version() -> str:
    text = HEADER.read_text()
    parts = [re.search(rf"^#define DPC_VERSION_{p} (\d+)$", text, re.M) for p in ("MAJOR", "MINOR", "PATCH")]
    assert all(parts), "dpc.h must define DPC_VERSION_MAJOR, _MINOR and _PATCH"
    return ".".join(m.group(1) for m in parts)


def test_one_version_everywhere():
    v = _header_version()
    assert dpc.__version__ == v  # dpc_version_string() of the linked libdpc
    assert importlib.metadata.version("deep-point-correlation") == v  # pyproject, read from dpc.h
    major, minor, patch = (int(p) for p in v.split("."))
    assert _core.VERSION_NUMBER == major * 10000 + minor * 100 + patch
    # the sources say so too: pyproject and CMake read dpc.h instead of repeating the number
    pyproject = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert "version" not in pyproject["project"] and pyproject["project"]["dynamic"] == ["version"]
    meta = pyproject["tool"]["scikit-build"]["metadata"]["version"]
    assert meta["input"] == "libdpc/include/dpc/dpc.h"
    m = re.search(meta["regex"], HEADER.read_text(), re.M)
    assert meta["result"].format(**m.groupdict()) == v
    cmake = (REPO / "CMakeLists.txt").read_text()
    version_vars = r"\$\{DPC_VERSION_MAJOR\}\.\$\{DPC_VERSION_MINOR\}\.\$\{DPC_VERSION_PATCH\}"
    assert re.search(r"project\(dpc VERSION " + version_vars, cmake)
    assert not re.search(r"project\(dpc VERSION \d", cmake)
    # the shared library inside the package is named by CMake's project version (soname)
    assert (Path(dpc.__file__).parent / "lib" / f"libdpc.so.{major}").is_file()


def test_enums_come_from_the_header():
    text = HEADER.read_text()
    for enum, prefix in ((dpc.Isa, "DPC_ISA_"), (dpc.Backend, "DPC_BACKEND_"), (dpc.Input, "DPC_INPUT_")):
        values = {name: int(v) for name, v in re.findall(rf"\b{prefix}(\w+) = (\d+)", text)}
        assert values and {k: int(v) for k, v in enum.__members__.items()} == values, enum
    assert dpc.isa_supported("scalar") and dpc.isa_supported("auto")
    m = dpc.load("bnot-2d", isa="scalar", backend="cpu", input="stratified")
    assert (m.isa, m.backend, m.input) == ("scalar", "cpu", "stratified")
    m = dpc.load("bnot-2d", isa=dpc.Isa.SCALAR, backend=dpc.Backend.CPU, input=dpc.Input.STRATIFIED)
    assert (m.isa, m.backend, m.input) == ("scalar", "cpu", "stratified")
    for bad in ("AVX2", 2, None):
        with pytest.raises(dpc.InvalidArgumentError, match="isa must be one of"):
            dpc.load("bnot-2d", isa=bad)


def test_one_default_thread_count():
    """C (dpc_load_options_init, dpc_layer_options_init), Python (dpc.load, dpc.training), the
    CLI (-t) and the TOML ([train] threads) share one default: 1, the calling thread."""
    from dpc_train.config import TrainConfig

    d = _core.load_defaults()
    assert d["threads"] == d["layer_threads"] == dpc.DEFAULT_THREADS == 1
    for f in (dpc.load, dpc.Model.__init__, dpc.training.layer_forward, dpc.training.layer_backward):
        assert inspect.signature(f).parameters["threads"].default == dpc.DEFAULT_THREADS, f
    for name in ("generate", "analyze", "compare"):
        opt = next(p for p in cli.cli.commands[name].params if p.name == "threads")
        assert opt.default == dpc.DEFAULT_THREADS, name
    assert TrainConfig().threads == dpc.DEFAULT_THREADS
    assert dpc.load("bnot-2d").threads == 1
    assert dpc.load("bnot-2d", threads=0).threads >= 1  # 0: one per CPU
