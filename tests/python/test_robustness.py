"""Robustness: no dead ends in the researcher's workflow, no bad input that loses data or hangs.

* every command that takes a model takes a bundled name, a name in $DPC_MODEL_PATH or a .onnx
  path; analyze/compare overlay the model's target and write PNG + PDF/SVG; dpc list prints
  whole descriptions and input kinds;
* every writer is atomic: a write failure injected by the kernel (RLIMIT_FSIZE: the write fails
  with EFBIG as on a full disk) or by a patched fsync leaves existing files byte for byte and
  no new file or folder;
* size limits before allocation, Ctrl-C within 0.5 s with no partial output;
* FIFOs, folders, devices and NUL bytes in paths; the work bound max_neighbours;
* strict counts and seeds; .csv with commas, .npy in float32, UTK's format names.
"""

import json
import math
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import dpc
from dpc import _atomic, pointio
from dpc.cli import main

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "tests" / "data"
DPC = [sys.executable, "-m", "dpc.cli"]


def run(capsys, *args):
    rc = main(list(map(str, args)))
    out, err = capsys.readouterr()
    return rc, out, err


def cli(*args, limit=None, env=None, cwd=None, timeout=300):
    """The dpc command in a subprocess; limit: RLIMIT_FSIZE in bytes (writes beyond fail)."""

    def pre():
        if limit is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return subprocess.run(
        DPC + [str(a) for a in args],
        capture_output=True,
        text=True,
        preexec_fn=pre,
        env={**os.environ, **(env or {})},
        cwd=cwd,
        timeout=timeout,
    )


def snapshot(folder: Path) -> dict:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


