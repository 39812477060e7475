"""The Python package's shape: one argument-checking module (dpc._args) that the modules use, the
shared input options of analyze and compare, training defaults stated once, test-only code kept
out of what ships."""

from __future__ import annotations

import ast
import dataclasses
import math
import pickle
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

import dpc
from dpc import _args, cli
from dpc.errors import InvalidArgumentError, LimitError

PACKAGE = Path(dpc.__file__).resolve().parent


def test_integer_states_the_accepted_range():
    assert _args.integer(7, "k", 1, 9) == 7 and _args.integer(np.int64(3), "k", 0) == 3
    for bad in (0, 10, 2.0, 2.5, "3", True, None):
        with pytest.raises(InvalidArgumentError, match=r"k must be an integer in 1 \.\. 9"):
            _args.integer(bad, "k", 1, 9)
    with pytest.raises(InvalidArgumentError, match="k must be an integer >= 1, got 0"):
        _args.integer(0, "k", 1)
    with pytest.raises(LimitError, match="at most 9"):
        _args.integer(10, "k", 1, 9, limit=True)
    assert _args.integer(64.0, "size", 2, whole_floats=True) == 64
    for bad in (64.5, math.nan, math.inf, np.bool_(True)):
        with pytest.raises(InvalidArgumentError, match=">= 2"):
            _args.integer(bad, "size", 2, whole_floats=True)


def test_seeds_and_threads_name_their_ranges():
    assert _args.seed(2**64 - 1) == 2**64 - 1
    with pytest.raises(InvalidArgumentError, match=r"seed must be an integer in 0 \.\. 2\^64 - 1"):
        _args.seed(2**64)
    assert _args.numpy_seed(2**70) == 2**70  # numpy seeds are unbounded (set c is seed + c)
    with pytest.raises(InvalidArgumentError, match=r"threads must be an integer in 0 \.\. 2\^32 - 1"):
        _args.threads(-1)
    with pytest.raises(InvalidArgumentError, match="max_bytes must be > 0"):
        _args.positive_real(0, "max_bytes")


def test_no_module_writes_its_own_integer_validator():
    """The validators that used to be written per module are gone: dpc._args is the one place."""
    old = {"_integer", "_seed", "_check_seed", "_check_mask_size"}
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef):
                assert node.name not in old, f"{path.relative_to(PACKAGE)} defines {node.name}; use dpc._args"


def _shared(command: str) -> list[tuple]:
    params = cli.cli.commands[command].params
    own = {"analyze": {"label", "no_plots"}, "compare": {"integration"}}[command] | {"output"}  # output: own help
    return [(p.name, tuple(p.opts), repr(p.type), p.default) for p in params if p.name not in own]


def test_analyze_and_compare_share_their_input_options():
    assert _shared("analyze") == _shared("compare")
    assert [p.name for p in cli.cli.commands["analyze"].params][:3] == ["inputs", "more", "output"]


def test_model_config_takes_cascade_spec_defaults():
    from dpc_train.cascade import CascadeSpec
    from dpc_train.config import ModelConfig

    def defaults(cls):
        return {
            f.name: f.default if f.default is not dataclasses.MISSING else f.default_factory()
            for f in dataclasses.fields(cls)
            if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING
        }

    spec, model = defaults(CascadeSpec), defaults(ModelConfig)
    assert model and all(spec[k] == v for k, v in model.items())
    assert set(spec) - set(model) == {"grid_axes", "grid_shape"}  # [pattern] states those
    assert pickle.loads(pickle.dumps(ModelConfig())) == ModelConfig()  # a class of dpc_train.config


def test_test_only_code_does_not_ship():
    shipped = {f.name for f in resources.files("dpc_train").iterdir()}
    assert "onnx_reference.py" not in shipped
    assert (Path(__file__).parent / "training" / "onnx_reference.py").is_file()
