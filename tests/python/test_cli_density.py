"""Blue noise that follows an image on the command line: `dpc stipple` (drawings and point files)
and `dpc generate --density`, their options and their one-line errors."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

import dpc
from dpc.density import as_density
from dpc.pointio import read_points
from test_cli import _one_line_error, run  # the CLI tests' helpers

N = 1000
MODEL = "bnot-2d-stratified"


def _save(path, grey, alpha=None):
    from PIL import Image

    a = np.asarray(grey, dtype=np.uint8)
    if alpha is not None:
        a = np.dstack([a, a, a, np.asarray(alpha, dtype=np.uint8)])
    Image.fromarray(a).save(path)
    return path


@pytest.fixture
def half(tmp_path):
    """64 x 32 pixels: the left half black, the right half white."""
    g = np.full((32, 64), 255, np.uint8)
    g[:, :32] = 0
    return _save(tmp_path / "half.png", g)


@pytest.fixture
def top(tmp_path):
    """32 x 32 pixels: the top half black, the bottom half white."""
    g = np.full((32, 32), 255, np.uint8)
    g[:16] = 0
    return _save(tmp_path / "top.png", g)


def _svg(path):
    root = ET.parse(path).getroot()
    return root, [c for c in root.iter() if c.tag.endswith("circle")]


# ---- dpc stipple -------------------------------------------------------------------------------


def test_stipple_png_puts_ink_where_the_image_is_dark(tmp_path, capsys, half):
    from PIL import Image

    out = tmp_path / "s.png"
    rc, _, err = run(capsys, "stipple", half, "-n", N, "-o", out)
    assert rc == 0, err
    assert f"{N} dots" in err
    with Image.open(out) as im:
        assert im.format == "PNG" and im.size == (1024, 512)  # the image's aspect, longer side 1024
        ink = 1.0 - np.asarray(im.convert("L"), dtype=np.float64) / 255.0
    assert ink[:, :500].mean() > 0.15
    assert ink[:, 530:].max() == 0.0  # no dot in the white half (a dot's radius away from it)
    grey = np.unique(ink[:, :500])
    assert len(grey) > 2  # antialiased edges, not just black and white


def test_stipple_invert_draws_white_dots_on_the_bright_half(tmp_path, capsys, half):
    from PIL import Image

    out = tmp_path / "s.png"
    rc, _, err = run(capsys, "stipple", half, "-n", N, "--invert", "-o", out)
    assert rc == 0, err
    with Image.open(out) as im:
        light = np.asarray(im.convert("L"), dtype=np.float64) / 255.0
    assert light[:, :490].max() == 0.0 and light[:, 524:].mean() > 0.15


def test_stipple_svg_has_one_circle_per_dot_and_states_its_size(tmp_path, capsys, half):
    out = tmp_path / "s.svg"
    rc, _, err = run(capsys, "stipple", half, "-n", N, "--width", 200, "--dot-size", 0.5, "-o", out)
    assert rc == 0, err
    root, circles = _svg(out)
    assert root.get("viewBox") == "0 0 200 100" and root.get("width") == "200"
    assert len(circles) == N
    r = {float(c.get("r")) for c in circles}
    # the densest area holds N / (mean / max density) = 2N dots per drawing: spacing sqrt(200 * 100 / 2N)
    assert len(r) == 1 and r.pop() == pytest.approx(0.5 * 0.5 * np.sqrt(200 * 100 / (2 * N)), rel=1e-3)
    cx = np.array([float(c.get("cx")) for c in circles])
    assert cx.max() < 100 and cx.min() >= 0
    rc, _, err = run(capsys, "stipple", half, "-n", N, "--invert", "-o", out)
    assert rc == 0, err
    root, circles = _svg(out)
    assert root.get("viewBox") == "0 0 1024 512"
    assert len(circles) == N and min(float(c.get("cx")) for c in circles) >= 512


def test_stipple_points_are_the_apis_and_follow_the_image(tmp_path, capsys, half, top):
    out = tmp_path / "s.npy"
    rc, _, err = run(capsys, "stipple", half, "-n", N, "-s", 7, "-o", out)
    assert rc == 0, err
    pts = np.load(out)
    assert pts.shape == (N, 2) and pts.dtype == np.float32
    assert pts[:, 0].max() < 0.5  # x to the right: all on the black left half
    want = dpc.load(MODEL).generate_density(as_density(half, invert=True), N, 7)
    np.testing.assert_array_equal(pts, want)
    # y runs down the image: the black top half holds them all
    rc, _, err = run(capsys, "stipple", top, "-n", N, "-o", out)
    assert rc == 0, err
    assert np.load(out)[:, 1].max() < 0.5
    rc, _, err = run(capsys, "stipple", half, "-n", N, "--invert", "-o", out)
    assert rc == 0, err
    assert np.load(out)[:, 0].min() >= 0.5


def test_stipple_csv_and_transparent_pixels(tmp_path, capsys):
    g = np.zeros((16, 16), np.uint8)  # all black, but the right half is transparent
    alpha = np.full((16, 16), 255, np.uint8)
    alpha[:, 8:] = 0
    img = _save(tmp_path / "rgba.png", g, alpha)
    out = tmp_path / "s.csv"
    rc, _, err = run(capsys, "stipple", img, "-n", 300, "-m", "bnot-2d", "-o", out)
    assert rc == 0, err
    pts = read_points(out)
    assert pts.shape == (1, 300, 2) and pts[0, :, 0].max() < 0.5


def test_stipple_gamma_and_grey_levels(tmp_path, capsys):
    g = np.zeros((16, 32), np.uint8)
    g[:, 16:] = 128  # black left, mid grey right
    img = _save(tmp_path / "grey.png", g)
    out = tmp_path / "s.npy"
    share = {}
    for gamma in (1.0, 3.0):
        rc, _, err = run(capsys, "stipple", img, "-n", 2000, "--gamma", gamma, "-o", out)
        assert rc == 0, err
        share[gamma] = (np.load(out)[:, 0] >= 0.5).mean()
    # grey 128 has ink 0.498: about a third of the dots at gamma 1, far fewer at gamma 3
    assert 0.28 < share[1.0] < 0.38 and share[3.0] < 0.15


# ---- dpc generate --density --------------------------------------------------------------------


def test_generate_density_follows_the_image(tmp_path, capsys, half):
    out = tmp_path / "g.npy"
    rc, _, err = run(capsys, "generate", "-m", MODEL, "--density", half, "-n", N, "-c", 2, "-s", 5, "-o", out)
    assert rc == 0, err
    assert "wrote 2 sets" in err and f"following {half}" in err
    sets = np.load(out)
    assert sets.shape == (2, N, 2) and sets.dtype == np.float32
    assert sets[..., 0].min() >= 0.5  # bright is dense: all on the white right half
    model = dpc.load(MODEL)
    for c in range(2):  # set c from seed + c, as without a density
        np.testing.assert_array_equal(sets[c], model.generate_density(as_density(half), N, 5 + c))
    rc, _, err = run(capsys, "generate", "-m", "bnot-2d", "--density", half, "-n", N, "--invert", "-o", out)
    assert rc == 0, err
    assert np.load(out)[:, 0].max() < 0.5
    rc, out_text, err = run(capsys, "generate", "-m", MODEL, "--density", half, "-n", 50, "--gamma", 2)
    assert rc == 0, err
    assert len(out_text.splitlines()) == 50


# ---- errors: one line, nothing written ---------------------------------------------------------


def _nothing_written(folder, before):
    assert sorted(p.name for p in folder.iterdir()) == before  # no output and no temporary


@pytest.mark.parametrize(
    "args, code, fragment",
    [
        (["stipple", "{d}/missing.png", "-o", "{d}/o.png"], 2, "does not exist"),
        (["stipple", "{d}/garbage.png", "-o", "{d}/o.png"], 1, "cannot read image"),
        (["stipple", "{d}/half.png", "-m", "bnot-3d", "-o", "{d}/o.png"], 1, "2-D model"),
        (["stipple", "{d}/half.png", "-m", "white", "-o", "{d}/o.svg"], 2, "baseline"),
        (["stipple", "{d}/half.png", "-m", "no-such-model", "-o", "{d}/o.npy"], 1, "dpc list"),
        (["stipple", "{d}/white.png", "-o", "{d}/o.png"], 1, "--invert"),
        (["stipple", "{d}/half.png", "-o", "{d}/o.jpg"], 2, ".svg"),
        (["stipple", "{d}/half.png", "--dot-size", "0", "-o", "{d}/o.png"], 2, "--dot-size"),
        (["stipple", "{d}/half.png", "--width", "100000", "-o", "{d}/o.png"], 1, "DPC_MAX_PIXELS"),
        (["stipple", "{d}/half.png", "-o", "{d}/missing/o.png"], 1, "does not exist"),
        (["generate", "-m", MODEL, "--invert", "-n", "8", "-o", "{d}/o.npy"], 2, "--density"),
        (["generate", "-m", MODEL, "--gamma", "2", "-n", "8", "-o", "{d}/o.npy"], 2, "--density"),
        (["generate", "-m", "white", "-n", "8", "--density", "{d}/half.png", "-o", "{d}/o.npy"], 2, "baseline"),
        (["generate", "-m", "bnot-3d", "--density", "{d}/half.png", "-o", "{d}/o.npy"], 1, "2-D model"),
        (["generate", "-m", MODEL, "--density", "{d}/half.png", "--balance", "2", "-o", "{d}/o.npy"], 2, "--balance"),
        (["generate", "-m", MODEL, "--density", "{d}/missing.png", "-o", "{d}/o.npy"], 2, "does not exist"),
        (["generate", "-m", MODEL, "--density", "{d}/half.png", "-n", "9", "-c", "9", "--max-output", "100"], 1, "GiB"),
    ],
    ids=lambda v: " ".join(v)[:70] if isinstance(v, list) else None,
)
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, half, args, code, fragment):
    (tmp_path / "garbage.png").write_bytes(b"not an image")
    _save(tmp_path / "white.png", np.full((8, 8), 255, np.uint8))
    before = sorted(p.name for p in tmp_path.iterdir())
    rc, _, err = run(capsys, *[a.format(d=tmp_path) for a in args])
    assert rc == code, err
    _one_line_error(err)
    assert fragment in err, err
    _nothing_written(tmp_path, before)


def test_a_failed_stipple_leaves_an_existing_output_as_it_was(tmp_path, capsys, half):
    out = tmp_path / "o.png"
    out.write_bytes(b"old")
    rc, _, err = run(capsys, "stipple", half, "-m", "bnot-3d", "-o", out)
    assert rc == 1
    _one_line_error(err)
    assert out.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["half.png", "o.png"]
