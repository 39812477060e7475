"""Blue-noise threshold masks for dithering and real-time rendering (docs/masks.md).

    >>> import dpc
    >>> m = dpc.mask("mask-64", seed=3)                    # (64, 64) float64, values (rank + ½)/4096
    >>> v = dpc.mask("mask-vector-64")                     # (64, 64, 2): per-pixel 2-D offsets
    >>> st = dpc.mask("mask-st-32x16")                     # (16, 32, 32): frame t = st[t]
    >>> vc = dpc.mask("void-and-cluster", size=128, seed=1)
    >>> dpc.masks.write_mask("mask.png", m, bits=16)       # also .npy, and .exr (the masks extra)

A mask is a float64 array of rank-normalised values: every value (k + ½)/S, k = 0 … S − 1, taken
by exactly one pixel (S = the pixels of one threshold map). Shapes: scalar (N, N); vector
(N, N, C), each channel ranked on its own; spatiotemporal (T, N, N), each frame ranked on its
own. Pixel (ix, iy) is ``mask[iy, ix]``; every mask tiles seamlessly (it is made on the torus).

Sources (:func:`available`):

* a gridded dpc model (bundled name or ``.onnx`` path). Its grid axes give the pixel grid (and
  frames), its free axes the values: 2 grid axes + 1 free axis → scalar, 2 + C → vector,
  3 + 1 → spatiotemporal (the third grid axis is time). At the trained grid the mask is
  ``model.generate(seed)``; at another size the same input construction (libdpc's uniform points
  of ``seed``, grid axes set to cell centres, docs/model-format.md §5) is filtered with
  ``model.filter``, whose radii scale with the point count (quality there: docs/masks.md).
* ``annealed``: masks designed by dpc's spectral annealing (:mod:`dpc.mask_design`), scalar or
  spatiotemporal (``frames``) or vector (``channels=2``, blue per channel and jointly). Sizes and seeds
  in :data:`dpc.mask_design.BUNDLED` load from the package; others are designed on the spot
  (about 11 s for 64 × 64, 3 minutes at 128 × 128).
* baselines from :mod:`dpc.baselines`: ``void-and-cluster`` (Ulichney 1993; with ``channels=2``
  two independent masks, with ``frames=T`` T independent masks), ``stbn`` (scalar spatiotemporal
  blue noise after Wolfe et al. 2022; needs ``frames``), ``white``, ``bayer``.
"""

from __future__ import annotations

import math
import struct
import zlib
from pathlib import Path

import numpy as np

from . import _args, _atomic, pointio
from . import baselines as _bl
from .errors import DpcError, InvalidArgumentError, ModelNotFoundError

BASELINE_MASKS = {
    "void-and-cluster": "Ulichney's void-and-cluster (1993), sigma 1.5, toroidal; channels=2: two "
    "independent masks; frames=T: T independent masks",
    "stbn": "scalar spatiotemporal blue noise (Wolfe et al. 2022): void-and-cluster over (T, N, N) "
    "with a spatial and a temporal Gaussian energy, sigma 1.9; needs frames",
    "white": "white noise, rank-normalised (any shape)",
    "bayer": "Bayer ordered-dither matrix (N a power of two)",
}
DESIGNED_MASKS = {
    "annealed": "dpc's spectral annealing (dpc.mask_design): below void-and-cluster at 48, 64, 128 (not 32); "
    "frames=T: blue in space and time; channels=2: blue per channel and jointly; default 64 x 64",
}
MASK_EXTENSIONS = (".npy", ".png", ".exr")


# ---------------------------------------------------------------- making masks
def rank_normalise(a: np.ndarray, kind: str) -> np.ndarray:
    """(rank + ½)/S per threshold map: the whole array (scalar), per channel (vector, last
    axis) or per frame (spatiotemporal, first axis)."""
    from .analysis.dither import rank_normalise as rn

    a = np.asarray(a, dtype=np.float64)
    if kind == "scalar":
        return rn(a)
    if kind == "vector":
        return np.stack([rn(a[..., c]) for c in range(a.shape[-1])], axis=-1)
    if kind == "spatiotemporal":
        return np.stack([rn(f) for f in a])
    raise InvalidArgumentError(f"unknown mask kind {kind!r}")


