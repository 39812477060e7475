"""Blue-noise threshold masks: the baselines (void-and-cluster, STBN, white, Bayer),
the quality measures of dpc.analysis.masks, dpc.masks.mask for models and baselines, the file
formats, and the `dpc mask` / `dpc dither` commands."""

from __future__ import annotations

import os
import struct
import zlib

import numpy as np
import pytest

import dpc
from dpc import baselines as B
from dpc import masks as M
from dpc.analysis import masks as AM
from dpc.analysis.dither import mask_quality, rank_normalise
from dpc.cli import main
from dpc.errors import InvalidArgumentError


def _exact_levels(a: np.ndarray) -> bool:
    """Every value (k + ½)/S, k = 0 … S − 1, exactly once."""
    return np.array_equal(np.sort(a.ravel()), (np.arange(a.size) + 0.5) / a.size)


# ---------------------------------------------------------------- void-and-cluster
def test_void_and_cluster_reproduces_ulichney_quality():
    # 32 x 32, sigma 1.5: Ulichney's construction measured mask E_low 0.0019 and thresholded-pattern mean 0.050
    # over 8 masks; white noise scores 1.
    ms = np.stack([B.void_and_cluster(32, seed=s) for s in range(4)])
    q = mask_quality(ms)
    assert q["mask_elow"] < 0.004, q
    assert q["levels_elow_mean"] < 0.07, q
    w = mask_quality(np.stack([B.white_mask((32, 32), seed=s) for s in range(4)]))
    assert w["mask_elow"] > 0.7 and w["levels_elow_mean"] > 0.7, w
    for m in ms:
        assert _exact_levels(m)


def test_void_and_cluster_is_deterministic_and_seeded():
    a, b, c = B.void_and_cluster(16, 3), B.void_and_cluster(16, 3), B.void_and_cluster(16, 4)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert _exact_levels(a) and a.shape == (16, 16)


def test_void_and_cluster_rejects_bad_input():
    for bad in (1, 0, -4, 2.5, "x"):
        with pytest.raises(InvalidArgumentError):
            B.void_and_cluster(bad)
    with pytest.raises(InvalidArgumentError):
        B.void_and_cluster(16, seed=-1)
    with pytest.raises(InvalidArgumentError):
        B.void_and_cluster(16, sigma=0)
    with pytest.raises(InvalidArgumentError):
        B.void_and_cluster(16, density=0.7)


def test_bayer_and_white_masks():
    assert _exact_levels(B.bayer_mask(8)) and _exact_levels(B.white_mask((8, 8), 1))
    v = B.white_mask((8, 8, 2), 1)
    assert v.shape == (8, 8, 2) and all(_exact_levels(v[..., c]) for c in range(2))
    with pytest.raises(InvalidArgumentError):
        B.bayer_mask(12)


# ---------------------------------------------------------------- vector and spatiotemporal
def test_two_independent_void_and_cluster_masks_are_blue_per_channel_not_jointly():
    v = B.vector_void_and_cluster(32, seed=0)
    q = AM.vector_quality(v)
    assert q["mask_elow_max"] < 0.01 and q["levels_elow_mean_max"] < 0.1, q
    # the joint box patterns are products of two unrelated blue patterns: far from blue
    assert q["joint_elow_mean"] > 0.3, q
    w = AM.vector_quality(B.white_mask((32, 32, 2), 0))
    assert w["joint_elow_mean"] > 0.7


def test_stbn_frames_blue_and_time_well_spread():
    st = B.stbn_scalar(16, 8, seed=0)
    assert st.shape == (8, 16, 16) and all(_exact_levels(f) for f in st)
    q = AM.spatiotemporal_quality(st)
    white = AM.spatiotemporal_quality(np.stack([B.white_mask((16, 16), s) for s in range(8)]))
    indep = AM.spatiotemporal_quality(np.stack([B.void_and_cluster(16, 100 + s) for s in range(8)]))
    assert q["mask_elow_mean"] < 0.5 * white["mask_elow_mean"], (q, white)
    # accumulated 1-spp estimates over all 8 frames: well below white noise and independent masks
    assert q["accumulated_rmse"][-1] < 0.6 * white["accumulated_rmse"][-1], (q, white)
    assert q["accumulated_rmse"][-1] < 0.6 * indep["accumulated_rmse"][-1], (q, indep)


