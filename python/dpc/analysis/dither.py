"""Dither masks (threshold maps) from gridded models, their quality, and ordered dithering.

A gridded model (e.g. ``dither-32``: x, y fixed at the centres of a 32 × 32 pixel grid, z free)
gives a mask: pixel (ix, iy) holds the z of its point. Masks are used by rank, (rank + ½)/N², so
every grey level is reached by exactly its share of pixels whatever the distribution of z.

Quality (Ulichney's criterion): a blue-noise mask has little power at low image frequencies,
both as a continuous image and in the binary pattern it gives for every constant grey. Power is
normalised so that a white-noise mask scores 1: |DFT(b − mean)|² / (N² · var), var = L(1 − L)
for the binary pattern of grey L. The largest single-frequency power of the thresholded
patterns tells periodic masks (Bayer: all power in a few spikes) from blue noise.
"""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np

from .. import _atomic
from ..errors import InvalidArgumentError

LEVELS = tuple(k / 8 for k in range(1, 8))


def rank_normalise(mask: np.ndarray) -> np.ndarray:
    """(rank + ½) / size, same shape: a uniform threshold map (ties broken by position)."""
    a = np.asarray(mask, dtype=np.float64)
    r = np.empty(a.size)
    r[np.argsort(a, axis=None, kind="stable")] = np.arange(a.size)
    return ((r + 0.5) / a.size).reshape(a.shape)


def mask_from_points(points: np.ndarray, grid_axes, grid_shape, value_axis: int | None = None) -> np.ndarray:
    """The mask of one set of a 2-D-gridded model: point i sits in cell (i mod G0, i div G0)
    (docs/model-format.md §5); returns mask[iy, ix] = rank-normalised value."""
    x = np.asarray(points)
    axes, shape = tuple(grid_axes), tuple(int(g) for g in grid_shape)
    if len(axes) != 2 or len(shape) != 2:
        raise InvalidArgumentError(f"a dither mask needs exactly 2 gridded axes, got {axes}")
    if x.ndim != 2 or x.shape[0] != shape[0] * shape[1]:
        raise InvalidArgumentError(f"points must be ({shape[0] * shape[1]}, n), got {x.shape}")
    free = [d for d in range(x.shape[1]) if d not in axes]
    if value_axis is None:
        if len(free) != 1:
            raise InvalidArgumentError(f"name the value axis: free axes are {free}")
        value_axis = free[0]
    if value_axis not in free:
        raise InvalidArgumentError(f"value axis {value_axis} is not a free axis ({free})")
    return rank_normalise(x[:, value_axis].reshape(shape[1], shape[0]))


def model_mask(model, seed: int = 0) -> np.ndarray:
    """Mask of a loaded gridded ``dpc.Model`` for one seed."""
    if not model.grid_axes:
        raise InvalidArgumentError("the model is not gridded: it has no pixel grid to make a mask on")
    return mask_from_points(model.generate(seed=seed), model.grid_axes, model.grid_shape)


def bayer(n: int) -> np.ndarray:
    """The n × n Bayer (ordered-dither) matrix, n a power of two, rank-normalised."""
    if n < 1 or n & (n - 1):
        raise InvalidArgumentError(f"Bayer size must be a power of two, got {n}")
    m = np.zeros((1, 1))
    while m.shape[0] < n:
        m = np.block([[4 * m, 4 * m + 2], [4 * m + 3, 4 * m + 1]])
    return (m + 0.5) / m.size


def _low_band(n: int, q_max: float) -> np.ndarray:
    q = np.fft.fftfreq(n, 1.0 / n)
    qq = np.hypot(q[:, None], q[None, :])
    return (qq > 0) & (qq <= q_max)


def mask_quality(masks, q_max: float = 6.0, levels=LEVELS) -> dict:
    """Low-band energies of square masks (count, N, N) or one mask: of the rank-normalised mask
    and of its thresholded patterns at ``levels`` (mean over masks; white-noise mask = 1)."""
    ms = np.asarray(masks, dtype=np.float64)
    if ms.ndim == 2:
        ms = ms[None]
    if ms.ndim != 3 or ms.shape[1] != ms.shape[2] or ms.shape[1] < 4:
        raise InvalidArgumentError(f"masks must be (count, N, N) with N >= 4, got {np.shape(masks)}")
    n = ms.shape[1]
    low = _low_band(n, q_max)
    r = np.stack([rank_normalise(m) for m in ms])
    c = r - r.mean(axis=(1, 2), keepdims=True)
    p0 = np.abs(np.fft.fft2(c)) ** 2 / (n * n * c.var(axis=(1, 2), keepdims=True))
    per_level, peaks = [], []
    for lv in levels:
        b = (r < lv).astype(np.float64)
        frac = b.mean(axis=(1, 2), keepdims=True)
        p = np.abs(np.fft.fft2(b - frac)) ** 2 / (n * n * lv * (1 - lv))
        per_level.append(float(p[:, low].mean()))
        p[:, 0, 0] = 0.0
        peaks.append(float(p.max(axis=(1, 2)).mean()))
    return {
        "mask_elow": float(p0[:, low].mean()),
        "levels": list(levels),
        "levels_elow": per_level,
        "levels_elow_mean": float(np.mean(per_level)),
        "levels_elow_max": float(np.max(per_level)),
        "levels_peak": peaks,
        "levels_peak_mean": float(np.mean(peaks)),
    }


