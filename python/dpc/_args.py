"""Argument checks shared by the package: each returns the checked value, or raises
InvalidArgumentError naming the argument and the range it accepts (LimitError, a subclass, where
the value is over a size limit rather than wrong)."""

from __future__ import annotations

import numbers

import numpy as np

from .errors import InvalidArgumentError, LimitError

UINT32_MAX = 0xFFFFFFFF
SEED_MAX = (1 << 64) - 1  # seeds are uint64 in libdpc


def _shown(n: int) -> str:
    """A bound as the messages write it: 2^32 - 1 and 2^64 - 1 by name."""
    return {UINT32_MAX: "2^32 - 1", SEED_MAX: "2^64 - 1"}.get(n, str(n))


def accepted(low: int, high: int | None = None) -> str:
    """The range of an integer argument, as the messages write it: ">= 1", "in 0 .. 32"."""
    return f">= {_shown(low)}" if high is None else f"in {_shown(low)} .. {_shown(high)}"


def integer(value, name: str, low: int, high: int | None = None, *, limit: bool = False, whole_floats=False) -> int:
    """An int in [low, high] (``high`` None: no upper bound). Refused with InvalidArgumentError:
    bools, strings, and floats (``whole_floats``: a float that is a whole number, e.g. a size of
    64.0, is taken as that integer). Over ``high``: a LimitError when ``limit`` (a size limit)."""
    ok_type = isinstance(value, numbers.Integral) or (whole_floats and isinstance(value, numbers.Real))
    if isinstance(value, (bool, np.bool_)) or not ok_type:
        raise InvalidArgumentError(f"{name} must be an integer {accepted(low, high)}, got {value!r}")
    try:
        v = int(value)
    except (ValueError, OverflowError):  # nan, inf
        raise InvalidArgumentError(f"{name} must be an integer {accepted(low, high)}, got {value!r}") from None
    if v != value or v < low:
        raise InvalidArgumentError(f"{name} must be an integer {accepted(low, high)}, got {value!r}")
    if high is not None and v > high:
        if limit:
            raise LimitError(f"{name} must be at most {_shown(high)}, got {v}")
        raise InvalidArgumentError(f"{name} must be an integer {accepted(low, high)}, got {v}")
    return v


def seed(value, name: str = "seed") -> int:
    """A seed: an integer in 0 .. 2^64 - 1 (libdpc's uint64; negative seeds are refused, as in the
    CLI)."""
    return integer(value, name, 0, SEED_MAX)


def numpy_seed(value) -> int:
    """A seed of the baselines and masks made with numpy: an integer >= 0, unbounded (numpy's
    generators take any, and set c of a batch is seed + c); a whole float is taken as one."""
    return integer(value, "seed", 0, whole_floats=True)


def threads(value) -> int:
    """A worker-thread count: an integer in 0 .. 2^32 - 1 (0: one per CPU)."""
    return integer(value, "threads", 0, UINT32_MAX)


def size(value, name: str = "size", low: int = 2) -> int:
    """A size or count of masks, baselines and images: an integer >= ``low``, a whole float taken
    as one (64.0 is 64)."""
    return integer(value, name, low, whole_floats=True)


def positive_real(value, name: str, note: str = "") -> float:
    """A number > 0 (bools refused) as a float; ``note`` follows the range in the message."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real) or not value > 0:
        raise InvalidArgumentError(f"{name} must be > 0{note}, got {value!r}")
    return float(value)


def point_array(points, error: type[Exception] = InvalidArgumentError) -> np.ndarray:
    """``points`` as an array (sets, m, n): (m,) is m 1-D points, (m, n) one set; numbers only
    (``error``, a subclass of InvalidArgumentError, otherwise)."""
    a = np.asarray(points)
    if a.dtype.kind not in "fiu":
        raise error(f"points must be numeric, got dtype {a.dtype}")
    if a.ndim == 1:
        return a[None, :, None]
    if a.ndim == 2:
        return a[None]
    if a.ndim != 3:
        raise error(f"points must have shape (m,), (m, n) or (sets, m, n), got {a.shape}")
    return a
