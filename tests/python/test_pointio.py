"""Point-set files: round trips in every format, UTK compatibility, clear errors."""

import os

import numpy as np
import pytest

from dpc import pointio
from dpc.errors import InvalidArgumentError
from dpc.pointio import PointFileError, read_points, write_points

SHAPES = [(1, 9, 2), (4, 7, 2), (3, 5, 1), (2, 6, 5)]


@pytest.mark.parametrize("ext", [".npy", ".txt", ".dat", ".bin"])
@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_round_trip_is_exact(tmp_path, ext, shape, dtype):
    a = np.random.default_rng(sum(shape)).random(shape).astype(dtype)
    f = tmp_path / f"pts{ext}"
    write_points(f, a, bin_dtype="float32" if dtype == np.float32 else "float64")
    b = read_points(f, dims=shape[2] if ext == ".bin" and shape[1] < 8 else None)
    assert b.dtype == np.float64 and b.shape == shape
    np.testing.assert_array_equal(b, a.astype(np.float64))


def test_bin_dimension_and_type_are_detected(tmp_path):
    a = np.random.default_rng(0).random((3, 500, 3))
    for bt in ("float64", "float32"):
        f = tmp_path / f"p-{bt}.bin"
        write_points(f, a, bin_dtype=bt)
        np.testing.assert_array_equal(read_points(f), a.astype(bt).astype(np.float64))


def test_single_set_npy_is_two_dimensional(tmp_path):
    write_points(tmp_path / "one.npy", np.zeros((5, 2)))
    assert np.load(tmp_path / "one.npy").shape == (5, 2)
    write_points(tmp_path / "two.npy", np.zeros((2, 5, 2)))
    assert np.load(tmp_path / "two.npy").shape == (2, 5, 2)
    np.save(tmp_path / "flat.npy", np.linspace(0, 0.9, 10))  # (m,) = m 1-D points
    assert read_points(tmp_path / "flat.npy").shape == (1, 10, 1)


def test_reads_utk_text_with_hash_separators_and_commas(tmp_path):
    f = tmp_path / "utk.txt"
    f.write_text("# header comment\n0.1 0.2\n0.3, 0.4\n#\n0.5\t0.6\n\n0.7 0.8\n#\n")
    got = read_points(f)
    np.testing.assert_array_equal(got, [[[0.1, 0.2], [0.3, 0.4]], [[0.5, 0.6], [0.7, 0.8]]])


def test_text_written_with_hash_between_sets_like_utk(tmp_path):
    f = tmp_path / "s.txt"
    write_points(f, np.full((3, 2, 2), 0.25))
    lines = f.read_text().splitlines()
    assert lines == ["0.25 0.25", "0.25 0.25", "#", "0.25 0.25", "0.25 0.25", "#", "0.25 0.25", "0.25 0.25"]


def test_reads_the_authors_plain_text_files():
    from importlib import resources

    f = resources.files("dpc") / "data" / "deepsampling" / "pcf" / "pcf-step-d2-n1024" / "pointset-step-n1024-0001.txt"
    assert read_points(str(f)).shape == (1, 1024, 2)


def test_bin_layout_is_utk_v1(tmp_path):
    # Per set: little-endian uint32 count, then count * n doubles; no header.
    a = np.array([[[0.5, 0.25], [0.75, 0.125]]])
    f = tmp_path / "u.bin"
    write_points(f, a)
    raw = f.read_bytes()
    assert raw[:4] == (2).to_bytes(4, "little")
    np.testing.assert_array_equal(np.frombuffer(raw[4:], "<f8"), a.ravel())
    # A file written the way UTK writes it reads back.
    g = tmp_path / "w.bin"
    g.write_bytes(b"".join((3).to_bytes(4, "little") + np.full(6, v, "<f8").tobytes() for v in (0.3, 0.6)))
    np.testing.assert_array_equal(read_points(g, dims=2), np.stack([np.full((3, 2), 0.3), np.full((3, 2), 0.6)]))


