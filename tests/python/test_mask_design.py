"""Annealed masks (dpc.masks.design, also dpc.mask_design): libdpc's annealer (dpc_mask_design) against a
direct evaluation of its energy, the designs' quality against void-and-cluster and STBN, the bundled
files, and the mask sources that serve them."""

from __future__ import annotations

import hashlib
import math

import numpy as np
import pytest

from dpc import _core
from dpc import baselines as B
from dpc import mask_design as MD
from dpc import masks as M
from dpc.analysis import masks as AM
from dpc.analysis.dither import mask_quality
from dpc.cli import main
from dpc.errors import InvalidArgumentError, LimitError


def _exact_levels(a: np.ndarray) -> bool:
    return np.array_equal(np.sort(a.ravel()), (np.arange(a.size) + 0.5) / a.size)


def _direct_energy(ranks: np.ndarray) -> float:
    """The annealer's energy (dpc.mask_design's module doc, libdpc/src/mask/mask_design.c) from
    scratch with numpy FFTs: ranks (frames, n, n, channels) as _core.mask_design returns them."""
    t, n, _, c = ranks.shape
    frames = np.moveaxis(ranks, -1, 1).reshape(t * c, n, n).astype(np.float64)  # the annealer's frames
    s, sigma = n * n, 6.0 * n / 64
    f = np.arange(-(n // 2) + 1, n // 2 + 1)
    qy, qx = (a.ravel() for a in np.meshgrid(f, f, indexing="ij"))
    r2 = (qx * qx + qy * qy).astype(np.float64)
    keep = ((qy > 0) | ((qy == 0) & (qx > 0))) & (r2 <= 16 * sigma * sigma)
    qx, qy, w = qx[keep] % n, qy[keep] % n, np.exp(-0.5 * r2[keep] / sigma**2)
    spatial = 1.0 / (w.sum() * len(frames))

    def power(img):  # |DFT|^2 at the kept frequencies
        return np.abs(np.fft.fft2(img)[..., qy, qx]) ** 2

    levels = np.arange(1, 64) / 64
    thr = np.floor(levels * s + 0.5)
    kappa = spatial / (s * levels * (1 - levels) * len(levels))
    e = 0.5 * spatial * (w * power(frames)).sum() / (s * (s * s - 1) / 12.0)
    for th, k in zip(thr, kappa):
        e += k * (w * power((frames < th).astype(float))).sum()
    if c == 1 and t > 1:  # each pixel's sequence along time, k = 0 ... t/2
        kt = np.arange(t // 2 + 1)
        wt = np.exp(-0.5 * (kt / (0.125 * t)) ** 2) * np.where((kt > 0) & (2 * kt != t), 2.0, 1.0)
        wt[0] *= 2.0
        ktime = 2.0 / (wt.sum() * s * t * levels * (1 - levels) * len(levels))
        for th, k in zip(thr, ktime):
            seq = np.abs(np.fft.fft((frames < th) - th / s, axis=0)[: t // 2 + 1]) ** 2  # (k, n, n)
            e += k * (wt[:, None, None] * seq).sum()
    if c == 2:  # joint box patterns
        corners = np.floor(np.arange(1, 8) / 8 * s + 0.5)
        for i, a in enumerate(corners):
            for j, b in enumerate(corners):
                share = (i + 1) * (j + 1) / 64
                box = ((frames[0] < a) & (frames[1] < b)).astype(float)
                e += 0.1 / (w.sum() * s * share * (1 - share) * 49) * (w * power(box)).sum()
    return float(e)


@pytest.mark.parametrize("shape", [(16, 1, 1), (16, 4, 1), (16, 1, 2)], ids=["scalar", "spatiotemporal", "vector"])
def test_annealer_energy_matches_a_direct_evaluation(shape):
    """Incremental updates (prefix sums over levels, per pixel and per box row) must track the
    energy exactly: libdpc's start and end energies against a from-scratch evaluation of the
    void-and-cluster start (steps 0) and of the design."""
    n, t, c = shape
    start, s0 = _core.mask_design(n, t, c, 0, 5)
    out, s1 = _core.mask_design(n, t, c, 600, 5)
    assert s0["energy_start"] == s1["energy_start"] and s0["accepted"] == 0
    assert s1["accepted"] > 1000
    assert s1["energy_start"] == pytest.approx(_direct_energy(start), rel=1e-10)
    assert s1["energy_end"] == pytest.approx(_direct_energy(out), rel=1e-10)
    assert s1["energy_end"] < s1["energy_start"]
    assert all(np.array_equal(np.sort(out[f, ..., k].ravel()), np.arange(n * n)) for f in range(t) for k in range(c))


def test_design_is_the_same_on_every_machine():
    """Plain double arithmetic in a fixed order with libdpc's own exp, sin and cos: these digests
    were made on an AMD EPYC (AVX2) and must come out the same on every machine and compiler
    (tests/c/test_mask.cpp pins the same designs from C)."""
    digests = {
        (16, 1, 1): "0b87eb935f66b187",
        (16, 4, 1): "e0408d63e9bcc57b",
        (16, 1, 2): "b11da04b49d789c5",
    }
    for (n, t, c), digest in digests.items():
        ranks, _ = _core.mask_design(n, t, c, 600, 7)
        assert hashlib.sha256(ranks.astype("<u4").tobytes()).hexdigest()[:16] == digest, (n, t, c)


def test_annealer_rejects_bad_input():
    with pytest.raises(InvalidArgumentError):
        MD.anneal_mask(4)
    with pytest.raises(InvalidArgumentError):
        MD.anneal_mask(16, frames=0)
    with pytest.raises(InvalidArgumentError):
        MD.anneal_mask(16, seed=-1)
    with pytest.raises(LimitError, match="DPC_MAX_DESIGN_PIXELS"):
        MD.anneal_mask(2048)  # Python's limit on the work, before libdpc's
    with pytest.raises(InvalidArgumentError, match="8 .. 1024"):
        MD.anneal_mask(2048, max_pixels=math.inf)
    with pytest.raises(InvalidArgumentError, match="not both"):
        _core.mask_design(16, 4, 2, 600, 0)
    with pytest.raises(InvalidArgumentError, match="GiB"):
        MD.anneal_mask(512, frames=64, max_pixels=math.inf)  # refused before anything is allocated
    with pytest.raises(LimitError, match="steps_per_pixel"):
        MD.anneal_mask(16, steps_per_pixel=2**40)
    for bad in ("16", 16.5, None, True):
        with pytest.raises(InvalidArgumentError):
            MD.anneal_mask(bad)
    with pytest.raises(InvalidArgumentError, match="seed"):
        MD.anneal_mask(16, seed=2**64)


def test_progress_reports_and_an_exception_stops_the_design():
    calls = []
    m = MD.anneal_mask(16, seed=1, progress=lambda done, total: calls.append((done, total)))
    assert np.array_equal(m, MD.anneal_mask(16, seed=1))
    assert calls[0] == (0, 600 * 256) and calls[-1] == (600 * 256, 600 * 256) and len(calls) >= 3

    class Stop(Exception):
        pass

    def stop(done, total):
        if done > 0:
            raise Stop

    with pytest.raises(Stop):
        MD.anneal_mask(16, frames=4, seed=1, progress=stop)


def test_annealed_mask_at_least_as_good_as_void_and_cluster_at_48():
    """Designed on the spot (about 3 s each): mask and thresholded-pattern energies at or below
    void-and-cluster's at the same size and seeds (measured, 4 masks, docs/masks.md)."""
    ours = np.stack([MD.anneal_mask(48, seed=s) for s in range(2)])
    assert all(_exact_levels(m) for m in ours)
    q = mask_quality(ours)
    vc = mask_quality(np.stack([B.void_and_cluster(48, seed=s) for s in range(2)]))
    for key in ("mask_elow", "levels_elow_mean", "levels_elow_max"):
        assert q[key] <= vc[key], (key, q[key], vc[key])
    assert AM.seam_ratio(ours) < 1.3


def test_design_is_deterministic_per_seed():
    a, b, c = MD.anneal_mask(16, seed=3), MD.anneal_mask(16, seed=3), MD.anneal_mask(16, seed=4)
    assert np.array_equal(a, b) and not np.array_equal(a, c)


@pytest.mark.parametrize("size", [64, 128])
def test_bundled_masks_beat_void_and_cluster(size):
    seeds = MD.BUNDLED[(size, None, None)]
    ours = np.stack([M.mask("annealed", size=size, seed=s) for s in seeds])
    assert all(_exact_levels(m) for m in ours)
    vc = np.stack([B.void_and_cluster(size, seed=s) for s in seeds])
    # the report's low band; over one twice as wide (|q| <= 12) the designs beat void-and-cluster
    # clearly at 128 x 128 and only by about 1 % at 64 x 64 (docs/masks.md), so that is not tested
    q, v = mask_quality(ours), mask_quality(vc)
    for key in ("mask_elow", "levels_elow_mean", "levels_elow_max"):
        assert q[key] <= v[key], (key, q[key], v[key])
    assert AM.seam_ratio(ours) < 1.3


def test_bundled_file_is_what_anneal_mask_makes():
    """The files are anneal_mask's output, not edited: remake the cheapest one."""
    assert np.array_equal(M.mask("annealed", size=64, seed=0), MD.anneal_mask(64, seed=0))


def test_vector_design_is_blue_per_channel_and_jointly():
    """Two channels designed together: each channel far bluer than white noise, and the joint
    box patterns far bluer than two independent void-and-cluster masks' (about 3 s per mask)."""
    ours = np.stack([MD.anneal_mask(32, seed=s, channels=2) for s in range(2)])
    assert ours.shape == (2, 32, 32, 2)
    assert all(_exact_levels(m[..., c]) for m in ours for c in range(2))
    q = AM.vector_quality(ours)
    vc = AM.vector_quality(np.stack([B.vector_void_and_cluster(32, s) for s in range(2)]))
    # measured: 0.30 against 0.42 (the joint gain grows with the size: docs/masks.md at 64 x 64)
    assert q["joint_elow_mean"] < 0.85 * vc["joint_elow_mean"], (q["joint_elow_mean"], vc["joint_elow_mean"])
    assert q["mask_elow_max"] < 0.01 and q["levels_elow_mean_max"] < 0.2, q


def test_bundled_vector_masks_beat_the_vector_model_and_two_void_and_cluster_masks_jointly():
    seeds = MD.BUNDLED[(64, None, 2)]
    ours = AM.vector_quality(np.stack([M.mask("annealed", size=64, seed=s, channels=2) for s in seeds]))
    vc = AM.vector_quality(np.stack([B.vector_void_and_cluster(64, s) for s in seeds]))
    # mask-vector-64 (docs/masks.md, 8 masks): per channel 0.148 / 0.134, joint boxes 0.245
    assert ours["mask_elow_max"] < 0.148 and ours["levels_elow_mean_max"] < 0.134, ours
    assert ours["joint_elow_mean"] < min(0.245, 0.5 * vc["joint_elow_mean"]), (ours, vc)


def test_spatiotemporal_design_is_blue_in_time_and_stratified_per_pixel():
    vs = np.stack([MD.anneal_mask(16, frames=16, seed=s) for s in range(2)])  # about 1 s each
    assert vs.shape == (2, 16, 16, 16) and all(_exact_levels(f) for v in vs for f in v)
    q = AM.spatiotemporal_quality(vs)
    vc = AM.spatiotemporal_quality(np.stack([M.mask("void-and-cluster", size=16, frames=16, seed=s) for s in (0, 9)]))
    stbn = AM.spatiotemporal_quality(np.stack([B.stbn_scalar(16, 16, s) for s in range(2)]))
    # measured: temporal E_low 0.47 (independent frames 0.98, STBN 0.62); error after 16 frames
    # 0.030 (0.106, 0.039)
    assert q["temporal_elow"] < min(0.6 * vc["temporal_elow"], stbn["temporal_elow"]), (q, stbn)
    assert q["accumulated_rmse"][-1] < min(0.5 * vc["accumulated_rmse"][-1], stbn["accumulated_rmse"][-1])


def test_mask_sources_serve_annealed_masks(tmp_path, capsys):
    assert "annealed" in M.available()
    m = M.mask("annealed")
    assert m.shape == (64, 64) and np.array_equal(m, M.mask("annealed", size=64, seed=0))
    v = M.mask("annealed", size=16, channels=2)
    assert v.shape == (16, 16, 2) and not np.array_equal(v[..., 0], v[..., 1])
    with pytest.raises(InvalidArgumentError, match="not both"):
        M.mask("annealed", size=16, frames=4, channels=2)
    out = tmp_path / "a.npy"
    assert main(["mask", "-o", str(out)]) == 0  # annealed is the default
    assert np.array_equal(np.load(out), m)
    assert "from annealed" in capsys.readouterr().err


@pytest.mark.parametrize("frames, channels", [(1, 1), (3, 1), (1, 2)])
def test_c_example_designs_the_masks_python_serves(tmp_path, frames, channels):
    """docs/examples/design_mask.c, compiled against libdpc, prints the ranks dpc.mask_design gives."""
    import subprocess

    import c_example

    exe = c_example.build("design_mask", tmp_path, flags=("-Wall", "-Werror"))
    args = [str(exe), "16", "9", str(frames), str(channels)]
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    blocks = [b for b in out.split("# frame ") if b]
    ranks = np.array([[int(v) for line in b.splitlines()[1:] for v in line.split()] for b in blocks])
    want = MD.anneal_mask(16, frames if frames > 1 else None, 9, channels=channels if channels > 1 else None)
    want = np.rint(want * 256 - 0.5).astype(int)
    if channels == 2:
        want = np.moveaxis(want, -1, 0)
    assert np.array_equal(ranks.reshape(want.shape), want)
