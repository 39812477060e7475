"""The authors' radially averaged target spectra (vendored, BSD-3-Clause; see
dpc/data/deepsampling/README.md)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from importlib import resources

import numpy as np

from ..errors import InvalidArgumentError

_NAME = re.compile(r"^([a-z]+)-powspec-radialmean-d(\d+)-n(\d+)\.txt$")


@dataclass
class ReferenceRadial:
    """A target radial spectrum: ring b (b <= |q| < b + 1) at ``radius`` = b, nu = b / m^(1/n).
    The DC row of the file (|q| = 0; m in some files, 0 in others) is dropped."""

    pattern: str
    n_points: int
    dims: int
    radius: np.ndarray
    nu: np.ndarray
    power: np.ndarray


def _spectra_dir():
    return resources.files("dpc") / "data" / "deepsampling" / "spectra"


def available_reference_spectra() -> list[tuple[str, int, int]]:
    """(pattern, dims, m) of every radial target file shipped."""
    out = []
    for f in _spectra_dir().iterdir():
        mt = _NAME.match(f.name)
        if mt:
            out.append((mt[1], int(mt[2]), int(mt[3])))
    return sorted(out)


def reference_radial_spectrum(pattern: str, n_points: int, dims: int = 2) -> ReferenceRadial:
    """Read ``{pattern}-powspec-radialmean-d{dims}-n{n_points}.txt``."""
    name = f"{pattern}-powspec-radialmean-d{int(dims)}-n{int(n_points)}.txt"
    f = _spectra_dir() / name
    if not f.is_file():
        have = ", ".join(f"{p} d={d} m={m}" for p, d, m in available_reference_spectra())
        raise InvalidArgumentError(f"no reference spectrum {name}; available: {have}")
    data = np.loadtxt(str(f), ndmin=2)
    data = data[data[:, 0] > 0]
    m, n = int(n_points), int(dims)
    return ReferenceRadial(
        pattern=pattern, n_points=m, dims=n, radius=data[:, 0], nu=data[:, 0] / m ** (1.0 / n), power=data[:, 1]
    )
