"""Writes that never lose data.

Every file dpc writes goes to a temporary file in the target's own folder, is flushed to disk
(fsync), and only then renamed over the target (``os.replace``: atomic on POSIX and Windows).
A failure at any point — a full disk, a write error, Ctrl-C — removes the temporary file and
leaves an existing target untouched.

The target's side: an overwritten file keeps its permission bits (a mode-600 file stays 600;
a new file gets 0666 less the umask). A symbolic link is written through: the file it points
to is replaced (its temporary sits beside that file) and the link stays a link. A hard link
cannot be written through atomically, so the name given gets the new file and the other names
of the old file keep the old contents.

Temporaries are named ``.NAME.PID.XXXXXXXX.part.EXT``, PID being the writing process. A
process killed while writing (kill -9, power loss) leaves its temporary behind; the next write
to that folder removes every temporary whose process is no longer running on this machine (and
those of the old, pid-less form ``.NAME.XXXXXXXX.part.EXT`` more than an hour old), never the
temporary of a writer that is still running.

A command that writes several files wraps them in :func:`transaction`: inside it, finished
files wait as temporaries and are renamed into place together when the block ends without an
exception; on an exception every temporary, and every folder the transaction created, is
removed, so a failed command leaves nothing behind and changes nothing.

    with transaction():
        out = make_dir("analysis")              # removed again if the block fails
        with atomic_file(out / "metrics.json", "w") as fh:
            fh.write(text)
        save_figure(fig, out / "radial.png")    # matplotlib, same rules

:func:`check_output` tells before the work whether a path can be written (its folder exists
and is writable, it is not a folder), naming what is wrong.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import re
import secrets
import stat
import time
from pathlib import Path

from .errors import InvalidArgumentError

_CURRENT: contextvars.ContextVar[_Transaction | None] = contextvars.ContextVar("dpc_transaction", default=None)


def _umask_mode() -> int:
    """The mode open() would give a new file (0666 less the umask)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


# .NAME.PID.XXXXXXXX.part.EXT (and the pid-less form of older versions)
_TEMP = re.compile(r"^\..+?\.(?:(\d+)\.)?[0-9a-f]{8}\.part(?:\.[^.]*)?$")
_OLD_TEMP_AGE = 3600.0  # seconds; pid-less temporaries carry no writer to ask about


def _running(pid: int) -> bool:
    if pid == os.getpid() or os.name == "nt":  # Windows' os.kill(pid, 0) would end the process
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # it exists (another user's) or cannot be asked: keep its file
    return True


def remove_stale(folder) -> list[Path]:
    """Remove the temporaries that killed writes left in ``folder`` (see the module doc);
    returns what was removed. Never raises: cleaning up is a courtesy of the next write."""
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    now = time.time()
    for e in entries:
        m = _TEMP.match(e.name)
        if m is None:
            continue
        try:
            if not e.is_file(follow_symlinks=False):
                continue
            if m.group(1) is not None:
                if _running(int(m.group(1))):
                    continue
            elif now - e.stat(follow_symlinks=False).st_mtime < _OLD_TEMP_AGE:
                continue
            os.unlink(e.path)
            removed.append(Path(e.path))
        except OSError:
            pass
    return removed


def _resolve(path) -> Path:
    """The file a write to ``path`` replaces: a symbolic link's target (written through)."""
    p = Path(path)
    return Path(os.path.realpath(p)) if p.is_symlink() else p


def check_output(path) -> Path:
    """InvalidArgumentError now, before any work, if ``path`` cannot be written: its folder is
    missing or not writable, or it is a folder. Returns the file a write would replace."""
    target = _resolve(path)
    folder = target.parent
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "does not exist"
        raise InvalidArgumentError(f"cannot write {path}: the output folder {folder} {what}; create it first")
    if target.is_dir():
        raise InvalidArgumentError(f"cannot write {path}: it is a folder; give a file name")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InvalidArgumentError(f"cannot write {path}: no permission to write in the folder {folder}")
    return target


def temp_path(path) -> Path:
    """A fresh temporary name beside ``path`` that keeps its extension (writers such as
    matplotlib and numpy choose the format from it): ``.NAME.PID.XXXXXXXX.part.EXT``. Removes
    the stale temporaries of killed writes in that folder first."""
    p = Path(path)
    folder = p.parent
    if not folder.is_dir():
        check_output(p)  # names the missing folder, not the temporary
    tr = _CURRENT.get()
    if tr is None or folder not in tr.cleaned:  # a command writing many files scans each folder once
        remove_stale(folder)
        if tr is not None:
            tr.cleaned.add(folder)
    return p.with_name(f".{p.name}.{os.getpid()}.{secrets.token_hex(4)}.part{p.suffix}")


def _mode_for(target: Path) -> int:
    """The permission bits of a new file at ``target``: those of the file it replaces, else
    0666 less the umask."""
    try:
        st = os.stat(target)
        if stat.S_ISREG(st.st_mode):
            return stat.S_IMODE(st.st_mode)
    except OSError:
        pass
    return _umask_mode()


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
        self.cleaned: set[Path] = set()  # folders whose stale temporaries are already removed

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
    target = _resolve(path)
    tmp = temp_path(target)
    try:
        yield tmp
        if not tmp.is_file():
            raise OSError(f"the writer made no file {tmp}")
        os.chmod(tmp, _mode_for(target))
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
    target = _resolve(path)
    tmp = temp_path(target)
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o600)
    try:
        os.chmod(tmp, _mode_for(target))  # exact bits, whatever the umask
        kw = {} if mode == "wb" else {"encoding": encoding or "utf-8", "newline": newline}
        fh = os.fdopen(fd, mode, **kw)
    except BaseException:
        os.close(fd)
        _unlink(tmp)
        raise
    try:
        with fh:
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
