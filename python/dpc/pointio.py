"""Point-set files: NumPy ``.npy``, text (UTK's ``.dat``, ``.txt``, ``.pts``, comma-separated
``.csv``) and UTK's binary ``.bin``.

Formats (chosen from the file extension unless given; the names match UTK's extensions):

* ``npy`` (``.npy``): an array (m, n) for one set or (sets, m, n); (m,) reads as m 1-D points.
  Written in the array's own float type: float32 from dpc models stays float32.
* ``dat`` (``.dat``, UTK's text format; also ``.txt``, ``.pts``; names ``txt``/``text``): one
  point per line, coordinates separated by spaces. Several sets are separated by a line ``#``
  (UTK's separator); a file holding one set is plain text.
* ``csv`` (``.csv``): the same with commas between coordinates (and ``#`` lines between sets).
* ``bin`` (``.bin``): UTK's binary format, no header: per set a little-endian uint32 point count
  followed by count x n coordinates (float64 by default, float32 possible). The file does not
  say n or the float type; the reader tries every n in 1..64 for both types and accepts the
  single reading whose counts tile the file exactly and whose values all lie in [0, 1]
  (pass ``dims``/``bin_dtype`` where that is ambiguous).

Text is written with enough digits (17 significant) to read back the same binary values. Text
readers accept blanks or commas. Every file is written atomically (``dpc._atomic``): a failed
write leaves an existing file untouched.

Every reader returns float64 ``(sets, m, n)``; all sets of one file must have the same shape.
"""

from __future__ import annotations

import io
import os
import re
import stat
from pathlib import Path

import numpy as np

from . import _args, _atomic
from .errors import InvalidArgumentError

FORMATS = ("npy", "dat", "csv", "bin")
_ALIASES = {"npy": "npy", "dat": "dat", "text": "dat", "txt": "dat", "csv": "csv", "bin": "bin"}
_EXTENSIONS = {".npy": "npy", ".bin": "bin", ".dat": "dat", ".txt": "dat", ".pts": "dat", ".csv": "csv"}
#: Every extension a point file may have, for help texts.
EXTENSIONS = tuple(_EXTENSIONS)
#: Every -f/--format name.
FORMAT_NAMES = tuple(_ALIASES)


def describe_extensions() -> str:
    """'.npy, .dat/.txt/.pts (text), .csv, .bin (UTK binary)' for help texts."""
    return ".npy, .dat/.txt/.pts (text, UTK's .dat), .csv (comma-separated), .bin (UTK binary)"


_BIN_DTYPES = {"float64": "<f8", "float32": "<f4"}
_MAX_GUESS_DIMS = 64
_SEPARATOR = re.compile(r"^[ \t]*#[^\n]*(?:\n|$)", re.MULTILINE)


class PointFileError(InvalidArgumentError):
    """A point-set file that cannot be read or written as asked (format, shape, values)."""


_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a device"), (stat.S_ISBLK, "a device"))


def open_regular(path, mode: str = "rb", error=InvalidArgumentError):
    """``open(path, mode)`` ("rb" or "r") for a regular file only. A folder, FIFO, socket or
    device is refused at once with ``error`` (a FIFO with no writer would block a plain open or
    read forever); so is a missing or unreadable file, naming it."""
    p = Path(path)
    try:  # O_NONBLOCK: opening a FIFO returns at once, so it can be refused below
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise error(f"{p}: no such file") from None
    except OSError as e:
        raise error(f"{p}: cannot open ({e.strerror or e})") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            kind = next((k for test, k in _KINDS if test(st.st_mode)), "not a regular file")
            raise error(f"{p}: is {kind}, not a regular file; give a file")
        os.set_blocking(fd, True)
        fh = os.fdopen(fd, mode, **({"encoding": "utf-8"} if "b" not in mode else {}))
        (fh.raw if "b" in mode else fh.buffer.raw).name = str(p)  # readers that ask for a name get it
        return fh
    except BaseException:
        os.close(fd)
        raise


def resolve_format(path, fmt: str | None = None) -> str:
    """The canonical format name for ``path``: ``fmt`` if given, else from the extension."""
    if fmt is not None:
        key = str(fmt).lower()
        if key == "utk":
            raise PointFileError("format 'utk' is ambiguous: UTK's text format is 'dat', its binary format 'bin'")
        if key not in _ALIASES:
            raise PointFileError(f"unknown point format {fmt!r}; choose from {', '.join(sorted(_ALIASES))}")
        return _ALIASES[key]
    ext = Path(path).suffix.lower()
    if ext not in _EXTENSIONS:
        raise PointFileError(
            f"cannot tell the format of {os.fspath(path)!r} from its extension; use one of "
            f"{', '.join(EXTENSIONS)} or give the format"
        )
    return _EXTENSIONS[ext]


