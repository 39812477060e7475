"""Every command of the CLI answers bad input with one line on stderr that says what to do
(exit code 1 or 2, no traceback), at once: bad numbers, missing files, FIFOs and folders where
files belong, wrong formats, oversized requests. Each case runs `dpc` in a subprocess with a
timeout, as a user would."""

from __future__ import annotations

import os
import struct
import subprocess
import sys
import zlib

import numpy as np
import pytest

_BIG = "1000000000000"
_NO_OPENEXR = "raise ImportError('No module named OpenEXR (hidden by the test)')\n"

# (arguments, a piece of the message); {d} is the folder of the fixtures below
CASES = [
    # generate
    (["generate", "-m", "white", "-n", "abc"], "'abc' is not a valid integer"),
    (["generate", "-m", "white", "-n", "0"], "0 is not in the range"),
    (["generate", "-m", "white", "-n", _BIG], "DPC_MAX_OUTPUT_BYTES"),
    (["generate", "-m", "bnot-2d", "-n", _BIG], "at most"),
    (["generate", "-m", "white", "-n", "64", "-c", _BIG], "DPC_MAX_OUTPUT_BYTES"),
    (["generate", "-m", "no-such-model"], "dpc list"),
    (["generate", "-m", "{d}/fifo.onnx"], "FIFO"),
    (["generate", "-m", "{d}/folder.onnx"], "directory"),
    (["generate", "-m", "white", "-n", "8", "-f", "jpeg"], "--format"),
    (["generate", "-m", "white", "-n", "8", "-o", "{d}/points.jpeg"], "extension"),
    (["generate", "-m", "white", "-n", "8", "-o", "{d}/missing/p.npy"], "does not exist"),
    (["generate", "-m", "white", "-n", "8", "-s", "-1"], "--seed"),
    # analyze and compare
    (["analyze", "-i", "{d}/missing.npy", "-o", "{d}/out"], "no such file"),
    (["analyze", "-i", "{d}/fifo.npy", "-o", "{d}/out"], "FIFO"),
    (["analyze", "-i", "{d}/garbage.npy", "-o", "{d}/out"], "not a readable .npy"),
    (["analyze", "-i", "{d}/garbage.dat", "-o", "{d}/out"], "could not convert"),
    (["analyze", "-i", "white", "-n", "64", "-o", "{d}/garbage.npy"], "is a file"),
    (["analyze", "-i", "white", "-n", "64", "-c", _BIG, "-o", "{d}/out"], "DPC_MAX_OUTPUT_BYTES"),
    (["analyze", "-i", "white", "-n", "64", "--plot-format", "gif", "-o", "{d}/out"], "choose from"),
    (["compare", "-i", "{d}/fifo.npy", "-o", "{d}/out"], "FIFO"),
    (["compare", "-i", "white", "-n", "64", "-c", _BIG, "-o", "{d}/out"], "DPC_MAX_OUTPUT_BYTES"),
    (["compare", "-o", "{d}/out"], "give inputs"),
    # mask
    (["mask", "-n", _BIG, "-o", "{d}/m.png"], "DPC_MAX_DESIGN_PIXELS"),
    (["mask", "-n", "x", "-o", "{d}/m.png"], "not a valid integer"),
    (["mask", "-m", "bayer", "-n", str(2**20), "-o", "{d}/m.npy"], "DPC_MAX_PIXELS"),
    (["mask", "-m", "white", "-n", "40000", "-o", "{d}/m.npy"], "DPC_MAX_PIXELS"),
    (["mask", "-m", "void-and-cluster", "-n", "2048", "-o", "{d}/m.npy"], "--max-pixels"),
    (["mask", "-m", "stbn", "-n", "8", "--frames", "1000000", "-o", "{d}/m.npy"], "--max-pixels"),
    (["mask", "-m", "no-such-mask", "-o", "{d}/m.png"], "unknown mask"),
    (["mask", "-o", "{d}/m.jpg"], "must end in"),
    (["mask", "-o", "{d}/missing/m.png"], "does not exist"),
    (["mask"], "give -o"),
    (["mask", "--channels", "9", "-o", "{d}/m.png"], "--channels"),
    (["mask", "--bits", "12", "-o", "{d}/m.png"], "--bits"),
    # dither
    (["dither", "{d}/fifo.png", "-o", "{d}/o.png"], "FIFO"),
    (["dither", "{d}/folder.png", "-o", "{d}/o.png"], "directory"),
    (["dither", "{d}/missing.png", "-o", "{d}/o.png"], "does not exist"),
    (["dither", "{d}/garbage.png", "-o", "{d}/o.png"], "cannot read image"),
    (["dither", "{d}/bomb.png", "-o", "{d}/o.png"], "DPC_MAX_PIXELS"),
    (["dither", "{d}/small.png", "-o", "{d}/o.jpg"], ".png"),
    (["dither", "{d}/small.png", "-o", "{d}/missing/o.png"], "does not exist"),
    (["dither", "{d}/small.png", "-m", "no-such-mask", "-o", "{d}/o.png"], "unknown mask"),
    (["dither", "{d}/small.png", "-m", "white", "-n", "40000", "-o", "{d}/o.png"], "DPC_MAX_PIXELS"),
    (["dither", "{d}/small.png", "--mask-output", "{d}/m.exr", "-o", "{d}/o.png"], "--mask-output"),
    (["stipple", "{d}/fifo.png", "-o", "{d}/o.png"], "FIFO"),
    (["stipple", "{d}/missing.png", "-o", "{d}/o.png"], "does not exist"),
    (["stipple", "{d}/garbage.png", "-o", "{d}/o.png"], "cannot read image"),
    (["stipple", "{d}/bomb.png", "-o", "{d}/o.png"], "DPC_MAX_PIXELS"),
    (["stipple", "{d}/small.png", "-o", "{d}/o.jpg"], ".svg"),
    (["stipple", "{d}/small.png", "-m", "bnot-3d", "-o", "{d}/o.png"], "2-D model"),
    (["generate", "-m", "bnot-2d", "--invert"], "--density"),
    # list, the group
    (["list", "extra"], "unexpected extra argument"),
    (["no-such-command"], "No such command"),
]