def mask_kind(model) -> str:
    """'scalar', 'vector' or 'spatiotemporal' for a gridded dpc.Model (see the module doc)."""
    axes = tuple(model.grid_axes)
    free = [d for d in range(model.dims) if d not in axes]
    if len(axes) == 2 and len(free) == 1:
        return "scalar"
    if len(axes) == 2 and len(free) >= 2:
        return "vector"
    if len(axes) == 3 and len(free) == 1:
        return "spatiotemporal"
    raise InvalidArgumentError(
        f"model {model.metadata.get('dpc.name', '?')} is not a mask model: it needs 2 grid axes "
        f"(+ 1 or more value axes) or 3 grid axes (x, y, time) + 1 value axis; it has grid axes "
        f"{list(axes)} of {model.dims} dims"
    )


def _model_mask(model, size: int | None, frames: int | None, seed: int, max_pixels=None) -> np.ndarray:
    kind = mask_kind(model)
    axes = tuple(model.grid_axes)
    shape = tuple(model.grid_shape)
    if shape[0] != shape[1]:
        raise InvalidArgumentError(f"the model's pixel grid is not square: {shape[:2]}")
    n = shape[0] if size is None else _args.size(size, "size", 4)
    if kind == "spatiotemporal":
        t = shape[2] if frames is None else _args.size(frames, "frames", 2)
        want = (n, n, t)
    else:
        if frames is not None:
            raise InvalidArgumentError(f"frames applies to spatiotemporal masks; this is a {kind} mask")
        want = (n, n)
    _bl.check_pixels(math.prod(want), f"a mask {' x '.join(map(str, want))} from {model.name}", max_pixels)
    if want == shape:
        pts = model.generate(seed=seed)
    else:
        pts = _filter_at_any_size(model, _grid_input(seed, want, axes, model.dims))
    free = [d for d in range(model.dims) if d not in axes]
    vals = np.asarray(pts, dtype=np.float64)[:, free]
    if kind == "scalar":
        out = vals[:, 0].reshape(n, n)
    elif kind == "vector":
        out = vals.reshape(n, n, len(free))
    else:
        out = vals[:, 0].reshape(want[2], n, n)
    return rank_normalise(out, kind)


