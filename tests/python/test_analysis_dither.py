"""Dither masks: rank normalisation, mask extraction from gridded points, the quality metric's
white-noise normalisation, Bayer, ordered dithering, and the `dpc dither` command."""

from pathlib import Path

import numpy as np
import pytest

import dpc
from dpc.analysis import dither as D
from dpc.cli import main
from dpc.errors import InvalidArgumentError

GRID_MODEL = Path(__file__).resolve().parents[1] / "data" / "model_grid_3to1.onnx"


def test_rank_normalise_is_uniform_and_order_preserving():
    a = np.random.default_rng(0).normal(size=(8, 8))
    r = D.rank_normalise(a)
    assert np.allclose(np.sort(r.ravel()), (np.arange(64) + 0.5) / 64)
    assert np.array_equal(np.argsort(r, axis=None), np.argsort(a, axis=None))


def test_mask_from_points_follows_the_format_cell_order():
    # point i sits in cell (i mod 4, i div 4): give it value i, the mask must read row by row
    i = np.arange(16)
    pts = np.stack([(i % 4 + 0.5) / 4, (i // 4 + 0.5) / 4, i / 16.0], axis=1)
    mask = D.mask_from_points(pts, (0, 1), (4, 4))
    assert np.allclose(mask, (i.reshape(4, 4) + 0.5) / 16)
    with pytest.raises(InvalidArgumentError):
        D.mask_from_points(pts[:15], (0, 1), (4, 4))
    with pytest.raises(InvalidArgumentError):
        D.mask_from_points(pts, (0,), (16,))


def test_white_noise_masks_score_one_and_bayer_is_periodic():
    q = D.mask_quality(np.random.default_rng(1).random((300, 32, 32)))
    assert abs(q["mask_elow"] - 1) < 0.05 and abs(q["levels_elow_mean"] - 1) < 0.05
    b = D.bayer(32)
    assert np.allclose(np.sort(b.ravel()), (np.arange(1024) + 0.5) / 1024)
    qb = D.mask_quality(b)
    assert qb["levels_elow_mean"] < 1e-12  # all power in a few high-frequency spikes
    assert qb["levels_peak_mean"] > 50 * q["levels_peak_mean"]
    with pytest.raises(InvalidArgumentError):
        D.bayer(12)


def test_dither_tiles_the_mask_and_keeps_the_grey_level():
    mask = D.bayer(8)
    for grey in (0.1, 0.5, 0.8):
        out = D.dither(np.full((40, 24), grey), mask)
        assert out.shape == (40, 24)
        assert abs(out[:40, :24].mean() - grey) < 1.5 / 64 + 1e-9
    rgb = np.zeros((4, 4, 3), np.uint8)
    rgb[..., 1] = 255
    assert np.allclose(D.luminance(rgb), 0.7152)
    with pytest.raises(InvalidArgumentError):
        D.dither(np.full((4, 4), np.nan), mask)


def test_model_mask_from_the_gridded_test_model():
    model = dpc.load(GRID_MODEL)
    mask = D.model_mask(model, seed=3)
    assert mask.shape == (model.grid_shape[1], model.grid_shape[0])
    assert np.allclose(np.sort(mask.ravel()), (np.arange(mask.size) + 0.5) / mask.size)
    with pytest.raises(InvalidArgumentError):
        D.model_mask(dpc.load(GRID_MODEL.with_name("model_2d.onnx")))


def test_dither_command(tmp_path, capsys):
    import matplotlib.image as mpimg

    ramp = np.tile(np.linspace(0, 1, 96), (64, 1))
    src = tmp_path / "ramp.png"
    mpimg.imsave(src, ramp, cmap="gray", vmin=0, vmax=1)
    out, mask = tmp_path / "out.png", tmp_path / "mask.npy"
    rc = main(["dither", str(src), "-m", str(GRID_MODEL), "-o", str(out), "--mask-output", str(mask)])
    err = capsys.readouterr().err
    assert rc == 0, err
    img = mpimg.imread(out)
    assert img.shape[:2] == (64, 96)
    white = img[..., 0] > 0.5
    # the ramp's grey level survives: column means follow the ramp
    assert abs(white[:, :24].mean() - ramp[:, :24].mean()) < 0.08
    assert abs(white[:, -24:].mean() - ramp[:, -24:].mean()) < 0.08
    assert np.load(mask).shape == (32, 32)
    rc = main(["dither", str(src), "-m", str(GRID_MODEL.with_name("model_2d.onnx")), "-o", str(out)])
    err = capsys.readouterr().err
    assert rc == 1 and "not gridded" in err
    rc = main(["dither", str(src), "-o", str(tmp_path / "x.jpg"), "-m", str(GRID_MODEL)])
    assert rc == 2