def test_format_names_and_extensions(tmp_path):
    assert pointio.resolve_format("a.NPY") == "npy"
    # the names are UTK's: dat (its text format), bin (its binary format); 'utk' is ambiguous
    assert pointio.resolve_format("a.anything", "dat") == "dat"
    assert pointio.resolve_format("a.x", "txt") == "dat"
    assert pointio.resolve_format("a.x", "text") == "dat"
    assert pointio.resolve_format("a.CSV") == "csv"
    with pytest.raises(PointFileError, match="'dat'.*'bin'"):
        pointio.resolve_format("a.x", "utk")
    write_points(tmp_path / "x.data", np.zeros((2, 2)), "dat")
    assert read_points(tmp_path / "x.data", "text").shape == (1, 2, 2)
    with pytest.raises(PointFileError, match="extension"):
        pointio.resolve_format("a.xyz")
    with pytest.raises(PointFileError, match="unknown point format"):
        pointio.resolve_format("a.txt", "hdf5")


@pytest.mark.parametrize(
    "content, match",
    [
        ("0.1 0.2\n0.3\n", "columns"),
        ("0.1 0.2\n#\n0.1 0.2 0.3\n", "all sets must match"),
        ("0.1 zero\n", "set 0"),
        ("", "no points"),
        ("0.1 nan\n", "NaN"),
    ],
)
def test_bad_text_files(tmp_path, content, match):
    f = tmp_path / "bad.txt"
    f.write_text(content)
    with pytest.raises(PointFileError, match=match):
        read_points(f)


def test_bad_binary_and_npy_files(tmp_path):
    (tmp_path / "t.bin").write_bytes(b"\x05\x00\x00\x00" + b"\x00" * 7)  # truncated
    with pytest.raises(PointFileError, match="not a UTK .bin"):
        read_points(tmp_path / "t.bin")
    (tmp_path / "z.bin").write_bytes(b"")
    with pytest.raises(PointFileError):
        read_points(tmp_path / "z.bin")
    (tmp_path / "s.npy").write_bytes(b"not numpy")
    with pytest.raises(PointFileError, match="not a readable"):
        read_points(tmp_path / "s.npy")
    np.save(tmp_path / "str.npy", np.array(["a", "b"]))
    with pytest.raises(PointFileError, match="dtype"):
        read_points(tmp_path / "str.npy")
    np.save(tmp_path / "4d.npy", np.zeros((1, 2, 3, 4)))
    with pytest.raises(PointFileError, match="shape"):
        read_points(tmp_path / "4d.npy")
    (tmp_path / "bin.txt").write_bytes(b"\xff\xfe\x00\x81")
    with pytest.raises(PointFileError, match="not a text file"):
        read_points(tmp_path / "bin.txt")
    with pytest.raises(PointFileError, match="no such file"):
        read_points(tmp_path / "missing.npy")


def test_dims_check_and_write_errors(tmp_path):
    write_points(tmp_path / "a.npy", np.zeros((4, 3)))
    with pytest.raises(PointFileError, match="expected 2"):
        read_points(tmp_path / "a.npy", dims=2)
    with pytest.raises(PointFileError):
        write_points(tmp_path / "e.npy", np.zeros((0, 2)))
    with pytest.raises(PointFileError):
        write_points(tmp_path / "e.bin", np.zeros((2, 2)), bin_dtype="int8")
    assert issubclass(PointFileError, InvalidArgumentError)


@pytest.mark.parametrize("ext", [".npy", ".dat", ".csv", ".bin"])
@pytest.mark.parametrize("kind", ["fifo", "folder", "device"])
def test_non_regular_files_are_refused_at_once(tmp_path, ext, kind):
    """A FIFO (a plain read would block forever), a folder or a device is refused before any
    read, naming what it is."""
    path = tmp_path / f"p{ext}"
    if kind == "fifo":
        os.mkfifo(path)
        what = "FIFO"
    elif kind == "folder":
        path.mkdir()
        what = "folder"
    else:
        path.symlink_to("/dev/zero")  # endless zeros: a reader without the check never ends
        what = "device"
    with pytest.raises(PointFileError, match=f"is a {what}, not a regular file"):
        read_points(path)


def test_model_file_reader_refuses_non_regular_files(tmp_path):
    pytest.importorskip("onnx")
    from dpc.errors import ModelIOError
    from dpc.model_file import read_model

    os.mkfifo(tmp_path / "m.onnx")
    with pytest.raises(ModelIOError, match="FIFO"):
        read_model(tmp_path / "m.onnx")
    (tmp_path / "d.onnx").mkdir()
    with pytest.raises(ModelIOError, match="folder"):
        read_model(tmp_path / "d.onnx")
    with pytest.raises(ModelIOError, match="no such file"):
        read_model(tmp_path / "missing.onnx")