def test_temporal_spectrum_of_white_noise_is_flat():
    rng = np.random.default_rng(0)
    ts = AM.temporal_spectrum(rng.random((16, 32, 32)))
    assert abs(ts[1:].mean() - 1.0) < 0.05


# ---------------------------------------------------------------- tiling
def test_seam_ratio_tells_toroidal_masks_from_cropped_ones():
    vc = np.stack([B.void_and_cluster(32, seed=s) for s in range(6)])
    crops = np.stack([B.void_and_cluster(64, seed=s)[:32, :32] for s in range(3)])
    assert AM.seam_ratio(vc) < 1.25
    assert AM.seam_ratio(crops) > 1.5


# ---------------------------------------------------------------- dpc.mask and files
def test_mask_from_baselines_and_bad_input():
    assert M.mask("void-and-cluster", size=16, seed=2).shape == (16, 16)
    assert M.mask("void-and-cluster", size=16, channels=2).shape == (16, 16, 2)
    assert M.mask("void-and-cluster", size=16, frames=3).shape == (3, 16, 16)
    assert M.mask("stbn", size=8, frames=4).shape == (4, 8, 8)
    assert M.mask("white", size=8, frames=2).shape == (2, 8, 8)
    for kwargs in ({"size": None}, {"size": 1}, {"size": 16, "seed": -1}, {"size": 16, "channels": 2, "frames": 2}):
        with pytest.raises(InvalidArgumentError):
            M.mask("void-and-cluster", **kwargs)
    with pytest.raises(InvalidArgumentError):
        M.mask("stbn", size=8)
    with pytest.raises(InvalidArgumentError):
        M.mask("no-such-mask", size=8)
    with pytest.raises(InvalidArgumentError):
        M.mask("bnot-2d")  # not gridded


def test_mask_from_a_gridded_model_at_its_size_and_another():
    from pathlib import Path

    grid = Path(__file__).resolve().parents[1] / "data" / "model_grid_3to1.onnx"
    model = dpc.load(grid)
    a = M.mask(str(grid), seed=1)
    assert a.shape == (model.grid_shape[1], model.grid_shape[0]) and _exact_levels(a)
    assert np.array_equal(a, rank_normalise(model.generate(seed=1)[:, 2].reshape(a.shape)))
    b = M.mask(str(grid), seed=1, size=2 * a.shape[0])
    assert b.shape == (2 * a.shape[0],) * 2 and _exact_levels(b)
    with pytest.raises(InvalidArgumentError):
        M.mask(str(grid), frames=4)


