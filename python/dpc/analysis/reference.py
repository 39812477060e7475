"""The authors' radially averaged target spectra (vendored, BSD-3-Clause; see
dpc/data/deepsampling/README.md)."""

from __future__ import annotations

import functools
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


def _radial_name(pattern: str, n_points: int, dims: int) -> str:
    return f"{pattern}-powspec-radialmean-d{int(dims)}-n{int(n_points)}.txt"


def reference_radial_spectrum(pattern: str, n_points: int, dims: int = 2) -> ReferenceRadial:
    """Read ``{pattern}-powspec-radialmean-d{dims}-n{n_points}.txt``."""
    name = _radial_name(pattern, n_points, dims)
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


_MAX_STRIDE, _MIN_RINGS = 4, 8  # reference_spectrum_copies' defaults
_ANY_RADIAL = re.compile(r"^([a-z]+)-powspec-radialmean-d(\d+)-n(\d+)(_old)?\.txt$")


@dataclass(frozen=True)
class ReferenceCopy:
    """A radial target file for n dimensions whose values are a file's for fewer dimensions: the
    power at radius b of ``copy`` equals the power at radius ``stride`` * b of ``source``, bit for
    bit, for every one of the copy's ``rings`` nonzero radii (the DC rows differ: they hold m).
    Both files then give the same power at the same nu when stride = (m_source^(1/n_source)) /
    (m_copy^(1/n_copy)): the copy is the lower-dimensional spectrum re-indexed in nu."""

    copy: str  # file names
    source: str
    stride: int
    rings: int
    copy_dims: int
    source_dims: int


def reference_spectrum_copies(max_stride: int = _MAX_STRIDE, min_rings: int = _MIN_RINGS) -> list[ReferenceCopy]:
    """Every shipped radial target file (the ``_old`` variants included) that repeats, exactly, a
    file of the same pattern for fewer dimensions (at radius b and stride * b, stride <=
    ``max_stride``, over all its nonzero rings, which take at least ``min_rings`` distinct
    values: a step or plateau would match by itself). Several of the
    authors' n-D targets are such copies (docs/analysis.md, "Reference targets"), so a model's
    distance to one of them measures how close it comes to a lower-dimensional spectrum."""
    return list(_copies(int(max_stride), int(min_rings)))


def reference_copied_from(pattern: str, n_points: int, dims: int) -> list[ReferenceCopy]:
    """The files that the radial target of (pattern, n_points, dims) repeats
    (:func:`reference_spectrum_copies` with default bounds); empty for 1-D and 2-D targets, which
    have no lower-dimensional file to repeat, without reading the files."""
    if int(dims) <= 2:
        return []
    name = _radial_name(pattern, n_points, dims)
    return [c for c in _copies(_MAX_STRIDE, _MIN_RINGS) if c.copy == name]


@functools.cache
def _copies(max_stride: int, min_rings: int) -> tuple[ReferenceCopy, ...]:
    rows = {}
    for f in sorted(_spectra_dir().iterdir(), key=lambda f: f.name):
        mt = _ANY_RADIAL.match(f.name)
        if mt:
            rows[f.name] = (mt[1], int(mt[2]), np.loadtxt(str(f), ndmin=2)[:, 1])
    out = []
    for copy, (pattern, dims, a) in rows.items():
        n = len(a) - 1
        if len(np.unique(a[1:])) < min_rings:
            continue
        for source, (pattern_s, dims_s, b) in rows.items():
            if pattern_s != pattern or dims_s >= dims:
                continue
            for s in range(1, max_stride + 1):
                if s * n < len(b) and np.array_equal(a[1:], b[s : s * n + 1 : s]):
                    out.append(ReferenceCopy(copy, source, s, n, dims, dims_s))
    return tuple(out)
