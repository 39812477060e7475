"""Turning a config's [loss] table into a callable loss(X) → scalar.

Two routes:
* `name = "..."` + `params = {...}`: a registered loss factory (see REGISTRY, @register);
* `source = "..."` or `file = "loss.py"`: Python code that defines `def loss(X): ...`, run in a
  namespace holding the loss language: spec, radspec, ddom, raddom, swizzles (x, xy, xz, ...),
  l1, l2, rel_l1, log_l1, lowband_weight, targets (radial_target, step_radial, jitter_radial,
  spectrum2d_target, integrand_spectrum, eq5_variance, load_point_sets, measured_radial), and
  M, N (trained point count and dims), torch and math.

Example (blue noise like the paper's `l1(radspec(X) − BNOT)`, with a weighted low band):

    BNOT = radial_target("bnot", M, 2, nu_max=4)
    W = lowband_weight(M, 2, nu_max=4, nu_low=0.75, factor=10)
    def loss(X):
        return l1(radspec(xy(X), nu_max=4) - BNOT, weight=W)
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Callable

import torch

from . import losses as L
from . import targets as T
from .cascade import AXES

REGISTRY: dict[str, Callable] = {}


class LossConfigError(ValueError):
    """A [loss] section that names no loss, an unknown loss, or code without `loss(X)`."""


def register(name: str):
    """Decorator: register a loss factory f(m, n, **params) → loss(X)."""

    def deco(f):
        REGISTRY[name] = f
        return f

    return deco


def namespace(m: int, n: int) -> dict:
    ns = {"torch": torch, "math": math, "M": m, "N": n}
    for mod in (L, T):
        ns.update(
            {k: v for k, v in vars(mod).items() if not k.startswith("_") and callable(v) and k not in ("annotations",)}
        )
    ns.update(L.swizzle_functions(min(n, 4)))
    return ns


def compile_source(source: str, m: int, n: int, origin: str = "<loss>") -> Callable:
    ns = namespace(m, n)
    exec(compile(source, origin, "exec"), ns)  # noqa: S102 (the user's own loss program)
    fn = ns.get("loss")
    if not callable(fn):
        raise LossConfigError(f"{origin}: the loss program must define a function loss(X)")
    return fn


def build_loss(section: dict, m: int, n: int, base_dir: Path | None = None):
    """(loss callable, loss source text for the model metadata) from a [loss] table."""
    keys = [k for k in ("name", "source", "file") if section.get(k)]
    if len(keys) != 1:
        raise LossConfigError("[loss] needs exactly one of name = ..., source = ..., file = ...")
    if "name" in keys:
        name = section["name"]
        if name not in REGISTRY:
            raise LossConfigError(f"unknown loss {name!r}; registered: {sorted(REGISTRY)}")
        params = dict(section.get("params", {}))
        try:
            fn = REGISTRY[name](m, n, **params)
        except TypeError as e:
            raise LossConfigError(f"loss {name!r}: bad params {params}: {e}") from None
        return fn, f"registered:{name} {params}"
    if "source" in keys:
        src = section["source"]
        return compile_source(src, m, n, "<config [loss] source>"), src
    path = Path(section["file"])
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    if not path.is_file():
        raise LossConfigError(f"loss file {path} not found")
    src = path.read_text()
    return compile_source(src, m, n, str(path)), src


@register("radspec")
def radspec_loss(
    m: int,
    n: int,
    target: str = "bnot",
    axes: str = "",
    nu_max: float = 4.0,
    metric: str = "l1",
    nu_low: float = 0.75,
    low_factor: float = 1.0,
    pcf_weight: float = 0.0,
    pcf_target: str = "",
    pcf_r_max: float = 2.0,
):
    """metric(radspec(axes(X)) − target) with an optional low-band weight (factor below ν_low)
    and an optional PCF term pcf_weight·l1(raddom − PCF of the point sets `pcf_target`).
    axes: a swizzle such as "xz"; default every dimension (radspec of the whole n-D set)."""
    if not axes:
        if n > len(AXES):
            raise LossConfigError(
                f"radspec over all {n} dims: only the first {len(AXES)} have axis letters; give params.axes"
            )
        axes = AXES[:n]  # every dimension (a 10-D pattern: all 10, not the first 4)
    k = len(axes)
    tgt = T.radial_target(target, m, k, nu_max)
    w = L.lowband_weight(m, k, nu_max, nu_low, low_factor)
    if metric not in ("l1", "l2", "log_l1", "rel_l1"):
        raise LossConfigError(f"metric must be l1, l2, log_l1 or rel_l1, got {metric!r}")
    pcf_ref = None
    if pcf_weight:
        if not pcf_target:
            raise LossConfigError("pcf_weight needs pcf_target (a folder of point sets)")
        pcf_ref = L.raddom(T.load_point_sets(pcf_target), r_max=pcf_r_max)

    def loss(X):
        rs = L.radspec(L.swizzle(X, axes), nu_max=nu_max)
        if metric == "l1":
            val = L.l1(rs, tgt, weight=w)
        elif metric == "l2":
            val = L.l2(rs, tgt, weight=w)
        elif metric == "log_l1":
            val = L.log_l1(rs[1:], tgt[1:])
        else:
            val = L.rel_l1(rs[1:], tgt[1:])
        if pcf_ref is not None:
            val = val + pcf_weight * L.l1(L.raddom(L.swizzle(X, axes), r_max=pcf_r_max), pcf_ref)
        return val

    return loss
