"""Training configuration: one TOML file per pattern, backed by dataclasses.

    [pattern]  name, dims, points, grid_axes, grid_shape, description
    [model]    layers, unique_kernels, bins, subspaces, radius, eps, init ("zero", "repulsion" or
               "model"), init_sigma, init_amplitude, init_model (init = "model": a bundled
               model's name or a model file, whose kernels the run starts from), input
               ("uniform" or "stratified": the training inputs), order ("set" or "progressive"), progressive_base,
               continuous (true: every kernel table ends at 0 at the radius), max_attraction (> 0:
               table values at most max_attraction x the distance in spacings), balance (> 0:
               the generator's output balance radius, docs/model-format.md §5.1)
    [loss]     name + params (registered) | source (Python code) | file (Python file)
    [train]    steps, batch, lr, lr_final, seed, device, threads, impl, checkpoint_every,
               log_every, eval_sets, run_dir, diverge_factor, diverge_patience

Every number is checked: finite, and positive where a size, rate or scale must be.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import tomllib

from dpc import DEFAULT_THREADS

from .cascade import CascadeSpec
from .filter import IMPLS


class ConfigError(ValueError):
    """A training config that is malformed: unknown keys, wrong types, bad values."""


@dataclass
class PatternConfig:
    name: str
    dims: int
    points: int
    grid_axes: list = field(default_factory=list)
    grid_shape: list = field(default_factory=list)
    description: str = ""


# [model]: CascadeSpec's fields and defaults (stated there, once), but for those [pattern] gives
# (dims, points, grid_axes, grid_shape)
ModelConfig = dataclasses.make_dataclass(
    "ModelConfig",
    [
        (f.name, f.type, field(default=f.default, default_factory=f.default_factory))
        for f in dataclasses.fields(CascadeSpec)
        if f.name not in ("dims", "n_points", "grid_axes", "grid_shape")
    ],
)
ModelConfig.__module__ = __name__  # a class of this module (pickle, repr), not of dataclasses


@dataclass
class TrainConfig:
    steps: int = 1000
    batch: int = 4
    lr: float = 1e-3
    lr_final: float = 1e-4  # exponential decay from lr to lr_final over `steps`
    seed: int = 0
    device: str = "cpu"
    # torch's intra-op threads and the C op's threads; dpc's one default (dpc.DEFAULT_THREADS, 1),
    # 0: torch's default (one per core)
    threads: int = DEFAULT_THREADS
    # "auto": libdpc's C kernels on the CPU (about 4x faster than torch on bnot-2d), torch on CUDA
    impl: str = "auto"
    checkpoint_every: int = 50
    log_every: int = 1
    eval_sets: int = 16  # sets used for the measured quality at the end / on export
    run_dir: str = "runs"
    # Divergence without NaN: stop when the batch loss stays above diverge_factor x the best
    # running mean (10 steps; for a negative best: more than (diverge_factor - 1) x its
    # magnitude above it) for diverge_patience steps in a row (0: never), or the points
    # collapse (more than 10% of a set's points coincide). No checkpoint is written meanwhile.
    diverge_factor: float = 10.0
    diverge_patience: int = 20


@dataclass
class Config:
    pattern: PatternConfig
    model: ModelConfig
    loss: dict
    train: TrainConfig
    source_path: str = ""

    def cascade_spec(self) -> CascadeSpec:
        p = self.pattern
        m = dataclasses.asdict(self.model)  # CascadeSpec's own fields (ModelConfig is made from them)
        m["radius"] = [float(r) for r in m["radius"]]
        m["max_attraction"] = float(m["max_attraction"])
        return CascadeSpec(
            dims=p.dims, n_points=p.points, grid_axes=list(p.grid_axes), grid_shape=list(p.grid_shape), **m
        )

    def to_dict(self) -> dict:
        return {
            "pattern": dataclasses.asdict(self.pattern),
            "model": dataclasses.asdict(self.model),
            "loss": dict(self.loss),
            "train": dataclasses.asdict(self.train),
        }

    def base_dir(self) -> Path:
        return Path(self.source_path).parent if self.source_path else Path.cwd()


def _section(cls, data: dict, name: str):
    known = {f.name: f for f in dataclasses.fields(cls)}
    unknown = set(data) - set(known)
    if unknown:
        raise ConfigError(f"[{name}]: unknown keys {sorted(unknown)}; known: {sorted(known)}")
    required = [
        f.name for f in known.values() if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
    ]
    missing = [k for k in required if k not in data]
    if missing:
        raise ConfigError(f"[{name}]: missing required keys {missing}")
    for k, v in data.items():
        f = known[k]
        want = f.type if isinstance(f.type, str) else f.type.__name__
        ok = {
            "int": isinstance(v, int) and not isinstance(v, bool),
            "float": isinstance(v, (int, float)) and not isinstance(v, bool),
            "str": isinstance(v, str),
            "bool": isinstance(v, bool),
            "list": isinstance(v, list),
        }.get(want, True)
        if not ok:
            raise ConfigError(f"[{name}] {k} = {v!r}: expected {want}")
    return cls(**data)


def config_from_dict(d: dict, source_path: str = "") -> Config:
    unknown = set(d) - {"pattern", "model", "loss", "train"}
    if unknown:
        raise ConfigError(f"unknown sections {sorted(unknown)}")
    for sec in ("pattern", "loss"):
        if sec not in d:
            raise ConfigError(f"missing section [{sec}]")
    cfg = Config(
        pattern=_section(PatternConfig, d["pattern"], "pattern"),
        model=_section(ModelConfig, d.get("model", {}), "model"),
        loss=dict(d["loss"]),
        train=_section(TrainConfig, d.get("train", {}), "train"),
        source_path=source_path,
    )
    t = cfg.train
    if t.steps < 1 or t.batch < 1 or t.checkpoint_every < 1 or t.log_every < 1:
        raise ConfigError("[train] steps, batch, checkpoint_every, log_every must be >= 1")
    for name in ("lr", "lr_final"):
        v = getattr(t, name)
        if not (math.isfinite(v) and v > 0):
            raise ConfigError(f"[train] {name} = {v!r}: must be finite and > 0")
    if not (math.isfinite(t.diverge_factor) and t.diverge_factor >= 0):
        raise ConfigError(f"[train] diverge_factor = {t.diverge_factor!r}: must be finite and >= 0 (0: off)")
    if t.diverge_factor and t.diverge_factor <= 1:
        raise ConfigError(f"[train] diverge_factor = {t.diverge_factor!r}: must be > 1 (or 0: off)")
    if t.diverge_patience < 1:
        raise ConfigError("[train] diverge_patience must be >= 1")
    if t.eval_sets < 1:
        raise ConfigError("[train] eval_sets must be >= 1")
    if t.seed < 0:
        raise ConfigError("[train] seed must be >= 0")
    m = cfg.model
    for name in ("eps", "init_sigma", "init_amplitude"):
        v = getattr(m, name)
        if not math.isfinite(v):
            raise ConfigError(f"[model] {name} = {v!r}: must be finite")
    if m.eps < 0:
        raise ConfigError(f"[model] eps = {m.eps!r}: must be >= 0")
    if not m.init_sigma > 0:
        raise ConfigError(f"[model] init_sigma = {m.init_sigma!r}: must be > 0")
    for r in m.radius:
        if isinstance(r, bool) or not isinstance(r, (int, float)) or not (math.isfinite(r) and r > 0):
            raise ConfigError(f"[model] radius {r!r}: every radius must be finite and > 0")
    if t.impl not in IMPLS:
        raise ConfigError(f"[train] impl must be one of {IMPLS}, got {t.impl!r}")
    if t.threads < 0:
        raise ConfigError("[train] threads must be >= 0 (0 = torch default)")
    try:
        cfg.cascade_spec()  # validates the architecture (typed FilterConfigError → ConfigError)
    except ValueError as e:
        raise ConfigError(f"[model]/[pattern]: {e}") from None
    return cfg


def load_config(path: str | Path) -> Config:
    path = Path(path)
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except FileNotFoundError:
        raise ConfigError(f"config file {path} not found") from None
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path}: invalid TOML: {e}") from None
    return config_from_dict(data, str(path.resolve()))
