"""Limits before work on dpc.Sampler: lookups evaluate their broadcast in chunks (memory beyond
the output stays O(chunk) however the arguments broadcast), refuse an output beyond max_bytes
with a LimitError before any work, and wrong types are InvalidArgumentErrors naming what is
accepted."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

import dpc
from dpc import _sampler


@pytest.fixture(scope="module")
def sampler():
    return dpc.Sampler("bnot-2d", samples_per_pixel=16, dimensions=8)


def _one_by_one(s, x, y, index, dimension, width):
    """Every lookup through the binding on its own (the unchunked reference)."""
    b = np.broadcast_arrays(*(np.asarray(v).astype(np.uint32) for v in (x, y, index, dimension)))
    flat = [np.ascontiguousarray(a.ravel()) for a in b]
    return s._h.get(*flat, width).reshape(b[0].shape + ((2,) if width == 2 else ()))


@pytest.mark.parametrize("width", [1, 2])
def test_chunked_lookups_are_the_lookups_bit_for_bit(sampler, monkeypatch, width):
    monkeypatch.setattr(_sampler, "LOOKUP_CHUNK", 1000)  # many chunks, one ending mid-row
    x, y = np.arange(-70, 67)[None, None, :], np.arange(45)[None, :, None]
    index, dims = 5, np.arange(3)[:, None, None]
    got = sampler.get_2d(x, y, index, dims) if width == 2 else sampler.get_1d(x, y, index, dims)
    assert got.shape == (3, 45, 137) + ((2,) if width == 2 else ())
    np.testing.assert_array_equal(got, _one_by_one(sampler, x % (1 << 32), y, index, dims, width))
    assert sampler.get_1d(3, 4, 5, 6).shape == ()
    assert sampler.get_2d(np.zeros((0, 3), int), 1, 1, 1).shape == (0, 3, 2)


def test_a_broadcast_lookup_holds_little_beyond_its_output(sampler):
    x, y = np.arange(4096)[None, :], np.arange(2048)[:, None]
    tracemalloc.start()
    try:
        out = sampler.get_2d(x, y, 0, 1)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert out.nbytes == 4096 * 2048 * 2 * 4
    # broadcast to full size first, four uint32 arguments alone would add out.nbytes
    assert peak < out.nbytes + 8 * 2**20, (peak, out.nbytes)


def test_an_output_beyond_the_limit_is_a_limit_error_before_work(sampler, monkeypatch):
    big = np.arange(1 << 20)
    with pytest.raises(dpc.LimitError, match=r"max_bytes=.*DPC_MAX_OUTPUT_BYTES"):
        sampler.get_2d(big[:, None], big[None, :], 0, 0)  # 8 TiB
    with pytest.raises(dpc.LimitError, match="limit of"):
        sampler.get_1d(np.arange(1000), 0, 0, 0, max_bytes=3999)
    assert sampler.get_1d(np.arange(1000), 0, 0, 0, max_bytes=4000).shape == (1000,)
    monkeypatch.setenv("DPC_MAX_OUTPUT_BYTES", "1K")
    with pytest.raises(dpc.LimitError):
        sampler.get_2d(np.arange(200), 0, 0, 0)


def test_arguments_that_do_not_broadcast_are_invalid(sampler):
    with pytest.raises(dpc.InvalidArgumentError, match="broadcast"):
        sampler.get_2d(np.arange(3), np.arange(4), 0, 0)
    with pytest.raises(dpc.InvalidArgumentError, match="integers"):
        sampler.get_2d(0.5, 0, 0, 0)


@pytest.mark.parametrize("models", [None, 3, 2.5, {"bnot-2d": 1}, object()])
def test_wrong_model_types_are_invalid_arguments_naming_what_is_accepted(models):
    with pytest.raises(dpc.InvalidArgumentError, match=r"dpc\.Model.*str or os\.PathLike") as e:
        dpc.Sampler(models)
    assert isinstance(e.value, ValueError)


def test_wrong_types_inside_the_model_list_are_invalid_arguments():
    for bad in ([None], ["bnot-2d", 7]):
        with pytest.raises(dpc.InvalidArgumentError, match="bundled name"):
            dpc.Sampler(bad)
    with pytest.raises(dpc.InvalidArgumentError, match="at least one"):
        dpc.Sampler([])
    with pytest.raises(dpc.InvalidArgumentError, match="samples_per_pixel"):
        dpc.Sampler("bnot-2d", samples_per_pixel=None)