def _as_3d(points) -> np.ndarray:
    a = _args.point_array(points, PointFileError)
    if 0 in a.shape:
        raise PointFileError(f"no points to write (shape {a.shape})")
    return a


def _bar(iterable, enabled: bool, desc: str, total: int | None = None):
    """A tqdm bar on stderr, shown only once the loop has run for a second."""
    from tqdm import tqdm

    return tqdm(iterable, desc=desc, total=total, disable=not enabled, delay=1.0, leave=False)


def write_points(
    path, points, fmt: str | None = None, *, bin_dtype: str = "float64", progress_bar: bool = False
) -> Path:
    """Write one set (m, n) or several (sets, m, n) to ``path`` in ``fmt`` (default: from the
    extension), atomically: into a temporary file beside it, renamed over ``path`` only when
    complete (an existing file survives any failure). ``.npy`` keeps the array's float type.
    Returns the path."""
    p = Path(os.fspath(path))
    if "\x00" in str(p):
        raise PointFileError(f"path {str(p)!r} contains a NUL character")
    kind = resolve_format(p, fmt)
    a = _as_3d(points)
    if kind == "bin":
        if bin_dtype not in _BIN_DTYPES:
            raise PointFileError(f"bin_dtype must be float64 or float32, got {bin_dtype!r}")
        if a.shape[1] >= 2**32:
            raise PointFileError("UTK .bin stores the point count as uint32")
    try:
        _write(p, a, kind, bin_dtype, progress_bar)
    except OSError as e:  # a full disk, a size limit, a vanished folder: say which file
        why = e.strerror or str(e)
        raise OSError(e.errno, f"cannot write {p}: {why}") from e
    return p


def _write(p: Path, a: np.ndarray, kind: str, bin_dtype: str, progress_bar: bool) -> None:
    with _atomic.atomic_file(p, "wb") as fh:
        if kind == "npy":
            arr = a[0] if a.shape[0] == 1 else a
            if arr.dtype.kind != "f":
                arr = arr.astype(np.float64)
            np.save(fh, np.ascontiguousarray(arr), allow_pickle=False)
        elif kind in ("dat", "csv"):
            sep = "," if kind == "csv" else " "
            # 17 significant digits read back as the same float64 (float32 values too);
            # one %-format over the whole set is ~4x faster than np.savetxt's row loop.
            row = sep.join(["%.17g"] * a.shape[2]) + "\n"
            for s in _bar(range(a.shape[0]), progress_bar, f"writing {p.name}"):
                if s:
                    fh.write(b"#\n")
                vals = tuple(np.asarray(a[s], np.float64).ravel().tolist())
                fh.write(((row * a.shape[1]) % vals).encode("ascii"))
        else:
            dt = np.dtype(_BIN_DTYPES[bin_dtype])
            for s in range(a.shape[0]):
                fh.write(int(a.shape[1]).to_bytes(4, "little"))
                fh.write(np.ascontiguousarray(a[s], dtype=dt).tobytes())


def _stack(sets: list[np.ndarray], where: str) -> np.ndarray:
    if not sets:
        raise PointFileError(f"{where}: no points found")
    first = sets[0].shape
    for i, s in enumerate(sets):
        if s.shape != first:
            raise PointFileError(
                f"{where}: set {i} has {s.shape[0]} points of dimension {s.shape[1]}, "
                f"set 0 has {first[0]} of dimension {first[1]}; all sets must match"
            )
    out = np.stack(sets).astype(np.float64)
    if not np.all(np.isfinite(out)):
        raise PointFileError(f"{where}: contains NaN or infinite coordinates")
    return out


def _read_npy(p: Path) -> np.ndarray:
    try:
        with open_regular(p, "rb", PointFileError) as fh:
            a = np.load(fh, allow_pickle=False)
    except (ValueError, EOFError, OSError) as e:
        if isinstance(e, PointFileError):
            raise
        raise PointFileError(f"{p}: not a readable .npy file ({e})") from None
    if isinstance(a, np.lib.npyio.NpzFile):
        raise PointFileError(f"{p}: is an .npz archive, expected one .npy array")
    if a.dtype.kind not in "fiu":
        raise PointFileError(f"{p}: array of dtype {a.dtype}, expected numbers")
    if a.ndim == 1:
        a = a[None, :, None]
    elif a.ndim == 2:
        a = a[None]
    elif a.ndim != 3:
        raise PointFileError(f"{p}: array of shape {a.shape}, expected (m, n) or (sets, m, n)")
    if 0 in a.shape:
        raise PointFileError(f"{p}: empty array of shape {a.shape}")
    return _stack(list(a), str(p))


