"""The dpc command line: every subcommand, every file format, one-line errors."""

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

import dpc
from dpc import analysis, baselines
from dpc.cli import main
from dpc.pointio import read_points

PNG = b"\x89PNG\r\n\x1a\n"


def run(capsys, *args):
    rc = main(list(map(str, args)))
    out, err = capsys.readouterr()
    return rc, out, err


def _one_line_error(err):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("dpc: error: "), err
    assert "Traceback" not in err


def test_list_shows_models_and_baselines(capsys):
    rc, out, _ = run(capsys, "list")
    assert rc == 0
    for name in dpc.available_models() + baselines.available():
        assert name in out
    assert "models:" in out and "baselines:" in out


@pytest.mark.parametrize("ext", [".npy", ".txt", ".bin"])
def test_generate_baseline_in_every_format(tmp_path, capsys, ext):
    f = tmp_path / f"sobol{ext}"
    rc, _, err = run(capsys, "generate", "-m", "sobol", "-n", 128, "-d", 3, "-s", 4, "-c", 3, "-o", f)
    assert rc == 0 and "wrote 3 sets" in err
    np.testing.assert_array_equal(read_points(f), baselines.generate("sobol", 128, dims=3, count=3, seed=4))


def test_generate_utk_text_format_option_and_float32_bin(tmp_path, capsys):
    f = tmp_path / "w.dat"
    assert run(capsys, "generate", "-m", "white", "-n", 16, "-c", 2, "-f", "dat", "-o", f)[0] == 0
    assert f.read_text().count("#\n") == 1
    g = tmp_path / "w.bin"
    rc = run(capsys, "generate", "-m", "white", "-n", 64, "-o", g, "--bin-dtype", "float32")[0]
    assert rc == 0 and g.stat().st_size == 4 + 64 * 2 * 4


def test_generate_from_a_model(tmp_path, capsys):
    names = dpc.available_models()
    assert names, "no bundled model: the package must ship at least one"
    model = dpc.load(names[0])
    f = tmp_path / "m.npy"
    n = model.n_points
    rc, _, err = run(capsys, "generate", "-m", names[0], "-s", 3, "-c", 2, "-o", f)
    assert rc == 0, err
    got = read_points(f)
    np.testing.assert_array_equal(got, model.generate_batch(2, seed=3).astype(np.float64))
    assert got.shape == (2, n, model.dims)


def test_generate_balance_option(tmp_path, capsys):
    f = tmp_path / "b.npy"
    rc, _, err = run(capsys, "generate", "-m", "bnot-2d-stratified", "-c", 2, "--balance", 3, "-o", f)
    assert rc == 0, err
    got = read_points(f)
    want = dpc.load("bnot-2d-stratified").generate_batch(2, seed=0)
    np.testing.assert_array_equal(got, np.stack([dpc.balance(s, 3) for s in want]).astype(np.float64))
    q = np.array([[1, 0], [0, 1], [1, 1], [1, -1], [2, 0], [0, 2]])
    for x in got:
        assert analysis.power_spectrum_direct(x, q).max() < 1e-9
    rc, _, err = run(capsys, "generate", "-m", "jitter", "-n", 256, "--balance", 40)
    assert rc != 0 and "--balance" in err
    # balancing a progressive set afterwards would move its prefixes: refused, nothing written
    p = tmp_path / "p.npy"
    rc, _, err = run(capsys, "generate", "-m", "progressive-2d", "-n", 256, "--balance", 3, "-o", p)
    assert rc != 0 and "prefixes" in err and not p.exists()


def test_generate_with_a_pinned_isa_says_what_ran_it(tmp_path, capsys):
    f = tmp_path / "s.npy"
    rc, _, err = run(capsys, "generate", "-m", "bnot-2d", "--isa", "scalar", "-c", 2, "-s", 4, "-o", f)
    assert rc == 0, err
    expect = dpc.load("bnot-2d", isa="scalar").generate_batch(2, seed=4).astype(np.float64)
    np.testing.assert_array_equal(read_points(f), expect)
    assert "from bnot-2d (cpu, scalar; uniform input) to" in err, err
    rc, _, err = run(capsys, "generate", "-m", "bnot-2d", "--isa", "sse9", "-o", f)
    assert rc == 2 and "sse9" in err


def test_generate_on_the_vulkan_backend_or_a_one_line_error(tmp_path, capsys):
    f = tmp_path / "v.npy"
    try:
        model = dpc.load("bnot-2d", backend="vulkan")
    except dpc.UnsupportedError as e:  # no usable device (or a build without Vulkan)
        rc, _, err = run(capsys, "generate", "-m", "bnot-2d", "--backend", "vulkan", "-o", f)
        assert rc == 1 and not f.exists()
        _one_line_error(err)
        assert "Vulkan" in err and str(e)[-40:] in err
        return
    rc, _, err = run(capsys, "generate", "-m", "bnot-2d", "--backend", "vulkan", "-c", 2, "-o", f)
    assert rc == 0, err
    np.testing.assert_array_equal(read_points(f), model.generate_batch(2, seed=0).astype(np.float64))
    assert f"from bnot-2d (vulkan, {model.device}; uniform input) to" in err, err
    rc, _, err = run(capsys, "generate", "-m", "bnot-2d", "--backend", "cpu", "-o", f)
    assert rc == 0 and "(cpu, " in err, err


