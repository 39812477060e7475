"""dpc.Sampler: sample values for (pixel, sample index, dimension), over libdpc's dpc_sampler."""

from __future__ import annotations

import math
import os

import numpy as np

from . import _args, _core
from ._model import Model, _max_bytes, load
from .errors import InvalidArgumentError, LimitError

DEFAULT_MODEL = "bnot-2d-stratified"
MAX_SPP = int(_core.SAMPLER_MAX_SPP)  # DPC_SAMPLER_MAX_SPP
MAX_DIMENSIONS = int(_core.SAMPLER_MAX_DIMENSIONS)  # DPC_SAMPLER_MAX_DIMENSIONS
NO_FOLD = int(_core.SAMPLER_NO_FOLD)  # DPC_SAMPLER_NO_FOLD
NET_DIMS_AUTO = int(_core.SAMPLER_NET_DIMS_AUTO)  # DPC_SAMPLER_NET_DIMS_AUTO
AUTO_NETS_SPP = int(_core.SAMPLER_AUTO_NETS_SPP)  # DPC_SAMPLER_AUTO_NETS_SPP
SCREEN_NETS_BELOW = int(_core.SAMPLER_SCREEN_NETS_BELOW)  # DPC_SAMPLER_SCREEN_NETS_BELOW
# net_layout: DPC_SAMPLER_NETS_AUTO, _SCREEN, _PER_PIXEL
_LAYOUTS = {
    "auto": int(_core.SAMPLER_NETS_AUTO),
    "screen": int(_core.SAMPLER_NETS_SCREEN),
    "pixel": int(_core.SAMPLER_NETS_PER_PIXEL),
}
#: Lookups are evaluated this many at a time: beyond the output, a lookup holds O(chunk) memory
#: whatever the broadcast shape of its arguments.
LOOKUP_CHUNK = 1 << 16


def _uint32_array(value, name: str, *, wrap: bool) -> np.ndarray:
    """Integers as uint32: pixels wrap modulo 2^32 (negative ones tile seamlessly); indices and
    dimensions must lie in 0 .. 2^32 - 1."""
    a = np.asarray(value)
    if a.dtype.kind not in "iu":
        raise InvalidArgumentError(f"{name} must hold integers, got dtype {a.dtype}")
    if wrap:
        return (a.astype(np.int64) % (1 << 32)).astype(np.uint32)
    if a.size and (a.min() < 0 or a.max() > 0xFFFFFFFF):
        raise InvalidArgumentError(f"{name} must lie in 0 .. 2^32 - 1")
    return a.astype(np.uint32)


