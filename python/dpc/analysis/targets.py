"""A model's design target, from its metadata, for plots (``dpc analyze``/``dpc compare`` draw
it dashed over the measured radial spectrum).

Where the target comes from, in order:

1. ``dpc.target`` (JSON ``{"label", "dims", "nu", "power"}``), for files that state it;
2. the loss program the model was trained with (``dpc.loss``, written by training/export.py):
   the variable subtracted from ``radspec(xy(X), ...)`` or ``radspec(X, ...)`` and its
   definition ``radial_target("NAME", M, K, ...)`` (the authors' radial file, or the analytic
   step / jitter profile the trainer used) or ``spectrum2d_radial("NAME", M, ...)`` (radial
   mean of the authors' 2-D spectrum), evaluated at the model's trained count, as training did.

Models whose loss is something else (Eq. 5 variance, dither masks, hand-made models) have no
target: :func:`model_target` returns None.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from importlib import resources

import numpy as np

from .reference import reference_copied_from

_ASSIGN = re.compile(r"^\s*(\w+)\s*=\s*(radial_target|spectrum2d_radial)\((.*)\)\s*$", re.MULTILINE)
_USE = re.compile(r"radspec\(\s*(xy\(X\)|X)\s*,[^()]*\)\s*-\s*(\w+)")
_ARG = re.compile(r"""^\s*(?:(\w+)\s*=\s*)?("[^"]*"|'[^']*'|[\w.+-]+)\s*$""")


@dataclass
class Target:
    """A radial target profile: ``power`` at normalised frequencies ``nu`` (of a ``dims``-D
    spectrum, white noise = 1), for plotting as (label, nu, power)."""

    label: str
    dims: int
    nu: np.ndarray
    power: np.ndarray

    def as_reference(self) -> tuple[str, np.ndarray, np.ndarray]:
        return (self.label, self.nu, self.power)


def _spectra_dir():
    return resources.files("dpc") / "data" / "deepsampling" / "spectra"


def _args(text: str) -> tuple[list, dict]:
    pos, kw = [], {}
    for part in text.split(","):
        mt = _ARG.match(part)
        if not mt:
            return [], {}
        key, val = mt.group(1), mt.group(2)
        if val[0] in "\"'":
            val = val[1:-1]
        if key:
            kw[key] = val
        else:
            pos.append(val)
    return pos, kw


def _radial_bins(m: int, k: int, nu_max: float) -> int:
    return int(math.floor(nu_max * m ** (1.0 / k))) + 1


def _radial_mean_2d(P: np.ndarray, nb: int) -> np.ndarray:
    """Radial mean of a centred 2-D spectrum with the trainer's binning (floor(|q|), DC = 0)."""
    R = nb - 1
    q = np.arange(-R, R + 1, dtype=np.float64)
    idx = np.floor(np.sqrt(q[:, None] ** 2 + q[None, :] ** 2) + 1e-9).astype(np.int64).ravel()
    ok = idx <= R
    sums = np.bincount(idx[ok], weights=P.ravel()[ok], minlength=nb)
    out = sums / np.bincount(idx[ok], minlength=nb)
    out[0] = 0.0
    return out


def _crop(a: np.ndarray, K: int) -> np.ndarray | None:
    c0, c1 = a.shape[0] // 2, a.shape[1] // 2
    if K > min(c0, c1) - 1:
        return None
    out = a[c0 - K : c0 + K + 1, c1 - K : c1 + K + 1].astype(np.float64)
    out[K, K] = 0.0
    return out


def _radial_target(name: str, m: int, k: int, nu_max: float, source: str) -> np.ndarray | None:
    nb = _radial_bins(m, k, nu_max)
    if source != "file":  # the trainer's analytic profiles (dpc_train/targets.py)
        if name == "step":
            nu = np.arange(nb) / m ** (1.0 / k)
            out = np.where(nu < 0.8, 0.0, 1.0)
            out[0] = 0.0
            return out
        if name == "jitter" and k == 2 and round(math.sqrt(m)) ** 2 == m:
            N = round(math.sqrt(m))
            q = np.arange(-(nb - 1), nb, dtype=np.float64)
            s = np.sinc(q / N) ** 2
            return _radial_mean_2d(1.0 - s[:, None] * s[None, :], nb)
    f = _spectra_dir() / f"{name}-powspec-radialmean-d{k}-n{m}.txt"
    if not f.is_file():
        return None
    a = np.loadtxt(str(f), ndmin=2)
    prof = a[:, 1].astype(np.float64)
    prof[0] = 0.0
    return prof[:nb] if len(prof) >= nb else None


def _spectrum2d_radial(name: str, m: int, nu_max: float) -> np.ndarray | None:
    nb = _radial_bins(m, 2, nu_max)
    f = _spectra_dir() / f"{name}-powspec-d2-n{m}.npy"
    if not f.is_file():
        return None
    with f.open("rb") as fh:
        P = _crop(np.load(fh, allow_pickle=False), nb - 1)
    return None if P is None else _radial_mean_2d(P, nb)


def _from_loss(loss: str, m: int) -> Target | None:
    uses = _USE.findall(loss)
    if not uses:
        return None
    var = uses[0][1]
    if any(v != var for _, v in uses):  # different targets for different projections
        return None
    for name, func, args in _ASSIGN.findall(loss):
        if name != var:
            continue
        pos, kw = _args(args)
        if not pos:
            return None
        pattern = pos[0]
        try:
            nu_max = float(kw.get("nu_max", 4.0))
            if func == "radial_target":
                k = int(pos[2]) if len(pos) > 2 else int(kw.get("k", 2))
                power = _radial_target(pattern, m, k, nu_max, kw.get("source", "auto"))
                what = (
                    "analytic"
                    if kw.get("source", "auto") != "file"
                    and pattern in ("step", "jitter")
                    and power is not None
                    and k == 2
                    and (pattern == "step" or round(math.sqrt(m)) ** 2 == m)
                    else "authors' radial mean"
                )
                if what != "analytic" and any(c.source_dims == 2 for c in reference_copied_from(pattern, m, k)):
                    what += ", which is their 2-D spectrum in ν"
            else:
                k = 2
                power = _spectrum2d_radial(pattern, m, nu_max)
                what = "radial mean of the authors' 2-D spectrum"
        except (ValueError, OSError):
            return None
        if power is None:
            return None
        nu = np.arange(len(power)) / m ** (1.0 / k)
        return Target(label=f"target: {pattern} ({what}, {k}-D, m={m})", dims=k, nu=nu[1:], power=power[1:])
    return None


def model_target(model) -> Target | None:
    """The design target of a loaded model (see the module notes), or None."""
    meta = getattr(model, "metadata", {}) or {}
    raw = meta.get("dpc.target")
    if raw:
        try:
            d = json.loads(raw)
            return Target(
                label=str(d.get("label", "target")),
                dims=int(d["dims"]),
                nu=np.asarray(d["nu"], np.float64),
                power=np.asarray(d["power"], np.float64),
            )
        except (ValueError, KeyError, TypeError):
            return None
    loss = meta.get("dpc.loss")
    if not loss:
        return None
    return _from_loss(loss, int(model.n_points))
