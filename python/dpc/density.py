"""Densities for blue noise that follows them (``Model.generate_density``, ``dpc stipple``).

A density is a (height, width) grid of finite values >= 0 over [0,1)^2, piecewise constant: row r
covers y in [r/height, (r+1)/height), column c covers x in [c/width, (c+1)/width). For an image
that means y runs down from the top row, as in image coordinates. Only ratios matter.
docs/density.md states the definition and its measurements.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .errors import InvalidArgumentError, LimitError, ModelIOError

__all__ = ["as_density", "image_tone", "MAX_CELLS"]

MAX_CELLS = 1 << 24  # dpc.h's DPC_DENSITY_MAX_CELLS (a 4096 x 4096 image)

_LUMA = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709


def image_tone(source) -> np.ndarray:
    """An image's tone in [0, 1] (0 black, 1 white) as float32 (height, width): from a file
    (anything Pillow reads) or an array (H, W), (H, W, 3) or (H, W, 4) (RGB luminance, Rec. 709;
    alpha ignored); integer arrays are scaled by their type's maximum."""
    if isinstance(source, (str, bytes, os.PathLike)):
        from PIL import Image, UnidentifiedImageError

        try:
            with Image.open(Path(os.fsdecode(source))) as img:
                img.load()
                if img.mode in ("I", "I;16", "I;16B", "I;16L", "F"):
                    arr = np.asarray(img, dtype=np.float64)
                    top = 65535.0 if img.mode.startswith("I;16") or arr.max() > 255 else 255.0
                    arr = arr / (1.0 if img.mode == "F" else top)
                else:
                    arr = np.asarray(img.convert("RGB"), dtype=np.float64) / 255.0
        except (OSError, UnidentifiedImageError) as e:
            raise ModelIOError(f"cannot read the image {os.fsdecode(source)!r}: {e}") from None
    else:
        arr = np.asarray(source)
        if arr.dtype.kind in "ui":
            arr = arr.astype(np.float64) / float(np.iinfo(arr.dtype).max)
        elif arr.dtype.kind in "fb":
            arr = arr.astype(np.float64)
        else:
            raise InvalidArgumentError(f"an image must be numeric, got dtype {arr.dtype}")
    if arr.ndim == 3 and arr.shape[2] in (3, 4):
        arr = arr[..., :3] @ _LUMA
    elif arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[..., 0]
    if arr.ndim != 2:
        raise InvalidArgumentError(f"an image must be (H, W), (H, W, 3) or (H, W, 4), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidArgumentError("the image has non-finite values")
    return np.clip(arr, 0.0, 1.0).astype(np.float32)


def as_density(source, *, resolution: int = 512, invert: bool = False, gamma: float = 1.0) -> np.ndarray:
    """A density grid, float32 (height, width), from:

    - a 2-D array of values >= 0 (used as it is; ``invert`` and ``gamma`` do not apply);
    - a callable ``f(x, y)`` taking and returning arrays, evaluated at the centres of a
      ``resolution`` x ``resolution`` grid;
    - an image file or an (H, W, 3|4) array: its tone t in [0, 1] gives t ** gamma (bright is
      dense), or (1 - t) ** gamma with ``invert`` (dark is dense, as ink).

    Checked before any work: negative, NaN or infinite values, an all-zero grid, a wrong shape
    and more than :data:`MAX_CELLS` cells raise :class:`InvalidArgumentError` (or
    :class:`LimitError`)."""
    if not (isinstance(gamma, (int, float)) and np.isfinite(gamma) and gamma > 0):
        raise InvalidArgumentError(f"gamma must be a positive number, got {gamma!r}")
    if callable(source):
        if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)) or resolution < 1:
            raise InvalidArgumentError(f"resolution must be a positive integer, got {resolution!r}")
        if resolution * resolution > MAX_CELLS:
            raise LimitError(f"resolution {resolution} gives more than {MAX_CELLS} cells")
        y, x = (np.mgrid[0:resolution, 0:resolution] + 0.5) / resolution
        values = np.asarray(source(x, y), dtype=np.float64)
        if values.shape != x.shape:
            values = np.broadcast_to(values, x.shape) if values.ndim == 0 else values
        if values.shape != x.shape:
            raise InvalidArgumentError(
                f"the density function returned shape {values.shape}, expected {x.shape} (it gets arrays x, y)"
            )
        return _checked(values)
    is_image = isinstance(source, (str, bytes, os.PathLike))
    if not is_image:
        arr = np.asarray(source)
        is_image = arr.ndim == 3
    if is_image:
        tone = image_tone(source).astype(np.float64)
        return _checked((1.0 - tone if invert else tone) ** gamma)
    return _checked(np.asarray(source))


def _checked(values) -> np.ndarray:
    arr = np.asarray(values)
    if arr.dtype.kind not in "uifb":
        raise InvalidArgumentError(f"a density must be numeric, got dtype {arr.dtype}")
    if arr.ndim != 2 or 0 in arr.shape:
        raise InvalidArgumentError(f"a density must be a non-empty 2-D array (height, width), got shape {arr.shape}")
    if arr.size > MAX_CELLS:
        raise LimitError(f"a density of {arr.shape[0]} x {arr.shape[1]} cells, at most {MAX_CELLS} in all")
    arr = arr.astype(np.float64)
    if not np.all(np.isfinite(arr)):
        raise InvalidArgumentError("a density must be finite (it has NaN or infinite values)")
    if np.any(arr < 0):
        raise InvalidArgumentError("a density must be >= 0 (it has negative values)")
    top = arr.max()
    if not top > 0:
        raise InvalidArgumentError("a density must be positive somewhere (it is zero everywhere)")
    out = (arr / top).astype(np.float32)  # only ratios matter; float32 keeps them
    if not np.any(out > 0):
        raise InvalidArgumentError("a density's positive values vanish in float32 beside its largest")
    return np.ascontiguousarray(out)