class Sampler:
    """Sample values for a renderer: dimension slot ``d`` of pixel ``(x, y)``, sample ``index``.

    Each of the ``dimensions`` slots holds one dpc point set of ``samples_per_pixel`` points
    (made once on libdpc's CPU backend, so every machine gets the same values); each pixel
    reads it rotated and toroidally shifted by its entry of a 32 x 32 screen-space mask (moved
    per 32 x 32 tile, so tiles do not repeat each other), so neighbouring pixels'
    errors cancel at low screen frequencies. Dimensions from ``fold_from``
    on (1: all but dimension 0, the pixel position) are folded by the baker's transform
    ``1 - |2v - 1|``, which makes smooth integrands periodic over the shifted table; the default
    ``None`` folds none; net slots are never folded. Slots below ``net_dims`` hold blue-noise
    (0,m,2)-nets, each pixel's a digital shift of its own, when ``samples_per_pixel`` is a power
    of two >= 2: every elementary interval of a pixel's samples holds one, which integrates
    geometry edges nearly along the pixel axes like a Sobol' net; 0 for none. The default,
    ``"auto"``, is every slot for set models (there nets beat the sets, folded or not, on a
    renderer's per-pixel error; the sets serve 1 spp and the other counts) and 1 (the pixel
    position) for progressive models;
    ``net_slots`` says how many slots are nets. ``net_layout`` says how nets are randomised across
    pixels: ``"screen"``, one Owen-scrambled Sobol' sequence per 32 x 32 tile, each pixel the
    block at its randomised Morton code, so neighbouring pixels' samples together form finer
    nets and the error is blue across pixels; ``"pixel"``, one optimised net per slot, digitally
    shifted per pixel (white error); ``"auto"`` (default), screen below 64 samples per pixel.
    ``frames`` (real-time use: ``samples_per_pixel`` samples per frame, ``frames`` frames averaged,
    e.g. by temporal accumulation): the tables hold ``samples_per_pixel * frames`` points read in
    order, so that each frame's error is blue across pixels and a pixel's frames together are one
    blue-noise set; pass ``frame=f`` to the lookups (the same as ``index + f * samples_per_pixel``).
    docs/rendering.md defines every step. Values are float32 in [0, 1); the same C object backs
    the C API, the Mitsuba plugin and this class, so all three give the same bits.

    The tables are made off the calling thread: Ctrl-C raises KeyboardInterrupt at once (a large
    progressive-2d-relaxed table takes minutes), and ``progress(done, total)``, if given, is
    called on this thread with the sets made so far (an exception from it stops the creation).
    ``models``: a :class:`Model`, a model name or ``.onnx`` path, or a list or tuple of them.
    Lookups broadcast their arguments like numpy's, evaluated in chunks (memory beyond the
    output stays small), and refuse an output beyond ``max_bytes`` (default 4 GiB, or
    $DPC_MAX_OUTPUT_BYTES) with :class:`LimitError` before any work.

    >>> s = dpc.Sampler("bnot-2d-stratified", samples_per_pixel=16)
    >>> s.get_2d(x=np.arange(640)[None, :], y=np.arange(480)[:, None], index=0, dimension=0).shape
    (480, 640, 2)
    """

    def __init__(
        self,
        models=DEFAULT_MODEL,
        samples_per_pixel: int = 16,
        dimensions: int = 16,
        seed: int = 0,
        fold_from: int | None = None,
        net_dims: int | str = "auto",
        net_layout: str = "auto",
        *,
        frames: int = 1,
        progress=None,
    ):
        if isinstance(models, (str, bytes, Model, os.PathLike)):
            models = [models]
        elif isinstance(models, (list, tuple)):
            models = list(models)
        else:
            raise InvalidArgumentError(
                "models must be a dpc.Model, a model name or .onnx path (str or os.PathLike), or a list "
                f"or tuple of them, got {models!r} ({type(models).__name__})"
            )
        if not models:
            raise InvalidArgumentError("models must name at least one model")
        self.models: list[Model] = [m if isinstance(m, Model) else load(m) for m in models]
        self.samples_per_pixel = _args.integer(samples_per_pixel, "samples_per_pixel", 1, MAX_SPP)
        self.dimensions = _args.integer(dimensions, "dimensions", 1, MAX_DIMENSIONS)
        self.seed = _args.seed(seed)
        self.fold_from = None if fold_from is None else _args.integer(fold_from, "fold_from", 0, NO_FOLD - 1)
        if isinstance(net_dims, str) and net_dims == "auto":
            self.net_dims = "auto"
        elif isinstance(net_dims, str):
            raise InvalidArgumentError(f'net_dims must be an integer or "auto", got {net_dims!r}')
        else:
            self.net_dims = _args.integer(net_dims, "net_dims", 0, NET_DIMS_AUTO - 1)
        if not isinstance(net_layout, str) or net_layout not in _LAYOUTS:
            raise InvalidArgumentError(f'net_layout must be "auto", "screen" or "pixel", got {net_layout!r}')
        self.net_layout = net_layout
        self.frames = _args.integer(frames, "frames", 1, MAX_SPP // self.samples_per_pixel)
        self._h = _core.Sampler(
            [m._h for m in self.models],
            self.samples_per_pixel,
            self.dimensions,
            self.seed,
            NO_FOLD if self.fold_from is None else self.fold_from,
            NET_DIMS_AUTO if self.net_dims == "auto" else self.net_dims,
            _LAYOUTS[net_layout],
            self.frames,
            progress,
        )

    def __repr__(self) -> str:
        names = ", ".join(m.name for m in self.models)
        return (
            f"dpc.Sampler([{names}], samples_per_pixel={self.samples_per_pixel}, "
            f"dimensions={self.dimensions}, seed={self.seed}, fold_from={self.fold_from}, net_dims={self.net_dims!r}, "
            f"net_layout={self.net_layout!r}, frames={self.frames})"
        )

    def _lookup(self, x, y, index, dimension, width: int, max_bytes, frame=0) -> np.ndarray:
        if not (isinstance(frame, (int, np.integer)) and frame == 0):
            # index + frame * spp, in int64 so that an index past 2^32 - 1 is refused, not wrapped
            index = np.asarray(_uint32_array(index, "index", wrap=False), dtype=np.int64) + np.asarray(
                _uint32_array(frame, "frame", wrap=False), dtype=np.int64
            ) * np.int64(self.samples_per_pixel)
        args = (
            _uint32_array(x, "x", wrap=True),
            _uint32_array(y, "y", wrap=True),
            _uint32_array(index, "index", wrap=False),
            _uint32_array(dimension, "dimension", wrap=False),
        )
        try:
            shape = np.broadcast_shapes(*(a.shape for a in args))
        except ValueError:
            raise InvalidArgumentError(
                f"x, y, index and dimension do not broadcast together: shapes {[a.shape for a in args]}"
            ) from None
        limit = _max_bytes(max_bytes)
        size = math.prod(shape)
        if size * width * 4 > limit:
            raise LimitError(
                f"the lookup's output, {'x'.join(map(str, shape))} x {width} float32, would take "
                f"{size * width * 4 / 2**30:.3g} GiB, more than the limit of {limit / 2**30:.3g} GiB: pass "
                "max_bytes= (or set DPC_MAX_OUTPUT_BYTES) to raise it, or look up in parts"
            )
        out = np.empty(shape + ((2,) if width == 2 else ()), dtype=np.float32)
        # the output seen as one element per lookup (a 2-D value as one complex64)
        target = out.view(np.complex64)[..., 0] if width == 2 else out
        # LOOKUP_CHUNK lookups at a time: the broadcast arguments are never made full size
        it = np.nditer(
            [*args, target],
            flags=["external_loop", "buffered", "zerosize_ok"],
            op_flags=[["readonly"]] * 4 + [["writeonly"]],
            buffersize=LOOKUP_CHUNK,
            order="C",
        )
        with it:
            for xs, ys, i_s, ds, o in it:
                values = self._h.get(*(np.ascontiguousarray(a) for a in (xs, ys, i_s, ds)), width)
                o[...] = values.view(np.complex64)[:, 0] if width == 2 else values
        return out

    def get_1d(self, x, y, index, dimension, *, frame=0, max_bytes: float | None = None) -> np.ndarray:
        """Values in [0, 1), one per stratum of width 1/spp, placed so that a pixel's values shifted
        by 0, 1/4, 1/2, 3/4 (hero-wavelength sampling) fill 4 spp strata once each (docs/rendering.md,
        "Definition"); arguments broadcast like numpy's (the
        broadcast is evaluated in chunks, never made full size). ``frame``: sample ``index`` of that
        frame, ``index + frame * samples_per_pixel`` (see ``frames``). ``max_bytes``: the largest
        output allowed (default 4 GiB or $DPC_MAX_OUTPUT_BYTES), else :class:`LimitError` before any
        work."""
        return self._lookup(x, y, index, dimension, 1, max_bytes, frame)

    def get_2d(self, x, y, index, dimension, *, frame=0, max_bytes: float | None = None) -> np.ndarray:
        """Points in [0, 1)^2 from the model's set: shape ``broadcast shape + (2,)`` (``frame`` and
        ``max_bytes`` as in :meth:`get_1d`)."""
        return self._lookup(x, y, index, dimension, 2, max_bytes, frame)

    @property
    def net_slots(self) -> int:
        """How many slots (the first ones) hold nets: ``net_dims`` resolved by libdpc
        (``dpc_sampler_get_info``)."""
        return int(self._h.info()["net_slots"])

    @property
    def net_layout_resolved(self) -> str:
        """How the net slots are laid out across pixels, ``net_layout`` resolved by libdpc:
        ``"screen"`` or ``"pixel"`` (``"pixel"`` also when there are no net slots)."""
        return "screen" if self._h.info()["net_layout"] == _core.SAMPLER_NETS_SCREEN else "pixel"

    def table(self, t: int) -> np.ndarray:
        """The (samples_per_pixel * frames, 2) point set of table ``t`` (0 <= t < dimensions)."""
        return self._h.table(_args.integer(t, "t", 0, self.dimensions - 1))

    @staticmethod
    def mask() -> np.ndarray:
        """The shared 32 x 32 screen-space mask: (32, 32, 3) float32, [y, x] = (2-D shift, 1-D offset)."""
        return _core.sampler_mask()
