"""Mask files: .npy (float64), .png (8- or 16-bit codes, dpc.masks.png) and .exr (float32, with
the masks extra); a spatiotemporal mask as one .npy or one image per frame. Every write is atomic."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import _atomic
from ..errors import InvalidArgumentError
from .png import open_regular, read_png, write_png

MASK_EXTENSIONS = (".npy", ".png", ".exr")


def kind_of(mask_array: np.ndarray, spatiotemporal: bool = False) -> str:
    """Kind of an array: (N, N) scalar, (N, N, C) vector, (T, N, N) spatiotemporal (a 3-D
    array is read as vector when its last axis is ≤ 4 and not equal to N, else as frames)."""
    a = np.asarray(mask_array)
    if a.ndim == 2:
        return "scalar"
    if a.ndim == 3:
        if spatiotemporal:
            return "spatiotemporal"
        if a.shape[0] == a.shape[1] and a.shape[2] <= 4 and a.shape[2] != a.shape[0]:
            return "vector"
        if a.shape[1] == a.shape[2]:
            return "spatiotemporal"
    raise InvalidArgumentError(f"a mask is (N, N), (N, N, C) or (T, N, N); got {a.shape}")


def frame_paths(path, frames: int) -> list[Path]:
    """The files of a spatiotemporal mask written to ``path``: stem_000.ext, stem_001.ext, …"""
    p = Path(path)
    width = max(3, len(str(frames - 1)))
    return [p.with_name(f"{p.stem}_{k:0{width}d}{p.suffix}") for k in range(frames)]


_EXR_CHANNELS = ("R", "G", "B", "A")


EXR_EXTRA = 'pip install "deep-point-correlation[masks]" (from a checkout: pip install ".[masks]")'


def _openexr():
    """The OpenEXR module, or InvalidArgumentError naming the extra that brings it."""
    try:
        import OpenEXR
    except ImportError:
        raise InvalidArgumentError(f"EXR files need the OpenEXR package: {EXR_EXTRA}; or write .png or .npy") from None
    return OpenEXR


def check_mask_path(path) -> Path:
    """Everything about an output path that can fail, checked before a mask is made: the
    extension, the package an EXR needs, and the output folder (it must exist)."""
    p = Path(path)
    ext = p.suffix.lower()
    if ext not in MASK_EXTENSIONS:
        raise InvalidArgumentError(f"mask file must end in {', '.join(MASK_EXTENSIONS)}; got {p.name!r}")
    if ext == ".exr":
        _openexr()
    _atomic.check_output(p)
    return p


def _write_exr(path: Path, img: np.ndarray) -> None:
    OpenEXR = _openexr()

    a = np.asarray(img, dtype=np.float32)
    if a.ndim == 2:
        chans = {"Y": np.ascontiguousarray(a)}
    else:
        if a.shape[2] > 4:
            raise InvalidArgumentError("EXR output holds at most 4 channels")
        chans = {_EXR_CHANNELS[c]: np.ascontiguousarray(a[:, :, c]) for c in range(a.shape[2])}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with _atomic.atomic_path(path) as tmp, OpenEXR.File(header, chans) as f:
        f.write(str(tmp))


def _read_exr(path: Path) -> np.ndarray:
    OpenEXR = _openexr()
    open_regular(path).close()  # a FIFO or folder: refused before OpenEXR opens it

    with OpenEXR.File(str(path)) as f:
        ch = f.channels()
        if "Y" in ch:
            return np.asarray(ch["Y"].pixels, dtype=np.float64)
        names = [c for c in _EXR_CHANNELS if c in ch]
        if not names:
            raise InvalidArgumentError(f"{path}: no Y or R/G/B/A channels")
        return np.stack([np.asarray(ch[c].pixels, dtype=np.float64) for c in names], axis=-1)


def write_mask(path, mask_array: np.ndarray, bits: int = 16, spatiotemporal: bool | None = None) -> list[Path]:
    """Write a mask: ``.npy`` (float64, exact), ``.png`` (8- or 16-bit codes floor(v · 2^bits);
    grey for scalar, R, G (B = 0) for 2 values) or ``.exr`` (float32, exact for masks up to
    2^23 pixels; channel Y, or R, G, …). A spatiotemporal (T, N, N) mask goes to one ``.npy``,
    or to T files stem_000.png … (each frame a scalar mask). Returns the paths written.

    Written atomically (``dpc._atomic``): each file goes to a temporary file beside it and is
    renamed into place when complete, and the frames of a spatiotemporal mask appear together;
    on any failure no new file is left and existing files are unchanged."""
    p = check_mask_path(path)
    ext = p.suffix.lower()
    a = np.asarray(mask_array, dtype=np.float64)
    kind = kind_of(a, bool(spatiotemporal))
    if not np.all(np.isfinite(a)) or a.min() < 0 or a.max() >= 1:
        raise InvalidArgumentError("mask values must be finite and in [0, 1)")
    if ext == ".npy":
        with _atomic.atomic_file(p, "wb") as fh:
            np.save(fh, a)
        return [p]
    if ext == ".png" and bits not in (8, 16):
        raise InvalidArgumentError(f"PNG bit depth must be 8 or 16, got {bits}")
    images, paths = ([a], [p]) if kind != "spatiotemporal" else (list(a), frame_paths(p, a.shape[0]))
    with _atomic.transaction():  # every frame, or none
        for img, q in zip(images, paths):
            if ext == ".png":
                write_png(q, img, bits)
            else:
                _write_exr(q, img)
    return paths


def read_mask(path, max_pixels=None) -> np.ndarray:
    """Read a mask file written by :func:`write_mask` (or a list of frame files, stacked into
    (T, N, N)). PNG codes come back as (code + ½)/2^bits; EXR and .npy exactly as written.
    Only regular files are read (a FIFO or folder is refused at once); a PNG's header is
    checked against ``max_pixels`` (as in :func:`mask`) before it is decoded. PNG needs no
    extra package; EXR needs OpenEXR (the ``masks`` extra)."""
    if isinstance(path, (list, tuple)):
        if not path:
            raise InvalidArgumentError("no mask files given")
        return np.stack([read_mask(q, max_pixels) for q in path])
    p = Path(path)
    ext = p.suffix.lower()
    if ext == ".npy":
        with open_regular(p) as fh:
            try:
                return np.load(fh, allow_pickle=False)
            except (ValueError, EOFError) as e:
                raise InvalidArgumentError(f"{p}: not a readable .npy file ({e})") from None
    if ext == ".png":
        return read_png(p, None, max_pixels)
    if ext == ".exr":
        return _read_exr(p)
    raise InvalidArgumentError(f"mask file must end in {', '.join(MASK_EXTENSIONS)}; got {p.name!r}")