def _png_claiming(path, width: int, height: int) -> None:
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    body = chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"")) + chunk(b"IEND", b"")
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + body)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    import matplotlib.image as mpimg

    d = tmp_path_factory.mktemp("bad-input")
    for name in ("fifo.png", "fifo.npy", "fifo.onnx"):
        os.mkfifo(d / name)
    for name in ("folder.png", "folder.onnx"):
        (d / name).mkdir()
    (d / "garbage.npy").write_bytes(b"not an array at all")
    (d / "garbage.png").write_bytes(b"not an image")
    (d / "garbage.dat").write_text("0.1 0.2\n0.3 x\n")
    _png_claiming(d / "bomb.png", 40000, 40000)  # 100 bytes that claim 1.6 G pixels
    mpimg.imsave(d / "small.png", np.linspace(0, 1, 64).reshape(8, 8), cmap="gray")
    return d


def dpc_run(args, cwd, env=None, timeout=60):
    return subprocess.run(
        [sys.executable, "-m", "dpc.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,  # a hang (a FIFO read, unbounded work) fails the test
        cwd=cwd,
        env={**os.environ, **(env or {})},
    )


def _assert_one_line_error(r, fragment: str) -> None:
    lines = r.stderr.strip().splitlines()
    assert r.returncode in (1, 2), (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr, r.stderr
    assert len(lines) == 1 and lines[0].startswith("dpc: error: "), r.stderr
    assert fragment in lines[0], lines[0]


@pytest.mark.parametrize("args, fragment", CASES, ids=[" ".join(a)[:60] for a, _ in CASES])
def test_bad_input_is_one_line_with_the_fix(files, args, fragment):
    r = dpc_run([a.format(d=files) for a in args], cwd=files)
    _assert_one_line_error(r, fragment)
    assert not (files / "out").exists() and not (files / "o.png").exists() and not (files / "m.png").exists()


def test_every_command_is_covered():
    r = dpc_run(["--help"], cwd=".")
    commands = [line.split()[0] for line in r.stdout.split("Commands:")[1].splitlines() if line.strip()]
    assert set(commands) <= {args[0] for args, _ in CASES}, commands


def test_exr_without_openexr_fails_at_once_naming_the_extra(files, tmp_path):
    """Before any work: an annealed 128 x 128 of seed 5 would be designed for minutes."""
    (tmp_path / "OpenEXR.py").write_text(_NO_OPENEXR)
    env = {"PYTHONPATH": os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")])}
    r = dpc_run(["mask", "-n", "128", "-s", "5", "-o", tmp_path / "m.exr"], cwd=tmp_path, env=env, timeout=30)
    _assert_one_line_error(r, "[masks]")
    assert 'pip install "deep-point-correlation[masks]"' in r.stderr and 'pip install ".[masks]"' in r.stderr


def test_png_needs_no_extra_package(tmp_path):
    """pypng (the masks extra) hidden: dpc mask still writes PNG, exactly."""
    (tmp_path / "png.py").write_text("raise ImportError('No module named png (hidden by the test)')\n")
    env = {"PYTHONPATH": os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")])}
    out = tmp_path / "m.png"
    r = dpc_run(["mask", "-m", "void-and-cluster", "-n", "32", "-s", "2", "-o", out], cwd=tmp_path, env=env)
    assert r.returncode == 0, r.stderr
    from dpc import baselines as B
    from dpc import masks as M

    assert np.array_equal(M.rank_normalise(M.read_mask(out), "scalar"), B.void_and_cluster(32, 2))