def test_generate_to_stdout_reads_back(tmp_path, capsys):
    rc, out, _ = run(capsys, "generate", "-m", "jitter", "-n", 16, "-c", 2, "-s", 1)
    assert rc == 0
    f = tmp_path / "o.txt"
    f.write_text(out)
    np.testing.assert_array_equal(read_points(f), baselines.generate("jitter", 16, count=2, seed=1))


def test_analyze_writes_metrics_and_plots(tmp_path, capsys):
    sets = baselines.generate("jitter", 256, count=6, seed=2)
    a, b = tmp_path / "a.npy", tmp_path / "b.txt"
    np.save(a, sets[:4])
    (tmp_path / "b.txt").write_text("\n#\n".join("\n".join(f"{x!r} {y!r}" for x, y in s.tolist()) for s in sets[4:]))
    out = tmp_path / "out"
    rc, stdout, err = run(capsys, "analyze", "-i", a, b, "-o", out)  # two inputs, one batch
    assert rc == 0, err
    doc = json.loads((out / "metrics.json").read_text())
    assert doc["input"]["sets"] == 6 and doc["input"]["points"] == 256
    want = analysis.power_spectrum_2d(sets).low_frequency_energy(0.5)
    assert doc["summary"]["E_low<0.5"] == pytest.approx(want, rel=1e-9)
    assert doc["min_distance"]["mean_ratio"] == pytest.approx(analysis.min_distance_ratio(sets), rel=1e-12)
    assert doc["discrepancy"]["CD"] == pytest.approx(analysis.discrepancy(sets, "CD"))
    assert len(doc["radial"]["nu"]) == len(doc["radial"]["mean"]) > 50
    assert doc["radial"]["nu"][-1] == pytest.approx(4.0)
    for png in ("points.png", "spectrum.png", "radial.png", "pcf.png", "projections.png"):
        assert (out / png).read_bytes()[:8] == PNG
    assert "E_low<0.5" in stdout


def test_analyze_3d_baseline_and_bin_input(tmp_path, capsys):
    f = tmp_path / "h.bin"
    assert run(capsys, "generate", "-m", "halton", "-n", 200, "-d", 3, "-c", 3, "-o", f)[0] == 0
    out = tmp_path / "o3"
    rc, _, err = run(capsys, "analyze", "-i", f, "-o", out, "--subspace", "2,0", "--discrepancy", "GL2")
    assert rc == 0, err
    doc = json.loads((out / "metrics.json").read_text())
    assert doc["spectrum_2d"]["dims"] == [2, 0] and doc["radial_nd"]["method"] == "monte-carlo"
    assert set(doc["discrepancy"]) == {"sets", "GL2"}
    assert (out / "radial_nd.png").read_bytes()[:8] == PNG


def test_compare_table_and_plots(tmp_path, capsys):
    f = tmp_path / "w.npy"
    np.save(f, baselines.generate("white", 256, count=4, seed=9))
    out = tmp_path / "cmp"
    rc, stdout, err = run(
        capsys,
        "compare",
        "-i",
        f,
        "-i",
        "jitter",
        "ref-bnot",
        "-n",
        256,
        "-c",
        4,
        "-o",
        out,
        "--discrepancy",
        "CD,L2-star",
    )
    assert rc == 0, err
    table = (out / "compare.md").read_text()
    assert table.strip() == stdout.strip().split("\nwrote")[0].strip()
    rows = [ln for ln in table.splitlines() if ln.startswith("| ") and "label" not in ln]
    assert [r.split("|")[1].strip() for r in rows] == ["w", "jitter", "ref-bnot"]
    doc = json.loads((out / "compare.json").read_text())
    low = {r["label"]: r["E_low<0.5"] for r in doc["rows"]}
    assert low["ref-bnot"] < low["jitter"] < low["w"]
    assert all("relvar_disk" in r for r in doc["rows"])
    for png in ("radial.png", "pcf.png", "points.png"):
        assert (out / png).read_bytes()[:8] == PNG


@pytest.mark.parametrize(
    "args, code",
    [
        (["generate", "-x"], 2),
        (["generate", "-m", "white"], 2),  # a baseline needs -n
        (["generate", "-m", "white", "-n", "abc"], 2),
        (["analyze", "-o", "OUT"], 2),  # no input
        (["generate", "-m", "no-such-model", "-n", "5"], 1),
        (["generate", "-m", "jitter", "-n", "1000"], 1),
        (["generate", "-m", "white", "-n", "5", "-o", "x.unknown"], 1),
        (["analyze", "-i", "missing.npy", "-o", "OUT"], 1),
        (["analyze", "-i", "BAD", "-o", "OUT"], 1),
        (["analyze", "-i", "OK", "-o", "OUT", "--subspace", "0,7"], 1),
        (["compare", "-i", "ref-bnot", "-o", "OUT"], 1),  # ambiguous without -n
    ],
)
def test_errors_are_one_line(tmp_path, capsys, args, code):
    bad = tmp_path / "bad.txt"
    bad.write_text("0.1 0.2\n0.3\n")
    ok = tmp_path / "ok.npy"
    np.save(ok, np.random.default_rng(0).random((2, 20, 2)))
    names = {"BAD": str(bad), "OK": str(ok), "OUT": str(tmp_path / "o")}
    args = [names.get(a, a) for a in args]
    rc, _, err = run(capsys, *args)
    assert rc == code
    _one_line_error(err)