def _read_text(p: Path, progress_bar: bool) -> np.ndarray:
    try:
        with open_regular(p, "r", PointFileError) as fh:
            text = fh.read()
    except UnicodeDecodeError:
        raise PointFileError(f"{p}: not a text file") from None
    sets = []
    for block in _bar(_SEPARATOR.split(text), progress_bar, f"reading {p.name}"):
        if not block.strip():
            continue
        try:
            arr = np.loadtxt(io.StringIO(block.replace(",", " ")), ndmin=2, dtype=np.float64)
        except ValueError as e:
            why = str(e).split("; use `usecols`")[0]  # numpy's advice does not apply here
            raise PointFileError(f"{p}: set {len(sets)}: {why}") from None
        sets.append(arr)
    return _stack(sets, str(p))


def _parse_bin(data: bytes, n: int, dtype: np.dtype) -> list[np.ndarray] | None:
    """The sets of a UTK .bin read as n-D points of ``dtype``, or None if the counts do not
    tile the file exactly."""
    item = n * dtype.itemsize
    off, sets = 0, []
    while off < len(data):
        if off + 4 > len(data):
            return None
        count = int.from_bytes(data[off : off + 4], "little")
        off += 4
        if count == 0 or off + count * item > len(data):
            return None
        sets.append(np.frombuffer(data, dtype=dtype, count=count * n, offset=off).reshape(count, n))
        off += count * item
    return sets or None


def _read_bin(p: Path, dims: int | None, bin_dtype: str | None) -> np.ndarray:
    with open_regular(p, "rb", PointFileError) as fh:
        data = fh.read()
    if bin_dtype is not None and bin_dtype not in _BIN_DTYPES:
        raise PointFileError(f"bin_dtype must be float64 or float32, got {bin_dtype!r}")
    if dims is not None and not 1 <= int(dims) <= 1 << 16:
        raise PointFileError(f"dims must be a positive count, got {dims}")
    dtypes = [bin_dtype] if bin_dtype else list(_BIN_DTYPES)
    dim_list = [int(dims)] if dims else list(range(1, _MAX_GUESS_DIMS + 1))
    readings = []
    for dt_name in dtypes:
        dt = np.dtype(_BIN_DTYPES[dt_name])
        for n in dim_list:
            sets = _parse_bin(data, n, dt)
            if sets is None or len({s.shape for s in sets}) != 1:
                continue
            if dims is None or bin_dtype is None:  # guessing: values must look like points
                if not all(np.all(np.isfinite(s)) and s.min() >= 0 and s.max() <= 1 for s in sets):
                    continue
            readings.append((n, dt_name, sets))
    if len(readings) > 1:
        # Pairs of float32 coordinates read as one float64 are tiny numbers (< 2^-7) and pass
        # the range test, so also ask every axis to reach 1/4 somewhere, as real sets do.
        plausible = [r for r in readings if np.all(np.max([s.max(axis=0) for s in r[2]], axis=0) >= 0.25)]
        if len(plausible) == 1:
            readings = plausible
    if not readings:
        what = f"dims={dims}" if dims else "any dimension 1..64"
        raise PointFileError(
            f"{p}: not a UTK .bin point file ({what}, {'/'.join(dtypes)}, equal point counts, values in [0, 1])"
        )
    if len(readings) > 1:
        opts = ", ".join(f"dims={n} {dt}" for n, dt, _ in readings)
        raise PointFileError(f"{p}: ambiguous UTK .bin file (could be {opts}); give the dimension")
    return _stack(readings[0][2], str(p))


def read_points(
    path, fmt: str | None = None, *, dims: int | None = None, bin_dtype: str | None = None, progress_bar: bool = False
) -> np.ndarray:
    """Read a point-set file: float64 array (sets, m, n). ``dims``/``bin_dtype`` only help
    reading ``.bin`` files (see the module notes); for other formats ``dims`` is checked."""
    p = Path(path)
    kind = resolve_format(p, fmt)
    if kind == "npy":
        out = _read_npy(p)
    elif kind in ("dat", "csv"):
        out = _read_text(p, progress_bar)
    else:
        out = _read_bin(p, dims, bin_dtype)
    if dims is not None and out.shape[2] != int(dims):
        raise PointFileError(f"{p}: points have {out.shape[2]} dimensions, expected {dims}")
    return out