# ---------------------------------------------------------------- item 3: workflow
def test_analyze_and_compare_take_onnx_paths_and_overlay_targets(tmp_path, capsys):
    onnx = tmp_path / "my-model.onnx"
    shutil.copy(REPO / "models" / "bnot-2d.onnx", onnx)
    rc, out, err = run(
        capsys,
        "analyze",
        "-i",
        onnx,
        "-c",
        2,
        "-o",
        tmp_path / "a",
        "--discrepancy",
        "none",
        "--plot-format",
        "png,pdf,svg",
    )
    assert rc == 0, err
    doc = json.loads((tmp_path / "a" / "metrics.json").read_text())
    assert doc["targets"][0]["label"].startswith("target: bnot"), doc.get("targets")
    for stem in ("radial", "pcf", "points", "spectrum"):
        assert (tmp_path / "a" / f"{stem}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert (tmp_path / "a" / f"{stem}.pdf").read_bytes()[:5] == b"%PDF-"
        assert b"<svg" in (tmp_path / "a" / f"{stem}.svg").read_bytes()[:2000]
    svg = (tmp_path / "a" / "radial.svg").read_text()
    # legend entries and axis labels are text in the SVG (matplotlib keeps labels as paths by
    # default, so look for the ids it writes for them)
    assert "legend" in svg and "axes_1" in svg and "axes_2" in svg, "two panels, with a legend"
    rc, out, err = run(
        capsys,
        "compare",
        "-i",
        onnx,
        "-i",
        "jitter-2d",
        "-c",
        2,
        "-o",
        tmp_path / "c",
        "--discrepancy",
        "none",
        "--no-integration",
    )
    assert rc == 0, err
    doc = json.loads((tmp_path / "c" / "compare.json").read_text())
    labels = [t["label"] for t in doc["targets"]]
    assert any("bnot" in t for t in labels) and any("jitter" in t for t in labels), labels
    assert (tmp_path / "c" / "radial.pdf").is_file() and (tmp_path / "c" / "points.pdf").is_file()


def test_targets_come_from_the_model_metadata():
    from dpc.analysis.targets import model_target

    t = model_target(dpc.load("bnot-2d"))
    ref = dpc.analysis.reference.reference_radial_spectrum("bnot", 1024, 2)
    np.testing.assert_allclose(t.power, ref.power[: len(t.power)])
    np.testing.assert_allclose(t.nu, ref.nu[: len(t.nu)])
    assert model_target(dpc.load("bnot-3d")).dims == 3
    # The authors' 5-D file is their 2-D spectrum (docs/analysis.md, "Reference targets"): the label says so.
    assert "2-D spectrum" in model_target(dpc.load("bnot-5d")).label
    assert "2-D spectrum" not in model_target(dpc.load("bnot-3d")).label
    assert model_target(dpc.load("font-2d")) is None  # Eq. 5 variance: no radial target
    assert model_target(dpc.load("repulsion-2d")) is None  # hand-made: no loss


def test_every_model_option_takes_a_name_from_dpc_model_path(tmp_path, capsys, monkeypatch):
    folder = tmp_path / "zoo"
    folder.mkdir()
    shutil.copy(REPO / "models" / "bnot-2d.onnx", folder / "my-blue.onnx")
    monkeypatch.setenv("DPC_MODEL_PATH", str(folder))
    assert "my-blue" in dpc.available_models()
    rc, out, err = run(capsys, "generate", "-m", "my-blue", "-n", 64, "-o", tmp_path / "p.npy")
    assert rc == 0, err
    rc, out, err = run(
        capsys,
        "analyze",
        "-i",
        "my-blue",
        "-c",
        2,
        "-n",
        256,
        "-o",
        tmp_path / "a",
        "--discrepancy",
        "none",
        "--no-plots",
    )
    assert rc == 0, err
    rc, out, _ = run(capsys, "list")
    assert "my-blue" in out and f"DPC_MODEL_PATH={folder}" in out


def test_list_prints_whole_descriptions_and_input_kinds(capsys):
    rc, out, _ = run(capsys, "list")
    assert rc == 0
    flat = " ".join(out.split())
    for name in ("bnot-2d", "bnot-2d-stratified", "step-2d"):
        m = dpc.load(name)
        desc = " ".join(m.metadata["dpc.description"].split())
        assert desc in flat, f"{name}: description cut: {desc!r}"
        assert f"{name} {m.dims}-D, trained m={m.n_points}, {m.layers} layers, {m.input} input" in flat
    assert "bnot-2d-stratified 2-D, trained m=1024, 40 layers, stratified input" in flat
    assert "et al. 2013)" in flat  # where the first-sentence cut used to stop


# ---------------------------------------------------------------- item 4: no write loses data
def _no_temporaries(folder: Path):
    left = [p.name for p in folder.rglob(".*") if ".part" in p.name or p.name.endswith(".tmp")]
    assert not left, f"temporary files left: {left}"


@pytest.mark.parametrize("ext", [".npy", ".dat", ".csv", ".bin"])
def test_generate_write_failure_keeps_the_existing_file(tmp_path, ext):
    out = tmp_path / f"points{ext}"
    old = b"precious old contents\n" * 10
    out.write_bytes(old)
    r = cli("generate", "-m", "bnot-2d", "-n", 16384, "-o", out, limit=64 * 1024)
    assert r.returncode == 1, r.stderr
    assert r.stderr.startswith(f"dpc: error: cannot write {out}: ") and len(r.stderr.splitlines()) == 1, r.stderr
    assert out.read_bytes() == old
    _no_temporaries(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == [out.name]
    # a new file: none at all after the failure
    r = cli("generate", "-m", "bnot-2d", "-n", 16384, "-o", tmp_path / f"new{ext}", limit=64 * 1024)
    assert r.returncode == 1 and not (tmp_path / f"new{ext}").exists()
    # and without the limit it works
    r = cli("generate", "-m", "bnot-2d", "-n", 16384, "-o", out)
    assert r.returncode == 0, r.stderr
    assert pointio.read_points(out).shape == (1, 16384, 2)


@pytest.mark.parametrize("command", ["analyze", "compare"])
def test_analysis_write_failure_changes_nothing(tmp_path, command):
    existing = tmp_path / "old"
    existing.mkdir()
    (existing / "metrics.json").write_text('{"old": true}\n')
    (existing / "radial.png").write_bytes(b"old png")
    before = snapshot(existing)
    args = [command, "-i", "bnot-2d", "-c", 2, "--discrepancy", "none"]
    # 40 KiB: the JSON fits, the plots do not
    r = cli(*args, "-o", existing, limit=40 * 1024)
    assert r.returncode == 1, r.stderr
    assert snapshot(existing) == before
    _no_temporaries(existing)
    fresh = tmp_path / "new" / "deeper"
    r = cli(*args, "-o", fresh, limit=40 * 1024)
    assert r.returncode == 1
    assert not (tmp_path / "new").exists(), "the folders the failed command created are gone"
    r = cli(*args, "-o", existing)
    assert r.returncode == 0, r.stderr
    assert json.loads((existing / "metrics.json" if command == "analyze" else existing / "compare.json").read_text())


def test_training_export_and_checkpoint_write_failures_keep_the_old_files(tmp_path):
    train = [
        sys.executable,
        str(REPO / "training" / "train.py"),
        "--config",
        str(REPO / "training" / "configs" / "tiny-test.toml"),
        "--run-dir",
        str(tmp_path / "run"),
        "--no-progress",
    ]
    r = subprocess.run(train + ["--steps", "10"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    ckpt = tmp_path / "run" / "checkpoint.pt"
    good = ckpt.read_bytes()

    def limited(n):
        return lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (n, n))

    r = subprocess.run(
        train + ["--steps", "20", "--resume"],
        capture_output=True,
        text=True,
        timeout=300,
        preexec_fn=limited(len(good) // 2),
    )
    assert r.returncode == 2 and "File too large" in r.stderr, r.stderr
    assert ckpt.read_bytes() == good
    _no_temporaries(tmp_path / "run")
    export = [sys.executable, str(REPO / "training" / "export.py"), str(ckpt)]
    model = tmp_path / "m.onnx"
    model.write_bytes(b"old model")
    r = subprocess.run(
        export + ["-o", str(model)], capture_output=True, text=True, timeout=300, preexec_fn=limited(256)
    )
    assert r.returncode == 2 and "File too large" in r.stderr, r.stderr
    assert model.read_bytes() == b"old model"
    _no_temporaries(tmp_path)
    r = subprocess.run(export + ["-o", str(model)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert dpc.load(model).layers == 4


def test_patched_writer_failure_in_process(tmp_path, monkeypatch):
    """The same guarantee in one process: fsync fails (as on a full disk) for every writer."""
    import errno

    from matplotlib.figure import Figure

    from dpc.analysis import plots

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    files = {"p.npy": b"a", "p.csv": b"b", "m.json": b"c", "f.png": b"d"}
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    monkeypatch.setattr(_atomic.os, "fsync", full)
    with pytest.raises(OSError, match="No space"):
        pointio.write_points(tmp_path / "p.npy", np.zeros((4, 2), np.float32))
    with pytest.raises(OSError, match="No space"):
        pointio.write_points(tmp_path / "p.csv", np.zeros((4, 2)))
    with pytest.raises(OSError, match="No space"):
        _atomic.write_text(tmp_path / "m.json", "{}")
    fig = Figure()
    fig.subplots().plot([0, 1])
    with pytest.raises(OSError, match="No space"):
        plots._save(fig, tmp_path / "f.png", formats=["pdf"])
    assert snapshot(tmp_path) == files  # nothing changed, nothing added (no f.pdf either)


def test_transaction_is_all_or_nothing(tmp_path):
    (tmp_path / "a.txt").write_text("old a")
    with pytest.raises(RuntimeError):
        with _atomic.transaction():
            d = _atomic.make_dir(tmp_path / "x" / "y")
            _atomic.write_text(tmp_path / "a.txt", "new a")
            _atomic.write_text(d / "b.txt", "new b")
            assert (tmp_path / "a.txt").read_text() == "old a", "nothing visible before the end"
            raise RuntimeError("the command failed")
    assert snapshot(tmp_path) == {"a.txt": b"old a"} and not (tmp_path / "x").exists()
    with _atomic.transaction():
        _atomic.write_text(tmp_path / "a.txt", "new a")
    assert (tmp_path / "a.txt").read_text() == "new a"


# ---------------------------------------------------------------- item 5: limits, Ctrl-C
def test_total_size_guard_before_allocation(capsys):
    m = dpc.load("bnot-2d")
    t = time.perf_counter()
    with pytest.raises(dpc.LimitError, match="max_bytes") as e:
        m.generate_batch(100, n_points=2**26)
    assert "50 GiB" in str(e.value) and time.perf_counter() - t < 1.0
    assert isinstance(e.value, dpc.InvalidArgumentError)
    with pytest.raises(dpc.LimitError):
        m.generate_batch(2, n_points=1000, max_bytes=1000)
    assert m.generate_batch(2, n_points=1000, max_bytes=16000).shape == (2, 1000, 2)
    rc, _, err = run(capsys, "generate", "-m", "bnot-2d", "-n", 67108864, "-c", 100, "-o", "/tmp/x.npy")
    assert rc == 1 and "--max-output" in err and "50 GiB" in err, err
    rc, _, err = run(capsys, "generate", "-m", "bnot-2d", "-n", 1000, "-c", 2, "--max-output", "1K")
    assert rc == 1 and "limit" in err, err


def test_max_output_bytes_from_the_environment(monkeypatch):
    monkeypatch.setenv("DPC_MAX_OUTPUT_BYTES", "1K")
    with pytest.raises(dpc.LimitError):
        dpc.load("bnot-2d").generate(0, 1000)
    monkeypatch.setenv("DPC_MAX_OUTPUT_BYTES", "lots")
    with pytest.raises(dpc.InvalidArgumentError, match="DPC_MAX_OUTPUT_BYTES"):
        dpc.load("bnot-2d").generate(0, 10)


def test_ctrl_c_stops_the_cli_within_half_a_second_without_output(tmp_path):
    out = tmp_path / "big.npy"
    p = subprocess.Popen(
        DPC + ["generate", "-m", "bnot-2d", "-n", "2000000", "-t", "1", "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    time.sleep(3.0)  # started, loaded, inside libdpc
    assert p.poll() is None, p.communicate()
    t = time.perf_counter()
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=30)
    latency = time.perf_counter() - t
    print(f"Ctrl-C to exit: {latency:.3f} s")
    assert p.returncode == 130 and "dpc: interrupted" in err, err
    assert latency < 0.5, latency
    assert not out.exists() and not list(tmp_path.iterdir())


def test_ctrl_c_in_python_raises_at_once_and_libdpc_stops_between_sets():
    probe = REPO / "tests" / "python" / "interrupt_probe.py"
    r = subprocess.run([sys.executable, str(probe), "5000", "400"], capture_output=True, text=True, timeout=300)
    res = json.loads(r.stdout.strip().splitlines()[-1])
    print(res)
    assert res["interrupted"] and res["raise_s"] < 0.5, res
    assert res["cpu_after_s"] < 0.1, f"libdpc kept working after the cancel: {res}"


def test_progress_callback_and_cancel_by_exception():
    m = dpc.load("bnot-2d", threads=1)
    seen = []
    m.generate_batch(3, seed=1, n_points=30000, progress=lambda d, t: seen.append((d, t)))
    assert seen[-1] == (3 * m.layers, 3 * m.layers)

    class Stop(Exception):
        pass

    def stop(done, total):
        raise Stop()

    with pytest.raises(Stop):
        m.generate_batch(50, seed=1, n_points=30000, progress=stop)


# ---------------------------------------------------------------- item 6: robustness
@pytest.mark.parametrize("kind", ["fifo", "dir", "device"])
def test_load_refuses_non_regular_files_without_hanging(tmp_path, kind):
    if kind == "fifo":
        path = tmp_path / "m.onnx"
        os.mkfifo(path)
    elif kind == "dir":
        path = tmp_path / "d.onnx"
        path.mkdir()
    else:
        path = Path("/dev/zero")
    t = time.perf_counter()
    with pytest.raises(dpc.ModelIOError, match="regular file"):
        dpc.load(path)
    assert time.perf_counter() - t < 2.0


def test_nul_in_paths_is_refused(tmp_path, capsys):
    shutil.copy(REPO / "models" / "bnot-2d.onnx", tmp_path / "m.onnx")
    for bad in (str(tmp_path / "m.onnx") + "\0junk", "bnot-2d\0x"):
        with pytest.raises(dpc.InvalidArgumentError, match="NUL"):
            dpc.load(bad)
    with pytest.raises(dpc.InvalidArgumentError, match="NUL"):
        pointio.write_points(str(tmp_path / "p.npy") + "\0x", np.zeros((2, 2)))


@pytest.mark.parametrize("n", [2**26 + 1, 2**40, 2**62, 2**70])
def test_oversize_counts_are_limit_errors_before_allocation(n):
    m = dpc.load("bnot-2d")
    for call in (lambda: m.generate(0, n), lambda: m.generate_batch(2, n_points=n), lambda: dpc.stratified(0, n, 2)):
        with pytest.raises(dpc.LimitError):
            call()
    with pytest.raises(dpc.LimitError):
        m.generate_batch(n, n_points=1000)
    with pytest.raises(dpc.LimitError):
        dpc.uniform(0, n, 2**30)


def _wide_model(tmp_path, radius):
    from dpc import model_file as mf

    kern = (-0.05 * np.sin(np.pi * np.linspace(0.0, 1.0, 16)))[None, :]
    layers = [mf.Layer([0b11], [radius], kern) for _ in range(3)]
    path = tmp_path / f"wide-{radius:g}.onnx"
    mf.write_model(mf.ModelSpec(dims=2, n_points=1024, layers=layers, name="wide"), path)
    return path


def test_work_bound_refuses_huge_radii_by_default(tmp_path):
    path = _wide_model(tmp_path, 1e6)
    m = dpc.load(path)
    assert math.isinf(m.neighbours) or m.neighbours > 1e12
    assert m.generate(0, 4000).shape == (4000, 2)  # 3,999 neighbours per point: within 4,096
    t = time.perf_counter()
    with pytest.raises(dpc.LimitError, match="max_neighbours"):
        m.generate(0, 16000)
    assert time.perf_counter() - t < 0.5, "refused before any work"
    strict = dpc.load(path, max_neighbours=100)
    with pytest.raises(dpc.LimitError):
        strict.generate(0, 500)
    assert dpc.load(path, max_neighbours=math.inf).generate(0, 600).shape == (600, 2)
    for bad in (0, -1, math.nan, "many", True):
        with pytest.raises(dpc.InvalidArgumentError):
            dpc.load(path, max_neighbours=bad)


def test_every_bundled_model_passes_the_default_work_bound():
    worst = max((dpc.load(n).neighbours, n) for n in dpc.available_models())
    print(f"largest expected neighbours per point: {worst[0]:.1f} ({worst[1]})")
    assert worst[0] <= dpc.DEFAULT_MAX_NEIGHBOURS


# ---------------------------------------------------------------- item 7: strict arguments
@pytest.mark.parametrize("bad", [10.5, 10.0, "100", True, None.__class__])
def test_non_integral_counts_are_refused(bad):
    m = dpc.load("bnot-2d")
    with pytest.raises(dpc.InvalidArgumentError):
        m.generate(0, bad)
    with pytest.raises(dpc.InvalidArgumentError):
        m.generate_batch(bad, seed=0, n_points=10)


@pytest.mark.parametrize("bad", [-1, 1.5, 2.0, "3", 2**64, 2**70, False])
def test_seeds_are_integers_in_0_to_2_pow_64(bad, capsys):
    m = dpc.load("bnot-2d")
    with pytest.raises(dpc.InvalidArgumentError):
        m.generate(bad, 10)
    with pytest.raises(dpc.InvalidArgumentError):
        m.generate_batch(2, seed=bad, n_points=10)
    with pytest.raises(dpc.InvalidArgumentError):
        dpc.uniform(bad, 4, 2)
    if isinstance(bad, int) and not isinstance(bad, bool):
        rc, _, err = run(capsys, "generate", "-m", "bnot-2d", "-n", 10, "-s", bad)
        assert rc == 2 and "seed" in err, err


def test_largest_seed_works_and_batches_wrap_like_c(capsys):
    m = dpc.load("bnot-2d")
    top = 2**64 - 1
    b = m.generate_batch(2, seed=top, n_points=50)
    assert np.array_equal(b[1], m.generate(0, 50))
    rc, out, err = run(capsys, "generate", "-m", "bnot-2d", "-n", 50, "-c", 2, "-s", top)
    assert rc == 0, err
    sets = out.split("#\n")
    assert np.allclose(np.loadtxt(sets[1].splitlines()), m.generate(0, 50).astype(np.float64))


def test_csv_is_comma_separated_and_npy_keeps_float32(tmp_path, capsys):
    m = dpc.load("bnot-2d")
    rc, _, err = run(capsys, "generate", "-m", "bnot-2d", "-n", 20, "-c", 2, "-o", tmp_path / "p.csv")
    assert rc == 0, err
    lines = (tmp_path / "p.csv").read_text().splitlines()
    assert lines[0].count(",") == 1 and " " not in lines[0] and lines[20] == "#"
    np.testing.assert_array_equal(
        pointio.read_points(tmp_path / "p.csv"), m.generate_batch(2, n_points=20).astype(np.float64)
    )
    rc, _, _ = run(capsys, "generate", "-m", "bnot-2d", "-n", 20, "-o", tmp_path / "p.npy")
    a = np.load(tmp_path / "p.npy")
    assert a.dtype == np.float32 and np.array_equal(a, m.generate(0, 20))
    rc, out, _ = run(capsys, "generate", "-m", "bnot-2d", "-n", 3, "-f", "csv")
    assert rc == 0 and all(ln.count(",") == 1 for ln in out.splitlines())


def test_format_names_are_utks(tmp_path, capsys):
    rc, _, err = run(capsys, "generate", "-m", "white", "-n", 8, "-f", "utk", "-o", tmp_path / "x")
    assert rc == 2, err
    rc, _, err = run(capsys, "generate", "-m", "white", "-n", 8, "-f", "bin", "-o", tmp_path / "x")
    assert rc == 0 and (tmp_path / "x").stat().st_size == 4 + 8 * 2 * 8
    rc, _, err = run(capsys, "generate", "-m", "white", "-n", 8, "-f", "dat", "-o", tmp_path / "y")
    assert rc == 0 and (tmp_path / "y").read_text().count("\n") == 8


@pytest.mark.parametrize("command", ["generate", "analyze", "compare"])
def test_help_lists_every_extension(command, capsys):
    rc, out, _ = run(capsys, command, "--help")
    flat = " ".join(out.split())
    for ext in pointio.EXTENSIONS:
        assert ext in flat, (command, ext)
    assert ".onnx" in flat and "DPC_MODEL_PATH" in flat
