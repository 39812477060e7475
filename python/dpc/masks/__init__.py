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
* ``annealed``: masks designed by dpc's spectral annealing (:mod:`dpc.masks.design`, also
  ``dpc.mask_design``), scalar or spatiotemporal (``frames``) or vector (``channels=2``, blue per
  channel and jointly). Sizes and seeds in :data:`dpc.masks.design.BUNDLED` load from the
  package; others are designed on the spot (about 11 s for 64 × 64, 3 minutes at 128 × 128).
* baselines from :mod:`dpc.masks.baselines` (also in ``dpc.baselines``): ``void-and-cluster``
  (Ulichney 1993; with ``channels=2`` two independent masks, with ``frames=T`` T independent
  masks), ``stbn`` (scalar spatiotemporal blue noise after Wolfe et al. 2022; needs ``frames``),
  ``white``, ``bayer``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import _args
from ..errors import DpcError, InvalidArgumentError, ModelNotFoundError
from . import baselines as _bl
from . import design
from .files import EXR_EXTRA, MASK_EXTENSIONS, check_mask_path, frame_paths, kind_of, read_mask, write_mask
from .png import open_regular, quantise

BASELINE_MASKS = {
    "void-and-cluster": "Ulichney's void-and-cluster (1993), sigma 1.5, toroidal; channels=2: two "
    "independent masks; frames=T: T independent masks",
    "stbn": "scalar spatiotemporal blue noise (Wolfe et al. 2022): void-and-cluster over (T, N, N) "
    "with a spatial and a temporal Gaussian energy, sigma 1.9; needs frames",
    "white": "white noise, rank-normalised (any shape)",
    "bayer": "Bayer ordered-dither matrix (N a power of two)",
}
DESIGNED_MASKS = {
    "annealed": "dpc's spectral annealing (dpc.masks.design): below void-and-cluster at 48, 64, 128 (not 32); "
    "frames=T: blue in space and time; channels=2: blue per channel and jointly; default 64 x 64",
}


def rank_normalise(a: np.ndarray, kind: str) -> np.ndarray:
    """(rank + ½)/S per threshold map: the whole array (scalar), per channel (vector, last
    axis) or per frame (spatiotemporal, first axis)."""
    from ..analysis.dither import rank_normalise as rn

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
    from ..model_file import read_model
    from ..training import layer_forward

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
    # frames and channels are checked by design.mask (a combination it has no bundle for
    # reaches anneal_mask, which refuses it)
    n = 64 if size is None else _args.size(size, "size", 8)
    t = None if frames is None else _args.size(frames, "frames", 1)
    return design.mask(n, t, seed, channels, progress=progress, max_pixels=max_pixels)


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
    (:func:`dpc.masks.design.anneal_mask`).

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


__all__ = [
    "mask",
    "available",
    "kind_of",
    "mask_kind",
    "rank_normalise",
    "write_mask",
    "read_mask",
    "check_mask_path",
    "quantise",
    "frame_paths",
    "open_regular",
    "MASK_EXTENSIONS",
    "EXR_EXTRA",
    "BASELINE_MASKS",
    "DESIGNED_MASKS",
    "baselines",
    "design",
]