def test_cli_default_discrepancies_are_all_methods():
    from dpc import cli

    assert cli._DISC_DEFAULT.split(",") == list(analysis.DISCREPANCY_METHODS)


def test_module_and_console_script_entry_points(tmp_path):
    r = subprocess.run(
        [sys.executable, "-m", "dpc.cli", "generate", "-m", "nope", "-n", "3"], capture_output=True, text=True
    )
    assert r.returncode == 1 and r.stderr.startswith("dpc: error:")
    exe = shutil.which("dpc")
    if exe is None:
        pytest.skip("the dpc console script is not on PATH (package not pip-installed)")
    r = subprocess.run([exe, "--help"], capture_output=True, text=True)
    assert r.returncode == 0 and "generate" in r.stdout and "analyze" in r.stdout


def test_generate_from_stratified_input(tmp_path, capsys):
    f = tmp_path / "s.npy"
    rc, _, err = run(capsys, "generate", "-m", "bnot-2d", "--stratified", "-s", 2, "-o", f)
    assert rc == 0, err
    expect = dpc.load("bnot-2d", input="stratified").generate(2).astype(np.float64)
    np.testing.assert_array_equal(read_points(f)[0], expect)
    rc, _, err = run(capsys, "generate", "-m", "dither-32", "--stratified", "-o", f)
    assert rc == 1 and "grid" in err
    _one_line_error(err)
    rc, _, err = run(capsys, "generate", "-m", "jitter", "-n", 16, "--stratified")
    assert rc == 2 and "baselines" in err
    rc, _, err = run(capsys, "generate", "-m", "bnot-2d", "--uniform", "-o", f)
    assert rc == 0 and "uniform input" in err, err


def test_compare_with_stratified_model_inputs(tmp_path, capsys):
    out = tmp_path / "cmp"
    rc, _, err = run(
        capsys,
        "compare",
        "-i",
        "bnot-2d",
        "-i",
        "jitter",
        "-n",
        1024,
        "-c",
        2,
        "--stratified",
        "--no-integration",
        "--discrepancy",
        "none",
        "-o",
        out,
    )
    assert rc == 0, err
    rows = {r["label"]: r for r in json.loads((out / "compare.json").read_text())["rows"]}
    assert set(rows) == {"bnot-2d (stratified)", "jitter"}, rows.keys()


def test_option_names_are_the_same_in_every_command(tmp_path, capsys):
    """-m is --model in generate, mask and dither (the mask's source there); mask's old --mask
    still works but is not shown."""
    import matplotlib.image as mpimg

    for cmd in ("generate", "mask", "dither"):
        rc, out, _ = run(capsys, cmd, "--help")
        assert rc == 0 and "-m, --model" in out and "--mask " not in out and "--mask," not in out, out
        for flag in ("-s, --seed", "-o, --output"):
            assert flag in out, (cmd, flag)
    a, b = tmp_path / "a.npy", tmp_path / "b.npy"
    assert run(capsys, "mask", "-m", "white", "-n", 8, "-s", 2, "-o", a)[0] == 0
    assert run(capsys, "mask", "--mask", "white", "-n", 8, "-s", 2, "-o", b)[0] == 0
    assert run(capsys, "mask", "--model", "white", "-n", 8, "-s", 3, "-o", tmp_path / "c.npy")[0] == 0
    assert np.array_equal(np.load(a), np.load(b)) and not np.array_equal(np.load(a), np.load(tmp_path / "c.npy"))
    img = tmp_path / "in.png"
    mpimg.imsave(img, np.linspace(0, 1, 64).reshape(8, 8), cmap="gray")
    for flag in ("--model", "--mask"):
        assert run(capsys, "dither", img, flag, "white", "-n", 4, "-o", tmp_path / f"o{flag}.png")[0] == 0


def test_counts_are_singular_or_plural(tmp_path, capsys):
    rc, _, err = run(capsys, "generate", "-m", "white", "-n", 16, "-c", 1, "-o", tmp_path / "one.npy")
    assert rc == 0 and "wrote 1 set of 16" in err
    rc, out, _ = run(capsys, "analyze", "-i", "white", "-n", 64, "-c", 1, "--discrepancy", "none", "-o", tmp_path / "a")
    assert rc == 0 and "white: 1 set of 64" in out
    from dpc.analysis._common import count_of

    assert count_of(1) == "1 set" and count_of(2) == "2 sets" and count_of(0) == "0 sets"
