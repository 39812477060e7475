"""Limits before work: every mask, design and image whose cost grows with a user's number is
refused with LimitError (naming the limit and how to raise it) before anything is allocated,
and wrong types are InvalidArgumentError with the accepted range."""

from __future__ import annotations

import math
import struct
import tracemalloc
import zlib

import numpy as np
import pytest

import dpc
from dpc import baselines as B
from dpc import mask_design as MD
from dpc import masks as M
from dpc.analysis.dither import read_image
from dpc.errors import InvalidArgumentError, LimitError


def _peak_bytes(fn) -> int:
    """Peak Python/numpy allocation while fn() runs (and raises)."""
    tracemalloc.start()
    try:
        fn()
    except Exception:  # noqa: BLE001 - the caller checks the exception separately
        pass
    finally:
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    return peak


@pytest.mark.parametrize(
    "name, kw, env",
    [
        ("bayer", {"size": 2**20}, "DPC_MAX_PIXELS"),
        ("white", {"size": 40000}, "DPC_MAX_PIXELS"),
        ("white", {"size": 8, "frames": 10**8}, "DPC_MAX_PIXELS"),
        ("white", {"size": 2**16, "channels": 4}, "DPC_MAX_PIXELS"),
        ("void-and-cluster", {"size": 2048}, "DPC_MAX_DESIGN_PIXELS"),
        ("void-and-cluster", {"size": 64, "frames": 10**6}, "DPC_MAX_DESIGN_PIXELS"),
        ("stbn", {"size": 8, "frames": 10**6}, "DPC_MAX_DESIGN_PIXELS"),
        ("annealed", {"size": 2**40}, "DPC_MAX_DESIGN_PIXELS"),
        ("annealed", {"size": 10**12}, "DPC_MAX_DESIGN_PIXELS"),
        ("annealed", {"size": 64, "frames": 10**6}, "DPC_MAX_DESIGN_PIXELS"),
        ("mask-64", {"size": 10**6}, "DPC_MAX_PIXELS"),
    ],
)
def test_oversized_masks_are_refused_before_any_work(name, kw, env):
    with pytest.raises(LimitError, match=env) as e:
        M.mask(name, **kw)
    assert "max_pixels=" in str(e.value) and "--max-pixels" in str(e.value)
    assert _peak_bytes(lambda: M.mask(name, **kw)) < 1 << 20  # nothing of the mask's size


def test_baseline_functions_check_their_own_limits():
    with pytest.raises(LimitError):
        B.white_mask((40000, 40000))
    with pytest.raises(LimitError):
        B.bayer_mask(2**20)
    with pytest.raises(LimitError):
        B.void_and_cluster(2048)
    with pytest.raises(LimitError):
        B.vector_void_and_cluster(512)
    with pytest.raises(LimitError):
        B.stbn_scalar(8, 10**6)
    with pytest.raises(LimitError):
        MD.anneal_mask(512)
    with pytest.raises(LimitError, match="steps_per_pixel"):
        MD.anneal_mask(16, steps_per_pixel=10**9)


def test_the_limit_is_raised_by_argument_and_environment(monkeypatch):
    with pytest.raises(LimitError, match="limit of 16"):
        M.mask("white", size=8, max_pixels=16)
    assert M.mask("white", size=8, max_pixels=64).shape == (8, 8)
    monkeypatch.setenv("DPC_MAX_PIXELS", "16")
    with pytest.raises(LimitError, match="limit of 16"):
        M.mask("white", size=8)
    assert M.mask("white", size=8, max_pixels=math.inf).shape == (8, 8)
    monkeypatch.setenv("DPC_MAX_DESIGN_PIXELS", "63")
    with pytest.raises(LimitError, match="DPC_MAX_DESIGN_PIXELS"):
        M.mask("void-and-cluster", size=8)
    monkeypatch.setenv("DPC_MAX_DESIGN_PIXELS", "64")
    assert np.array_equal(M.mask("void-and-cluster", size=8), B.void_and_cluster(8, max_pixels=64))
    monkeypatch.setenv("DPC_MAX_PIXELS", "lots")
    with pytest.raises(InvalidArgumentError, match="DPC_MAX_PIXELS"):
        M.mask("white", size=8)


def test_bundled_masks_are_not_designs():
    """The bundled annealed 128 x 128 loads instantly: the design limit does not apply."""
    assert M.mask("annealed", size=128, seed=1, max_pixels=None).shape == (128, 128)


@pytest.mark.parametrize(
    "kw",
    [
        {"size": "64"},
        {"size": 64.5},
        {"size": None, "frames": 3},
        {"size": True},
        {"size": [64]},
        {"size": 64, "seed": -1},
        {"size": 64, "seed": "1"},
        {"size": 64, "seed": 1.5},
        {"size": 64, "max_pixels": 0},
        {"size": 64, "max_pixels": "big"},
    ],
)
def test_wrong_types_are_invalid_arguments_with_the_range(kw):
    with pytest.raises(InvalidArgumentError) as e:
        M.mask("white", **kw)
    assert ">=" in str(e.value) or "needs a size" in str(e.value)
    with pytest.raises(InvalidArgumentError):
        dpc.mask("annealed", **{**kw, "size": kw["size"] if kw["size"] is not None else "x"})


def _png_header_only(path, width: int, height: int) -> None:
    """A PNG that claims width x height but holds a few bytes: a decompression bomb's header."""

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b"")
    )


def test_images_are_checked_by_their_header_before_decoding(tmp_path):
    big = tmp_path / "big.png"
    _png_header_only(big, 40000, 40000)
    with pytest.raises(LimitError, match="40000 x 40000.*DPC_MAX_PIXELS"):
        read_image(big)
    assert _peak_bytes(lambda: read_image(big)) < 1 << 20
    with pytest.raises(LimitError, match="40000 x 40000"):
        M.read_mask(big)
    # a small image is read as before; a tight limit refuses it
    import matplotlib.image as mpimg

    small = tmp_path / "small.png"
    mpimg.imsave(small, np.linspace(0, 1, 48).reshape(6, 8), cmap="gray")
    assert read_image(small).shape[:2] == (6, 8)
    with pytest.raises(LimitError, match="limit of 47"):
        read_image(small, max_pixels=47)
    # over Pillow's own decompression-bomb bound, but allowed here: the header decides
    _png_header_only(big, 20000, 20000)
    with pytest.raises(InvalidArgumentError) as e:
        read_image(big, max_pixels=math.inf)  # gets past the header; the data is too short
    assert not isinstance(e.value, LimitError)


def test_dpc_mask_of_a_huge_size_is_a_limit_error():
    """dpc.mask's default source is annealed, as dpc mask's: 2^40 per side is refused before any
    work, not a TypeError from the binding."""
    with pytest.raises(LimitError, match="1099511627776 x 1099511627776"):
        dpc.mask(size=2**40)
    assert np.array_equal(dpc.mask(), M.mask("annealed", size=64, seed=0))
