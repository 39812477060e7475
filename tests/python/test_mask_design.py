"""Annealed masks (dpc.mask_design, issue 13): the C++ annealer's bookkeeping against a direct
evaluation of its energy, the designs' quality against void-and-cluster and STBN, the bundled
files, and the mask sources that serve them."""

from __future__ import annotations

import numpy as np
import pytest

from dpc import _mask_anneal
from dpc import baselines as B
from dpc import mask_design as MD
from dpc import masks as M
from dpc.analysis import masks as AM
from dpc.analysis.dither import mask_quality
from dpc.cli import main
from dpc.errors import InvalidArgumentError


def _exact_levels(a: np.ndarray) -> bool:
    return np.array_equal(np.sort(a.ravel()), (np.arange(a.size) + 0.5) / a.size)


def _direct_energy(
    ranks, qx, qy, w_mask, w_level, thresholds, kappa, w_time, kappa_time, joint_thresholds, joint_kappa, w_joint
) -> float:
    """The annealer's energy (bindings/python/mask_anneal.cpp, header) evaluated from scratch."""
    t, n, _ = ranks.shape
    ys, xs = np.mgrid[0:n, 0:n]
    e = 0.0
    for f in range(t):
        for i in range(len(qx)):
            ph = np.exp(-2j * np.pi * (qx[i] * xs + qy[i] * ys) / n)
            e += w_mask[i] * abs((ranks[f] * ph).sum()) ** 2
            for g in range(len(w_level)):
                for lv, th in enumerate(thresholds):
                    e += w_level[g, i] * kappa[g, lv] * abs(((ranks[f] < th) * ph).sum()) ** 2
    for i in range(len(w_joint)):  # box patterns of a 2-channel mask
        ph = np.exp(-2j * np.pi * (qx[i] * xs + qy[i] * ys) / n)
        for a, ta in enumerate(joint_thresholds):
            for b, tb in enumerate(joint_thresholds):
                box = (ranks[0] < ta) & (ranks[1] < tb)
                e += w_joint[i] * joint_kappa[a, b] * abs((box * ph).sum()) ** 2
    for k in range(len(w_time)):
        ph = np.exp(-2j * np.pi * k * np.arange(t) / t)[:, None, None]
        for lv, th in enumerate(thresholds):
            c = ((ranks < th) - th / (n * n)) * ph
            e += w_time[k] * kappa_time[lv] * (np.abs(c.sum(axis=0)) ** 2).sum()
    return float(e)


@pytest.mark.parametrize("kind", ["scalar", "spatiotemporal", "vector"])
def test_annealer_energy_matches_a_direct_evaluation(kind):
    """Incremental updates (prefix sums over levels, per group, per pixel and per box row) must
    track the energy exactly: compare the start and end energies with a from-scratch evaluation."""
    rng = np.random.default_rng(len(kind))
    frames = {"scalar": 1, "spatiotemporal": 4, "vector": 2}[kind]
    n = 8
    ranks = np.stack([rng.permutation(n * n).reshape(n, n) for _ in range(frames)]).astype(np.int32)
    terms = dict(
        qx=np.array([1, 0, 1, 2, -1, 3], np.int32),
        qy=np.array([0, 1, 1, 1, 2, 0], np.int32),
        w_mask=rng.random(6),
        w_level=rng.random((2, 6)),
        thresholds=np.array([8, 16, 32, 48, 56], np.int32),
        kappa=rng.random((2, 5)),
        w_time=rng.random(3) if kind == "spatiotemporal" else np.zeros(0),
        kappa_time=rng.random(5) if kind == "spatiotemporal" else np.zeros(0),
        joint_thresholds=np.array([16, 32, 48], np.int32) if kind == "vector" else np.zeros(0, np.int32),
        joint_kappa=3 * rng.random((3, 3)) if kind == "vector" else np.zeros((0, 0)),
        w_joint=rng.random(6) if kind == "vector" else np.zeros(0),
    )
    terms["kappa"][0, 1] = 0.0  # a level outside a group
    out, accepted, e0, e1 = _mask_anneal.anneal(
        ranks, **terms, steps=4000, reach=2, rank_reach=3, t_start=0.3, t_end=1e-3, seed=1
    )
    assert accepted > 100
    assert e0 == pytest.approx(_direct_energy(ranks, **terms), rel=1e-10)
    assert e1 == pytest.approx(_direct_energy(out, **terms), rel=1e-10)
    assert e1 < 0.2 * e0
    assert all(np.array_equal(np.sort(f.ravel()), np.arange(n * n)) for f in out)


def test_annealer_rejects_bad_input():
    terms = MD.energy_terms(8, 1)
    bad = np.zeros((1, 8, 8), np.int32)  # not a permutation
    with pytest.raises(ValueError, match="permutation"):
        _mask_anneal.anneal(bad, **terms, steps=1, reach=1, rank_reach=1, t_start=0, t_end=0, seed=0)
    with pytest.raises(InvalidArgumentError):
        MD.anneal_mask(4)
    with pytest.raises(InvalidArgumentError):
        MD.anneal_mask(16, frames=0)
    with pytest.raises(InvalidArgumentError):
        MD.anneal_mask(16, seed=-1)
    with pytest.raises(InvalidArgumentError, match="GiB"):
        MD.anneal_mask(512, frames=64)  # refused before anything is allocated


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
