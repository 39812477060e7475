"""The PNG codec of mask files, on the standard library alone (struct, zlib): 8- and 16-bit grey
or RGB written, and the PNGs masks are stored in read back (no imaging package needed)."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

from .. import _atomic, pointio
from ..errors import InvalidArgumentError
from .baselines import check_pixels

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_PLANES = {0: 1, 2: 3, 4: 2, 6: 4}  # colour type -> samples per pixel (grey, RGB, grey + alpha, RGBA)


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def quantise(mask_array: np.ndarray, bits: int) -> np.ndarray:
    """The integer codes a PNG of ``bits`` (8 or 16) stores: floor(v · 2^bits), v in [0, 1)."""
    if bits not in (8, 16):
        raise InvalidArgumentError(f"PNG bit depth must be 8 or 16, got {bits}")
    a = np.asarray(mask_array, dtype=np.float64)
    if a.size == 0 or not np.all(np.isfinite(a)) or a.min() < 0 or a.max() >= 1:
        raise InvalidArgumentError("mask values must be finite and in [0, 1)")
    return np.minimum(np.floor(a * (1 << bits)), (1 << bits) - 1).astype(np.uint16 if bits == 16 else np.uint8)


def write_png(path: Path, img: np.ndarray, bits: int) -> None:
    """A PNG of the codes floor(v · 2^bits): grey for a scalar mask, RGB (B = 0) for 2 or 3
    values. Encoded with the standard library (zlib): no imaging package is needed, and 16-bit
    colour, which Pillow cannot write, is exact too."""
    codes = quantise(img, bits)
    if codes.ndim == 3:
        c = codes.shape[2]
        if c > 3:
            raise InvalidArgumentError("PNG output holds at most 3 channels")
        rgb = np.zeros(codes.shape[:2] + (3,), dtype=codes.dtype)
        rgb[..., :c] = codes  # 2 values: R, G (B = 0)
        codes = rgb
    h, w = codes.shape[:2]
    rows = codes.astype(">u2" if bits == 16 else np.uint8).reshape(h, -1).view(np.uint8)
    raw = np.concatenate([np.zeros((h, 1), np.uint8), rows], axis=1)  # filter type 0 on every row
    header = struct.pack(">IIBBBBB", w, h, bits, 0 if codes.ndim == 2 else 2, 0, 0, 0)
    data = (
        _PNG_SIGNATURE
        + _png_chunk(b"IHDR", header)
        + _png_chunk(b"IDAT", zlib.compress(raw.tobytes(), 6))
        + _png_chunk(b"IEND", b"")
    )
    _atomic.write_bytes(path, data)


def _png_unfilter(data: bytes, h: int, stride: int, bpp: int) -> np.ndarray:
    """Undo PNG's per-row filters (types 0-4): (h, stride) bytes."""
    if len(data) != h * (stride + 1):
        raise ValueError(f"{len(data)} bytes of image data, expected {h * (stride + 1)}")
    out = np.zeros((h + 1, stride), np.uint8)  # row 0: the zero row before the first
    for y in range(h):
        pos = y * (stride + 1)
        kind = data[pos]
        line = np.frombuffer(data, np.uint8, stride, pos + 1).copy()
        prior = out[y]
        if kind == 1:  # Sub: running sums, modulo 256, per byte of a pixel
            line = np.cumsum(line.reshape(-1, bpp), axis=0, dtype=np.uint8).ravel()
        elif kind == 2:  # Up
            line += prior
        elif kind in (3, 4):  # Average, Paeth: each byte depends on the one before
            r, up = line.tolist(), prior.tolist()
            for i in range(stride):
                a = r[i - bpp] if i >= bpp else 0
                b = up[i]
                if kind == 3:
                    r[i] = (r[i] + (a + b) // 2) & 0xFF
                else:
                    c = up[i - bpp] if i >= bpp else 0
                    p = a + b - c
                    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                    r[i] = (r[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 0xFF
            line = np.array(r, np.uint8)
        elif kind != 0:
            raise ValueError(f"unknown PNG filter type {kind}")
        out[y + 1] = line
    return out[1:]


def png_header(path) -> tuple[int, int, int, int, int]:
    """(width, height, bit depth, colour type, interlace) from a PNG's IHDR, without decoding."""
    with open_regular(path) as fh:
        head = fh.read(33)
    if len(head) < 33 or head[:8] != _PNG_SIGNATURE or head[12:16] != b"IHDR":
        raise InvalidArgumentError(f"{path}: not a PNG file")
    w, h, bits, colour, _compression, _filter, interlace = struct.unpack(">IIBBBBB", head[16:29])
    return w, h, bits, colour, interlace


def read_png(path: Path, channels: int | None, max_pixels=None) -> np.ndarray:
    w, h, bits, colour, interlace = png_header(path)
    if bits not in (8, 16) or colour not in _PNG_PLANES:
        raise InvalidArgumentError(
            f"{path}: {bits}-bit PNG of colour type {colour}; masks are 8 or 16 bits, grey or RGB(A)"
        )
    if interlace:
        raise InvalidArgumentError(f"{path}: an interlaced PNG; save the mask without interlacing")
    check_pixels(w * h, f"{path} ({w} x {h})", max_pixels)
    planes = _PNG_PLANES[colour]
    stride = w * planes * bits // 8
    chunks = []
    with open_regular(path) as fh:
        fh.seek(8)
        try:
            while True:
                length, kind = struct.unpack(">I4s", fh.read(8))
                body = fh.read(length)
                fh.read(4)  # CRC
                if len(body) != length:
                    raise ValueError("truncated")
                if kind == b"IDAT":
                    chunks.append(body)
                elif kind == b"IEND":
                    break
            inflater = zlib.decompressobj()
            # never inflate beyond the image's size (a small file can claim gigabytes)
            data = inflater.decompress(b"".join(chunks), h * (stride + 1) + 1)
            rows = _png_unfilter(data, h, stride, planes * bits // 8)
        except (struct.error, zlib.error, ValueError) as e:
            raise InvalidArgumentError(f"{path}: a damaged PNG ({e})") from None
    a = rows.view(">u2" if bits == 16 else np.uint8).reshape(h, w, planes).astype(np.float64)
    v = (a + 0.5) / (1 << bits)
    if planes == 1:
        return v[:, :, 0]
    c = 2 if channels is None else channels
    return v[:, :, :c]


def open_regular(path):
    """``open(path, "rb")`` for a regular file only: a FIFO, a device or a folder is refused at
    once (InvalidArgumentError) instead of blocking or failing later."""
    return pointio.open_regular(path, "rb")