@pytest.mark.parametrize("shape", [(32, 32), (32, 32, 2), (4, 16, 16)])
def test_files_read_back_exactly(tmp_path, shape):
    st = len(shape) == 3 and shape[2] != 2
    if st:
        a = np.stack([B.white_mask(shape[1:], s) for s in range(shape[0])])
    else:
        a = B.white_mask(shape, 5)
    for ext in (".npy", ".exr", ".png"):
        for bits in (8, 16) if ext == ".png" else (16,):
            paths = M.write_mask(tmp_path / f"m{bits}{ext}", a, bits=bits, spatiotemporal=st)
            assert len(paths) == (shape[0] if st and ext != ".npy" else 1)
            r = M.read_mask(paths if len(paths) > 1 else paths[0])
            assert r.shape == a.shape
            if ext == ".png":
                # the stored codes are exactly floor(v * 2^bits); 16 bits keep every rank of a
                # mask of up to 65,536 pixels, so rank normalisation recovers the mask exactly
                assert np.array_equal(M.quantise(r, bits), M.quantise(a, bits))
                if bits == 16:
                    back = M.rank_normalise(r, M.kind_of(a, st))
                    assert np.array_equal(back, a)
                else:
                    # 8 bits: every code is taken by exactly its share of each threshold map
                    codes = M.quantise(r, 8)
                    maps = [codes] if not st else list(codes)
                    if codes.ndim == 3 and not st:
                        maps = [codes[..., c] for c in range(codes.shape[2])]
                    for cm in maps:
                        counts = np.bincount(cm.ravel(), minlength=256)
                        assert np.all(counts == cm.size // 256)
            else:
                assert np.array_equal(r, a)


def test_write_mask_rejects_bad_input(tmp_path):
    a = B.white_mask((8, 8), 0)
    with pytest.raises(InvalidArgumentError):
        M.write_mask(tmp_path / "m.jpg", a)
    with pytest.raises(InvalidArgumentError):
        M.write_mask(tmp_path / "m.png", a, bits=12)
    with pytest.raises(InvalidArgumentError):
        M.write_mask(tmp_path / "m.npy", a + 1.0)
    with pytest.raises(InvalidArgumentError):
        M.read_mask(tmp_path / "missing.png")


# ---------------------------------------------------------------- CLI
def test_mask_command_writes_and_reports(tmp_path, capsys):
    out = tmp_path / "vc.png"
    rc = main(["mask", "-m", "void-and-cluster", "-n", "32", "-s", "1", "-o", str(out)])
    err = capsys.readouterr().err
    assert rc == 0, err
    assert "mask E_low" in err
    assert np.array_equal(M.rank_normalise(M.read_mask(out), "scalar"), B.void_and_cluster(32, 1))
    rc = main(["mask", "-m", "stbn", "-n", "8", "--frames", "3", "-o", str(tmp_path / "st.npy")])
    assert rc == 0 and np.load(tmp_path / "st.npy").shape == (3, 8, 8)
    rc = main(["mask", "-m", "stbn", "-n", "8", "--frames", "3", "-o", str(tmp_path / "st.png")])
    assert rc == 0 and all((tmp_path / f"st_{k:03d}.png").is_file() for k in range(3))
    assert main(["mask", "-m", "void-and-cluster", "-n", "8", "-o", str(tmp_path / "x.jpg")]) == 2
    assert main(["mask", "-m", "void-and-cluster", "-o", str(tmp_path / "x.npy")]) == 1
    assert "needs a size" in capsys.readouterr().err


def test_dither_command_with_a_baseline_mask(tmp_path, capsys):
    import matplotlib.image as mpimg

    ramp = np.tile(np.linspace(0, 1, 64), (32, 1))
    src = tmp_path / "ramp.png"
    mpimg.imsave(src, ramp, cmap="gray", vmin=0, vmax=1)
    out = tmp_path / "out.png"
    rc = main(["dither", str(src), "-m", "void-and-cluster", "-n", "16", "-o", str(out)])
    assert rc == 0, capsys.readouterr().err
    white = mpimg.imread(out)[..., 0] > 0.5
    assert abs(white.mean() - ramp.mean()) < 0.05
    rc = main(["dither", str(src), "-m", "stbn", "-n", "8", "--frame", "2", "-o", str(out)])
    assert rc == 0


# ---------------------------------------------------------------- atomic writes
def _snapshot(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _disk_full(monkeypatch):
    """fsync fails, as on a full disk, for every writer that goes through dpc._atomic."""
    import errno

    from dpc import _atomic

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(_atomic.os, "fsync", full)


@pytest.mark.parametrize(
    "name, shape",
    [("m.npy", (16, 16)), ("m.png", (16, 16)), ("m.exr", (16, 16, 2)), ("st.png", (3, 8, 8)), ("st.exr", (3, 8, 8))],
)
def test_write_mask_is_atomic(tmp_path, monkeypatch, name, shape):
    """A failing write_mask leaves every existing file as it was and adds nothing (no temporary,
    no first frame of a spatiotemporal mask); then the same call succeeds."""
    st = len(shape) == 3 and shape[2] != 2
    a = np.stack([B.white_mask(shape[1:], s) for s in range(shape[0])]) if st else B.white_mask(shape, 3)
    target = tmp_path / name
    old = {target.name: b"old mask"}
    if st:  # an old frame 1 only: frames 0 and 2 would be new files
        old = {M.frame_paths(target, shape[0])[1].name: b"old frame"}
    for k, v in old.items():
        (tmp_path / k).write_bytes(v)
    with monkeypatch.context() as mp:
        _disk_full(mp)
        with pytest.raises(OSError, match="No space"):
            M.write_mask(target, a, spatiotemporal=st)
    assert _snapshot(tmp_path) == old
    paths = M.write_mask(target, a, spatiotemporal=st)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in paths)
    back = M.read_mask(paths if len(paths) > 1 else paths[0])
    assert np.array_equal(M.rank_normalise(back, M.kind_of(a, st)), a)


@pytest.mark.parametrize("mask_ext", [".npy", ".png"])
def test_dither_command_is_atomic(tmp_path, monkeypatch, capsys, mask_ext):
    """dpc dither writes the image and --mask-output together, or neither."""
    import matplotlib.image as mpimg

    ramp = np.tile(np.linspace(0, 1, 32), (16, 1))
    src = tmp_path / "ramp.png"
    mpimg.imsave(src, ramp, cmap="gray", vmin=0, vmax=1)
    out, mask = tmp_path / "out.png", tmp_path / f"mask{mask_ext}"
    out.write_bytes(b"old image")
    args = ["dither", str(src), "-m", "void-and-cluster", "-n", "8", "-o", str(out), "--mask-output", str(mask)]
    before = _snapshot(tmp_path)
    with monkeypatch.context() as mp:
        _disk_full(mp)
        assert main(args) == 1
    assert "No space" in capsys.readouterr().err
    assert _snapshot(tmp_path) == before  # the old image kept, no mask file, no temporary
    assert main(args) == 0, capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([src.name, out.name, mask.name])
    assert mpimg.imread(out).shape[:2] == ramp.shape
    if mask_ext == ".npy":
        assert np.array_equal(np.load(mask), B.void_and_cluster(8, 0))


# ---------------------------------------------------------------- C: baking a mask at load time
def test_c_example_bakes_the_same_ranks_as_dpc_mask(tmp_path):
    import subprocess

    import c_example

    exe = c_example.build("bake_mask", tmp_path)
    grid = c_example.ROOT / "tests" / "data" / "model_grid_3to1.onnx"
    out = subprocess.run([str(exe), str(grid), "5"], check=True, capture_output=True, text=True).stdout
    ranks = np.array([int(v) for line in out.splitlines() if not line.startswith("#") for v in line.split()])
    a = M.mask(str(grid), seed=5)
    assert np.array_equal(ranks.reshape(a.shape), np.round(a * a.size - 0.5).astype(int))


# ---------------------------------------------------------------- the bundled mask models
def _bundled(name: str) -> None:
    if name not in dpc.available_models():
        pytest.skip(f"{name} is not bundled")


def test_mask_64_is_a_tileable_rank_normalised_blue_noise_mask():
    _bundled("mask-64")
    ms = np.stack([M.mask("mask-64", seed=s) for s in range(4)])
    assert ms.shape == (4, 64, 64) and all(_exact_levels(m) for m in ms)
    q = mask_quality(ms)
    # measured (docs/masks.md, 8 masks): 0.075 / 0.072; white noise 1.0, dither-32 (at 32) 0.18 / 0.17
    assert q["mask_elow"] < 0.12 and q["levels_elow_mean"] < 0.12, q
    assert AM.seam_ratio(ms) < 1.3


@pytest.mark.xfail(
    strict=True,
    reason="the mask models' goal is not reached: mask-64 at 64 x 64 has "
    "mask / thresholded low-band energies ~0.07 / 0.07 against void-and-cluster's "
    "0.00015 / 0.025 (docs/masks.md). Strict: remove this marker when a model meets it.",
)
def test_mask_64_at_least_as_good_as_void_and_cluster():
    _bundled("mask-64")
    ours = mask_quality(np.stack([M.mask("mask-64", seed=s) for s in range(4)]))
    vc = mask_quality(np.stack([B.void_and_cluster(64, seed=s) for s in range(4)]))
    for key in ("mask_elow", "levels_elow_mean", "levels_elow_max"):
        assert ours[key] <= vc[key], (key, ours[key], vc[key])


def test_mask_vector_64_is_blue_per_channel_and_jointly_bluer_than_two_void_and_cluster_masks():
    _bundled("mask-vector-64")
    ms = np.stack([M.mask("mask-vector-64", seed=s) for s in range(2)])  # ~2 s each
    assert ms.shape == (2, 64, 64, 2)
    assert all(_exact_levels(m[..., c]) for m in ms for c in range(2))
    q = AM.vector_quality(ms)
    vc = AM.vector_quality(np.stack([B.vector_void_and_cluster(64, s) for s in range(2)]))
    # measured (docs/masks.md, 8 masks): per channel 0.146 / 0.133 (white 1.07 / 1.03); joint
    # boxes 0.247 against two independent void-and-cluster masks' 0.446
    assert q["mask_elow_max"] < 0.25 and q["levels_elow_mean_max"] < 0.25, q
    assert q["joint_elow_mean"] < vc["joint_elow_mean"], (q["joint_elow_mean"], vc["joint_elow_mean"])
    assert AM.seam_ratio(ms[..., 0]) < 1.3 and AM.seam_ratio(ms[..., 1]) < 1.3


def test_mask_st_32x16_frames_are_rank_normalised_and_blue():
    _bundled("mask-st-32x16")
    vs = np.stack([M.mask("mask-st-32x16", seed=s) for s in range(2)])  # ~3 s each
    assert vs.shape == (2, 16, 32, 32) and all(_exact_levels(f) for v in vs for f in v)
    q = AM.spatiotemporal_quality(vs)
    # measured (4 volumes): frames 0.375 / 0.362 (white noise 1.0)
    assert q["mask_elow_mean"] < 0.6 and q["levels_elow_mean"] < 0.6, q
    assert AM.seam_ratio(vs[0]) < 1.3


@pytest.mark.xfail(
    strict=True,
    reason="the mask models' goal is not reached: mask-st-32x16's frames "
    "(0.37 / 0.36) and accumulated 16-frame error (0.103, white noise 0.105) are far "
    "from STBN's (0.022 / 0.146, 0.039; docs/masks.md). Strict: remove when met.",
)
def test_mask_st_32x16_at_least_as_good_as_stbn():
    _bundled("mask-st-32x16")
    ours = AM.spatiotemporal_quality(np.stack([M.mask("mask-st-32x16", seed=s) for s in range(2)]))
    stbn = AM.spatiotemporal_quality(np.stack([B.stbn_scalar(32, 16, s) for s in range(2)]))
    assert ours["accumulated_rmse"][-1] <= stbn["accumulated_rmse"][-1]
    assert ours["mask_elow_mean"] <= stbn["mask_elow_mean"]
    assert ours["levels_elow_mean"] <= stbn["levels_elow_mean"]


# ---------------------------------------------------------------- PNG without extra packages
def _png_filters(path) -> set:
    """The filter types used by the rows of a (non-interlaced, 1-IDAT-stream) PNG."""
    data = path.read_bytes()
    pos, idat, w, h, stride = 8, b"", 0, 0, 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos : pos + 8])
        body = data[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            w, h, bits, colour = struct.unpack(">IIBB", body[:10])
            stride = w * {0: 1, 2: 3, 4: 2, 6: 4}[colour] * bits // 8
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = zlib.decompress(idat)
    return {raw[y * (stride + 1)] for y in range(h)}


@pytest.mark.parametrize("shape", [(24, 24), (24, 24, 2), (16, 16, 3)])
@pytest.mark.parametrize("bits", [8, 16])
def test_png_codes_are_exact_and_read_by_other_decoders(tmp_path, shape, bits):
    """write_mask's PNG (the standard library's zlib, no pypng) holds exactly floor(v · 2^bits):
    Pillow and pypng (where installed) decode the same codes, and so does read_mask."""
    from PIL import Image

    a = B.white_mask(shape, 11)
    (path,) = M.write_mask(tmp_path / "m.png", a, bits=bits)
    want = M.quantise(a, bits)
    if want.ndim == 3:  # stored as R, G, B with the missing channels 0
        want = np.concatenate([want, np.zeros(shape[:2] + (3 - shape[2],), want.dtype)], axis=2)
    back = M.quantise(M.read_mask(path), bits)  # the first two values of a vector mask
    assert np.array_equal(back, M.quantise(a, bits)[..., :2] if a.ndim == 3 else M.quantise(a, bits))
    with Image.open(path) as im:
        assert im.size == (shape[1], shape[0])
        if bits == 8 or len(shape) == 2:  # Pillow keeps 16 bits for grey only
            assert np.array_equal(np.asarray(im).astype(np.int64), want.astype(np.int64))
    png = pytest.importorskip("png")
    with open(path, "rb") as fh:
        w, h, rows, info = png.Reader(file=fh).read()
        got = np.array([np.asarray(r) for r in rows]).reshape(want.shape)
    assert info["bitdepth"] == bits and np.array_equal(got, want)


@pytest.mark.parametrize("mode", ["L", "I;16", "RGB", "RGBA"])
def test_read_mask_decodes_every_png_filter(tmp_path, mode):
    """PNGs from Pillow (adaptive filters: Sub, Up, Average, Paeth per row) read back as Pillow
    reads them."""
    from PIL import Image

    rng = np.random.default_rng(3)
    y, x = np.mgrid[0:48, 0:64]
    smooth = (x * 3 + y * 5) % 256  # predictable rows: Pillow picks the predicting filters
    noise = rng.integers(0, 256, (48, 64))
    grey = np.where(y < 24, smooth, noise)
    if mode == "I;16":
        arr = (grey * 257 + (x % 7)).astype(np.uint16)
    elif mode == "L":
        arr = grey.astype(np.uint8)
    else:
        arr = np.stack([grey, (grey + x) % 256, (grey * 3) % 256, 255 - grey][: len(mode)], axis=-1).astype(np.uint8)
    path = tmp_path / f"{mode.replace(';', '')}.png"
    Image.fromarray(arr).save(path)
    assert len(_png_filters(path) - {0}) >= 2, _png_filters(path)
    bits = 16 if mode == "I;16" else 8
    with Image.open(path) as im:
        want = np.asarray(im).astype(np.int64)
    got = np.floor(M.read_mask(path) * (1 << bits)).astype(np.int64)
    if got.ndim == 3:  # read_mask keeps the first two channels
        want = want[..., :2]
    assert np.array_equal(got, want)


def test_mask_file_readers_refuse_non_regular_files(tmp_path):
    for name in ("f.png", "f.npy", "f.exr"):
        os.mkfifo(tmp_path / name)
        with pytest.raises(InvalidArgumentError, match="FIFO"):
            M.read_mask(tmp_path / name)  # at once: a FIFO without a writer would block a read
    (tmp_path / "d.png").mkdir()
    with pytest.raises(InvalidArgumentError, match="folder"):
        M.read_mask(tmp_path / "d.png")
    with pytest.raises(InvalidArgumentError, match="no such file"):
        M.read_mask(tmp_path / "missing.npy")
    (tmp_path / "bad.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 40)
    with pytest.raises(InvalidArgumentError, match="not a PNG"):
        M.read_mask(tmp_path / "bad.png")


def test_exr_without_openexr_is_refused_before_the_work(tmp_path, monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_openexr(name, *args, **kwargs):
        if name == "OpenEXR":
            raise ImportError("No module named 'OpenEXR'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_openexr)
    with pytest.raises(InvalidArgumentError, match=r"\[masks\]"):
        M.check_mask_path(tmp_path / "m.exr")
    with pytest.raises(InvalidArgumentError, match=r"\[masks\]"):
        M.write_mask(tmp_path / "m.exr", B.white_mask((8, 8), 0))
    assert list(tmp_path.iterdir()) == []
    M.write_mask(tmp_path / "m.png", B.white_mask((8, 8), 0))  # PNG needs nothing


# ---------------------------------------------------------------- Ctrl-C
def test_ctrl_c_stops_mask_making_within_half_a_second_every_time():
    """20 interrupts each of an annealed design (libdpc on a worker thread, cancelled through
    its progress poll) and of void-and-cluster (numpy): KeyboardInterrupt within 0.5 s each
    time, and no design keeps running afterwards."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    probe = Path(__file__).resolve().parent / "interrupt_probe.py"
    r = subprocess.run([sys.executable, str(probe), "masks", "20"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    res = json.loads(r.stdout.strip().splitlines()[-1])
    print(res)
    for kind in ("annealed", "void_and_cluster"):
        lat = res[kind]
        assert len(lat) == 20 and all(t is not None and t < 0.5 for t in lat), (kind, lat)
    assert res["design_threads_left"] == 0 and res["cpu_after_s"] < 0.2, res


def test_ctrl_c_stops_dpc_mask_and_leaves_nothing(tmp_path):
    """`dpc mask` designing an annealed 128 x 128 on the spot (minutes): SIGINT is answered with
    "dpc: interrupted" within 0.5 s, the process exits with 130 once libdpc has seen the cancel
    at its next poll (no abort from a thread left inside libdpc), and no file is written."""
    import signal
    import subprocess
    import sys
    import time

    for _ in range(3):
        p = subprocess.Popen(
            [sys.executable, "-m", "dpc.cli", "mask", "-n", "128", "-s", "5", "-o", str(tmp_path / "m.png")],
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "COLUMNS": "80"},
        )
        time.sleep(3.0)  # started and designing
        assert p.poll() is None
        t0 = time.monotonic()
        p.send_signal(signal.SIGINT)
        err = ""
        while "interrupted" not in err:
            chunk = p.stderr.read(1)
            assert chunk, err
            err += chunk
        took = time.monotonic() - t0
        p.wait(timeout=60)
        err += p.stderr.read()
        p.stderr.close()
        assert took < 0.5, took
        assert p.returncode == 130 and "terminate" not in err, err
        assert list(tmp_path.iterdir()) == []