def _grid_input(seed: int, grid: tuple, axes: tuple, dims: int) -> np.ndarray:
    """libdpc's input for a gridded model (docs/model-format.md §5) on another grid: the
    uniform points of ``seed``, grid axes at the cell centres (first axis fastest)."""
    import dpc

    m = math.prod(grid)
    pts = np.asarray(dpc.uniform(seed, m, dims), dtype=np.float64)
    idx = np.arange(m)
    div = 1
    for a, g in zip(axes, grid):
        pts[:, a] = ((idx // div) % g + 0.5) / g
        div *= g
    return pts


def _filter_at_any_size(model, pts: np.ndarray) -> np.ndarray:
    """Run a gridded model's cascade on points of any count. libdpc's dpc_generate/dpc_filter
    serve a gridded model at its grid's point count only, so this runs the file's layers one by
    one through libdpc's float64 layer kernels (dpc_layer_forward, the training API; radii
    scale with the point count as in every layer, docs/model-format.md §3). Needs the onnx
    package to read the layers (the ``masks`` extra)."""
    from .model_file import read_model
    from .training import layer_forward

    try:
        spec = read_model(model.path)
    except ImportError as e:
        raise InvalidArgumentError(f"a mask model at a size other than its grid needs the onnx package ({e})") from e
    x = np.ascontiguousarray(pts, dtype=np.float64)
    for layer in spec.layers:
        x = layer_forward(x, layer.kernels, layer.subspaces, layer.radius, layer.eps, int(layer.fixed), threads=0)
        x = x - np.floor(x)
    return x


def _baseline_mask(name: str, size, frames, channels, seed: int, max_pixels=None) -> np.ndarray:
    if size is None:
        raise InvalidArgumentError(f"mask {name!r} needs a size")
    n = _args.size(size, "size", 2)
    c = 1 if channels is None else _args.size(channels, "channels", 1)
    t = None if frames is None else _args.size(frames, "frames", 1)
    what = f"{name} {n} x {n}" + (f", {t} frames" if t is not None else "") + (f", {c} channels" if c > 1 else "")
    design = name in ("void-and-cluster", "stbn")
    _bl.check_pixels(n * n * (t or 1) * c, what, max_pixels, design)
    free = math.inf  # checked above for the whole mask
    if name == "white":
        if c > 1 and t is not None:
            raise InvalidArgumentError("white: give channels or frames, not both")
        if t is not None:
            return np.stack([_bl.white_mask((n, n), seed + k, free) for k in range(t)])
        return _bl.white_mask((n, n), seed, free) if c == 1 else _bl.white_mask((n, n, c), seed, free)
    if name == "bayer":
        if c != 1 or t is not None:
            raise InvalidArgumentError("bayer is a scalar mask (no channels, no frames)")
        return _bl.bayer_mask(n, free)
    if name == "void-and-cluster":
        if c > 1 and t is not None:
            raise InvalidArgumentError("void-and-cluster: give channels or frames, not both")
        vac = [_bl.void_and_cluster(n, seed + 1_000_003 * k, max_pixels=free) for k in range(t or c)]
        if t is not None:
            return np.stack(vac)
        return vac[0] if c == 1 else np.stack(vac, axis=-1)
    if name == "stbn":
        if t is None:
            raise InvalidArgumentError("stbn needs frames (e.g. frames=16)")
        if c != 1:
            raise InvalidArgumentError("stbn here is the scalar construction (channels = 1)")
        return _bl.stbn_scalar(n, t, seed, max_pixels=free)
    raise InvalidArgumentError(f"unknown mask {name!r}")


def _annealed_mask(size, frames, channels, seed: int, progress=None, max_pixels=None) -> np.ndarray:
    from . import mask_design

    # frames and channels are checked by mask_design (a combination it has no bundle for
    # reaches anneal_mask, which refuses it)
    n = 64 if size is None else _args.size(size, "size", 8)
    t = None if frames is None else _args.size(frames, "frames", 1)
    return mask_design.mask(n, t, seed, channels, progress=progress, max_pixels=max_pixels)


def available() -> dict[str, str]:
    """Mask sources: the bundled gridded models and the baselines, with one line each."""
    import dpc

    out = {}
    for name in dpc.available_models():
        try:
            model = dpc.load(name)
            kind = mask_kind(model)
        except DpcError:
            continue
        shape = "x".join(str(g) for g in model.grid_shape)
        out[name] = f"dpc model, {kind}, trained at {shape}"
    out.update(DESIGNED_MASKS)
    out.update(BASELINE_MASKS)
    return out


def mask(
    name: str = "annealed",
    size: int | None = None,
    seed: int = 0,
    frames: int | None = None,
    channels: int | None = None,
    progress=None,
    max_pixels: int | None = None,
) -> np.ndarray:
    """A rank-normalised mask from a gridded model (bundled name or .onnx path), ``annealed``
    (the default, as in ``dpc mask``) or a baseline (see the module doc). ``size`` (pixels per
    side) defaults to the model's grid (64 for ``annealed``); ``frames``: spatiotemporal masks;
    ``channels``: baselines and ``annealed`` only (a vector model has its own).
    ``progress(done, total)``: reports an ``annealed`` design made on the spot
    (:func:`dpc.mask_design.anneal_mask`).

    Limits, checked before any work (:class:`dpc.errors.LimitError` beyond them): the mask's
    pixels (frames × size² × channels) at most ``max_pixels``. Its default is 65,536 (256 × 256,
    ``dpc.baselines.DEFAULT_MAX_DESIGN_PIXELS``, or $DPC_MAX_DESIGN_PIXELS) for the designs whose
    time grows with the square of the pixels (void-and-cluster, stbn, annealed made on the
    spot), else 2^26 (8192 × 8192, ``DEFAULT_MAX_PIXELS``, or $DPC_MAX_PIXELS); ``math.inf``
    lifts it. Ctrl-C stops every source promptly (KeyboardInterrupt)."""
    s = _args.numpy_seed(seed)
    _bl.pixel_limit(max_pixels)  # a bad max_pixels is said whatever the source
    if not isinstance(name, (str, Path)):
        raise InvalidArgumentError(f"mask name must be a string, got {type(name).__name__}")
    if str(name) in BASELINE_MASKS:
        return _baseline_mask(str(name), size, frames, channels, s, max_pixels)
    if str(name) in DESIGNED_MASKS:
        return _annealed_mask(size, frames, channels, s, progress, max_pixels)
    import dpc

    try:
        model = dpc.load(str(name))
    except ModelNotFoundError:
        raise InvalidArgumentError(
            f"unknown mask {name!r}: not a bundled model, a model file or one of "
            f"{', '.join([*DESIGNED_MASKS, *BASELINE_MASKS])}"
        ) from None
    if not model.grid_axes:
        raise InvalidArgumentError(f"model {name} is not gridded: it has no pixel grid")
    if channels is not None:
        raise InvalidArgumentError("channels applies to baselines; a model has its own")
    return _model_mask(model, size, frames, s, max_pixels)


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


# ---------------------------------------------------------------- files
def quantise(mask_array: np.ndarray, bits: int) -> np.ndarray:
    """The integer codes a PNG of ``bits`` (8 or 16) stores: floor(v · 2^bits), v in [0, 1)."""
    if bits not in (8, 16):
        raise InvalidArgumentError(f"PNG bit depth must be 8 or 16, got {bits}")
    a = np.asarray(mask_array, dtype=np.float64)
    if a.size == 0 or not np.all(np.isfinite(a)) or a.min() < 0 or a.max() >= 1:
        raise InvalidArgumentError("mask values must be finite and in [0, 1)")
    return np.minimum(np.floor(a * (1 << bits)), (1 << bits) - 1).astype(np.uint16 if bits == 16 else np.uint8)


def frame_paths(path, frames: int) -> list[Path]:
    """The files of a spatiotemporal mask written to ``path``: stem_000.ext, stem_001.ext, …"""
    p = Path(path)
    width = max(3, len(str(frames - 1)))
    return [p.with_name(f"{p.stem}_{k:0{width}d}{p.suffix}") for k in range(frames)]


_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_PLANES = {0: 1, 2: 3, 4: 2, 6: 4}  # colour type -> samples per pixel (grey, RGB, grey + alpha, RGBA)


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def _write_png(path: Path, img: np.ndarray, bits: int) -> None:
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


def _read_png(path: Path, channels: int | None, max_pixels=None) -> np.ndarray:
    w, h, bits, colour, interlace = png_header(path)
    if bits not in (8, 16) or colour not in _PNG_PLANES:
        raise InvalidArgumentError(
            f"{path}: {bits}-bit PNG of colour type {colour}; masks are 8 or 16 bits, grey or RGB(A)"
        )
    if interlace:
        raise InvalidArgumentError(f"{path}: an interlaced PNG; save the mask without interlacing")
    _bl.check_pixels(w * h, f"{path} ({w} x {h})", max_pixels)
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
                _write_png(q, img, bits)
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
        return _read_png(p, None, max_pixels)
    if ext == ".exr":
        return _read_exr(p)
    raise InvalidArgumentError(f"mask file must end in {', '.join(MASK_EXTENSIONS)}; got {p.name!r}")
