"""Atomic writes' side effects (dpc._atomic): the leftovers of a killed write are removed by the
next write to that folder (never a running writer's), an overwritten file keeps its mode, a
symbolic link is written through, a hard link's name gets the new file, and a missing output
folder is reported before the work, by its name."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from dpc import _atomic
from dpc.errors import InvalidArgumentError

WRITER = textwrap.dedent(
    """
    import sys, time
    from dpc import _atomic
    with _atomic.atomic_file(sys.argv[1], "wb") as fh:
        fh.write(b"x" * 1_000_000)
        fh.flush()
        print("writing", flush=True)
        time.sleep(120)
    """
)


def _start_writer(target):
    p = subprocess.Popen([sys.executable, "-c", WRITER, str(target)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "writing"
    return p


def _temps(folder):
    return sorted(p.name for p in folder.iterdir() if ".part" in p.name)


def test_a_killed_writes_leftover_is_removed_by_the_next_write(tmp_path):
    target = tmp_path / "points.npy"
    target.write_bytes(b"old")
    p = _start_writer(target)
    left = _temps(tmp_path)
    assert len(left) == 1 and left[0].startswith(f".points.npy.{p.pid}.") and left[0].endswith(".part.npy")
    p.send_signal(signal.SIGKILL)
    p.wait(timeout=30)
    p.stdout.close()
    assert _temps(tmp_path) == left  # kill -9: nothing could clean up
    assert target.read_bytes() == b"old"
    _atomic.write_bytes(tmp_path / "other.txt", b"new")  # any write to the folder
    assert _temps(tmp_path) == []
    assert target.read_bytes() == b"old" and (tmp_path / "other.txt").read_bytes() == b"new"


def test_a_running_writers_temporary_is_kept(tmp_path):
    p = _start_writer(tmp_path / "a.npy")
    try:
        live = _temps(tmp_path)
        _atomic.write_bytes(tmp_path / "b.npy", b"b")
        assert _temps(tmp_path) == live
    finally:
        p.kill()
        p.wait(timeout=30)
        p.stdout.close()


def test_old_pidless_leftovers_go_after_an_hour(tmp_path):
    old, fresh = tmp_path / ".m.png.0123abcd.part.png", tmp_path / ".n.png.89abcdef.part.png"
    old.write_bytes(b"x")
    fresh.write_bytes(b"y")
    hour_ago = time.time() - 3700
    os.utime(old, (hour_ago, hour_ago))
    _atomic.write_text(tmp_path / "t.txt", "t")
    assert not old.exists() and fresh.exists()


def test_an_overwritten_file_keeps_its_mode(tmp_path):
    f = tmp_path / "secret.json"
    f.write_text("{}")
    os.chmod(f, 0o600)
    _atomic.write_text(f, '{"a": 1}')
    assert stat.S_IMODE(f.stat().st_mode) == 0o600 and f.read_text() == '{"a": 1}'
    os.chmod(f, 0o640)
    with _atomic.atomic_path(f) as tmp:  # a writer that wants a file name
        tmp.write_text("[]")
    assert stat.S_IMODE(f.stat().st_mode) == 0o640
    with _atomic.transaction():
        _atomic.write_text(f, "[1]")
    assert stat.S_IMODE(f.stat().st_mode) == 0o640 and f.read_text() == "[1]"
    new = tmp_path / "new.txt"
    _atomic.write_text(new, "n")
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(new.stat().st_mode) == 0o666 & ~mask


def test_a_symlink_is_written_through(tmp_path):
    real_dir, link_dir = tmp_path / "real", tmp_path / "links"
    real_dir.mkdir()
    link_dir.mkdir()
    real = real_dir / "mask.npy"
    np.save(real, np.zeros(3))
    os.chmod(real, 0o600)
    link = link_dir / "mask.npy"
    link.symlink_to(real)
    with _atomic.atomic_file(link, "wb") as fh:
        np.save(fh, np.ones(3))
    assert link.is_symlink() and os.readlink(link) == str(real)
    assert np.array_equal(np.load(real), np.ones(3)) and stat.S_IMODE(real.stat().st_mode) == 0o600
    assert sorted(p.name for p in link_dir.iterdir()) == ["mask.npy"]
    dangling = link_dir / "later.txt"
    dangling.symlink_to(real_dir / "later.txt")  # as open() does: the target is created
    _atomic.write_text(dangling, "made")
    assert dangling.is_symlink() and (real_dir / "later.txt").read_text() == "made"


def test_a_hard_links_name_gets_the_new_file(tmp_path):
    """Documented: writing through a hard link cannot be atomic, so the name written gets a new
    file and the other names keep the old contents."""
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    a.write_text("old")
    os.link(a, b)
    _atomic.write_text(a, "new")
    assert a.read_text() == "new" and b.read_text() == "old"


def test_a_missing_folder_is_named_not_the_temporary(tmp_path):
    target = tmp_path / "missing" / "out.npy"
    for write in (
        lambda: _atomic.write_bytes(target, b"x"),
        lambda: _atomic.atomic_file(target).__enter__(),
        lambda: _atomic.check_output(target),
    ):
        with pytest.raises(InvalidArgumentError) as e:
            write()
        msg = str(e.value)
        assert f"folder {tmp_path / 'missing'} does not exist" in msg and ".part" not in msg
    with pytest.raises(InvalidArgumentError, match="is a folder"):
        _atomic.check_output(tmp_path)


@pytest.mark.parametrize(
    "args",
    [
        # an annealed 128 x 128 of seed 5 is designed on the spot: minutes of work
        ["mask", "-n", "128", "-s", "5", "-o", "{missing}/mask.png"],
        ["mask", "-m", "void-and-cluster", "-n", "256", "-o", "{missing}/mask.npy"],
        ["generate", "-m", "bnot-2d", "-n", "3000000", "-c", "4", "-o", "{missing}/points.npy"],
        ["dither", "{image}", "-o", "{missing}/out.png"],
        ["dither", "{image}", "-o", "{tmp}/out.png", "--mask-output", "{missing}/mask.npy"],
    ],
)
def test_cli_reports_a_missing_output_folder_before_the_work(tmp_path, args):
    import matplotlib.image as mpimg

    image = tmp_path / "in.png"
    mpimg.imsave(image, np.linspace(0, 1, 64).reshape(8, 8), cmap="gray")
    fill = {"missing": tmp_path / "missing", "image": image, "tmp": tmp_path}
    argv = [a.format(**fill) for a in args]
    t0 = time.monotonic()
    r = subprocess.run(
        [sys.executable, "-m", "dpc.cli", *argv], capture_output=True, text=True, timeout=60, cwd=tmp_path
    )
    took = time.monotonic() - t0
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 1 and len(lines) == 1, r.stderr
    assert f"the output folder {tmp_path / 'missing'} does not exist" in lines[0], lines
    assert took < 30, f"reported after {took:.1f} s: after the work?"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.png"]