def luminance(image: np.ndarray) -> np.ndarray:
    """Grey values in [0, 1] from an (H, W), (H, W, 3) or (H, W, 4) image (uint8 or float);
    Rec. 709 weights on the (assumed linear) channels; alpha is ignored."""
    a = np.asarray(image)
    if a.dtype.kind in "ui":
        a = a.astype(np.float64) / np.iinfo(a.dtype).max
    else:
        a = a.astype(np.float64)
    if a.ndim == 3 and a.shape[2] in (3, 4):
        a = a[:, :, :3] @ np.array([0.2126, 0.7152, 0.0722])
    elif a.ndim != 2:
        raise InvalidArgumentError(f"image must be (H, W) or (H, W, 3|4), got {np.shape(image)}")
    if not np.all(np.isfinite(a)):
        raise InvalidArgumentError("image has non-finite values")
    return np.clip(a, 0.0, 1.0)


_PIL_LOCK = threading.Lock()


def read_image(path, max_pixels=None) -> np.ndarray:
    """An image file as matplotlib's ``imread`` gives it (PNG: float in [0, 1]; other formats
    Pillow reads: integers), for :func:`dither`. Only a regular file is read (a FIFO or folder is
    refused at once), and its header's width × height is checked against ``max_pixels`` before
    anything is decoded (default 2^26 = 8192 × 8192 or $DPC_MAX_PIXELS, ``math.inf``: none;
    :class:`dpc.errors.LimitError` beyond it). Unreadable files raise InvalidArgumentError."""
    import warnings

    import matplotlib.image as mpimg
    from PIL import Image, UnidentifiedImageError

    from ..masks.baselines import check_pixels, pixel_limit
    from ..pointio import open_regular

    pixel_limit(max_pixels)  # a bad max_pixels or DPC_MAX_PIXELS: said before the file is opened
    with open_regular(path) as fh, _PIL_LOCK, warnings.catch_warnings():
        # Pillow's own bound (a process-wide setting) is replaced, while this file is read, by
        # this call's limit, checked against the header before anything is decoded.
        saved = Image.MAX_IMAGE_PIXELS
        Image.MAX_IMAGE_PIXELS = None
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)
        try:
            with Image.open(fh) as im:  # reads the header only
                w, h = im.size
            check_pixels(w * h, f"image {path} ({w} x {h})", max_pixels)
            fh.seek(0)
            return mpimg.imread(fh)
        except (OSError, SyntaxError, ValueError) as e:  # Pillow/libpng failures on bad files
            if isinstance(e, InvalidArgumentError):
                raise
            why = "not an image format Pillow reads" if isinstance(e, UnidentifiedImageError) else _one_line(e)
            raise InvalidArgumentError(f"cannot read image {path}: {why}") from None
        finally:
            Image.MAX_IMAGE_PIXELS = saved


def _one_line(e) -> str:
    return " ".join(str(e).split()) or type(e).__name__


def dither(image: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Ordered dithering: the mask tiled over the image, pixel on where grey > threshold.
    Returns a bool (H, W) array."""
    g = luminance(image)
    m = np.asarray(mask, dtype=np.float64)
    if m.ndim != 2 or min(m.shape) < 1:
        raise InvalidArgumentError(f"mask must be 2-D, got {np.shape(mask)}")
    reps = (-(-g.shape[0] // m.shape[0]), -(-g.shape[1] // m.shape[1]))
    return g > np.tile(m, reps)[: g.shape[0], : g.shape[1]]


def save_mask_figure(path, mask: np.ndarray, title: str = "") -> Path:
    """The mask, its power spectrum (log) and its binary patterns at greys 1/4 and 1/2."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = rank_normalise(mask)
    n = r.shape[0]
    c = r - r.mean()
    p = np.fft.fftshift(np.abs(np.fft.fft2(c)) ** 2 / (n * n * c.var()))
    fig, axs = plt.subplots(1, 4, figsize=(11, 3))
    axs[0].imshow(np.tile(r, (2, 2)), cmap="gray", interpolation="nearest")
    axs[0].set_title("mask (2 × 2 tiles)")
    axs[1].imshow(np.log10(np.maximum(p, 1e-3)), cmap="viridis", interpolation="nearest")
    axs[1].set_title("log10 power (DC centred)")
    for ax, lv in zip(axs[2:], (0.25, 0.5)):
        ax.imshow(np.tile(r < lv, (2, 2)), cmap="gray_r", interpolation="nearest")
        ax.set_title(f"grey {lv:g}")
    for ax in axs:
        ax.set_xticks([])
        ax.set_yticks([])
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    try:
        _atomic.save_figure(fig, path, dpi=110)  # atomic, like every writer of dpc
    finally:
        plt.close(fig)
    return path
