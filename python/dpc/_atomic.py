"""Writes that never lose data.

Every file dpc writes goes to a temporary file in the target's own folder, is flushed to disk
(fsync), and only then renamed over the target (``os.replace``: atomic on POSIX and Windows).
A failure at any point — a full disk, a write error, Ctrl-C — removes the temporary file and
leaves an existing target untouched.

A command that writes several files wraps them in :func:`transaction`: inside it, finished
files wait as temporaries and are renamed into place together when the block ends without an
exception; on an exception every temporary, and every folder the transaction created, is
removed, so a failed command leaves nothing behind and changes nothing.

    with transaction():
        out = make_dir("analysis")              # removed again if the block fails
        with atomic_file(out / "metrics.json", "w") as fh:
            fh.write(text)
        save_figure(fig, out / "radial.png")    # matplotlib, same rules
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import secrets
from pathlib import Path

_CURRENT: contextvars.ContextVar[_Transaction | None] = contextvars.ContextVar("dpc_transaction", default=None)


def _umask_mode() -> int:
    """The mode open() would give a new file (0666 less the umask)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


def temp_path(path) -> Path:
    """A fresh temporary name beside ``path`` that keeps its extension (writers such as
    matplotlib and numpy choose the format from it): ``.NAME.XXXXXXXX.part.EXT``."""
    p = Path(path)
    return p.with_name(f".{p.name}.{secrets.token_hex(4)}.part{p.suffix}")


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _unlink(path: Path) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


class _Transaction:
    def __init__(self) -> None:
        self.files: list[tuple[Path, Path]] = []  # (temporary, target)
        self.dirs: list[Path] = []  # folders created, outermost first

    def commit(self) -> None:
        done = []
        try:
            for tmp, target in self.files:
                os.replace(tmp, target)
                done.append(target)
        except BaseException:
            self.abort()
            raise
        self.files = []

    def abort(self) -> None:
        for tmp, _ in self.files:
            _unlink(tmp)
        self.files = []
        for d in reversed(self.dirs):
            try:
                d.rmdir()  # only if empty: never removes what was there before
            except OSError:
                pass
        self.dirs = []


@contextlib.contextmanager
def transaction():
    """All files written inside appear together at the end, or not at all (see the module)."""
    outer = _CURRENT.get()
    if outer is not None:  # nested: part of the outer one
        yield outer
        return
    tr = _Transaction()
    token = _CURRENT.set(tr)
    try:
        yield tr
    except BaseException:
        tr.abort()
        raise
    else:
        tr.commit()
    finally:
        _CURRENT.reset(token)


def make_dir(path) -> Path:
    """mkdir -p that a failing transaction undoes (only the folders it created)."""
    p = Path(path)
    missing = []
    q = p
    while not q.exists():
        missing.append(q)
        if q.parent == q:
            break
        q = q.parent
    p.mkdir(parents=True, exist_ok=True)
    tr = _CURRENT.get()
    if tr is not None:
        tr.dirs.extend(reversed(missing))
    return p


def _finish(tmp: Path, target: Path, synced: bool = False) -> None:
    """tmp is complete: fsync it and put it in place (or hand it to the transaction)."""
    if not synced:
        _fsync(tmp)
    tr = _CURRENT.get()
    if tr is not None:
        tr.files.append((tmp, target))
    else:
        os.replace(tmp, target)


@contextlib.contextmanager
def atomic_path(path):
    """Yields a temporary path beside ``path`` (same extension) for a writer that wants a file
    name; when the block ends without an exception the file is put in place."""
    target = Path(path)
    tmp = temp_path(target)
    try:
        yield tmp
        if not tmp.is_file():
            raise OSError(f"the writer made no file {tmp}")
        os.chmod(tmp, _umask_mode())
        _finish(tmp, target)
    except BaseException:
        _unlink(tmp)
        raise


@contextlib.contextmanager
def atomic_file(path, mode: str = "wb", encoding: str | None = None, newline: str | None = None):
    """An open file object (``mode`` "wb" or "w") whose contents replace ``path`` atomically
    when the block ends without an exception."""
    if mode not in ("wb", "w"):
        raise ValueError(f"atomic_file mode must be 'wb' or 'w', got {mode!r}")
    target = Path(path)
    tmp = temp_path(target)
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), _umask_mode())
    try:
        kw = {} if mode == "wb" else {"encoding": encoding or "utf-8", "newline": newline}
        with os.fdopen(fd, mode, **kw) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        _finish(tmp, target, synced=True)
    except BaseException:
        _unlink(tmp)
        raise


def write_bytes(path, data: bytes) -> Path:
    with atomic_file(path, "wb") as fh:
        fh.write(data)
    return Path(path)


def write_text(path, text: str, encoding: str = "utf-8") -> Path:
    with atomic_file(path, "w", encoding=encoding, newline="") as fh:
        fh.write(text)
    return Path(path)


def save_figure(fig, path, **kwargs) -> Path:
    """``fig.savefig`` to ``path`` atomically; the format comes from the extension."""
    target = Path(path)
    fmt = kwargs.pop("format", None) or target.suffix.lstrip(".").lower() or "png"
    with atomic_file(target, "wb") as fh:
        fig.savefig(fh, format=fmt, **kwargs)
    return target
