"""The Model class: a loaded libdpc model (immutable, shareable across threads)."""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np

from . import _args, _core
from .errors import InvalidArgumentError, LimitError, ModelIOError, ModelNotFoundError

#: dpc_isa, dpc_backend, dpc_input of dpc.h, as the binding exports them (the Python API names
#: their members in lower case: "auto", "scalar", "avx2", "avx512"; "auto", "cpu", "vulkan";
#: "auto", "uniform", "stratified").
Isa = _core.Isa
Backend = _core.Backend
Input = _core.Input


def _names(enum) -> dict:
    return {name.lower(): value for name, value in enum.__members__.items()}


_ISA = _names(Isa)
_BACKEND = _names(Backend)
_INPUT = _names(Input)


def _choice(value, enum, names: dict, what: str):
    """The enum member for a name ("avx2") or a member (dpc.Isa.AVX2); InvalidArgumentError else."""
    if isinstance(value, enum):
        return value
    if isinstance(value, str) and value in names:
        return names[value]
    raise InvalidArgumentError(f"{what} must be one of {sorted(names)}, got {value!r}")


_DEFAULTS = _core.load_defaults()

#: Worker threads of a model (``load(threads=)``), of the CLI (``-t``), of a layer call
#: (``dpc.training``) and of training (``[train] threads``): libdpc's default
#: (``dpc_load_options_init``), 1, the calling thread only. 0 means one per CPU.
DEFAULT_THREADS = int(_DEFAULTS["threads"])

#: Largest point count of one set (libdpc's DPC_MAX_POINTS).
MAX_POINTS = int(_core.MAX_POINTS)
#: Default bound on the neighbours per point a model may ask for (``dpc.load(max_neighbours=)``).
DEFAULT_MAX_NEIGHBOURS = float(_core.DEFAULT_MAX_NEIGHBOURS)
#: Default limit on the bytes one call may return (4 GiB); ``max_bytes=`` or the environment
#: variable DPC_MAX_OUTPUT_BYTES raise it.
DEFAULT_MAX_OUTPUT_BYTES = 4 << 30


def _max_bytes(max_bytes) -> float:
    """The byte limit of one call: the argument, else $DPC_MAX_OUTPUT_BYTES, else 4 GiB."""
    if max_bytes is None:
        env = os.environ.get("DPC_MAX_OUTPUT_BYTES", "").strip()
        if not env:
            return float(DEFAULT_MAX_OUTPUT_BYTES)
        try:
            return float(parse_size(env))
        except InvalidArgumentError as e:
            raise InvalidArgumentError(f"DPC_MAX_OUTPUT_BYTES: {e}") from None
    return _args.positive_real(max_bytes, "max_bytes")


def parse_size(text) -> int:
    """Bytes from "4096", "512M", "16G", "1.5T" (powers of 1024)."""
    t = str(text).strip().upper().removesuffix("B").removesuffix("I")
    scale = {"K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}.get(t[-1:], 1)
    num = t[:-1] if t[-1:] in "KMGT" and t else t
    try:
        v = float(num) * scale
    except ValueError:
        raise InvalidArgumentError(f"not a size: {text!r} (e.g. 512M, 16G)") from None
    if not (math.isfinite(v) and v > 0):
        raise InvalidArgumentError(f"a size must be positive: {text!r}")
    return int(v)


def _check_path(path) -> str:
    """A model path or name as a str: str, bytes or os.PathLike, without a NUL (which C would
    silently cut the name at); InvalidArgumentError else."""
    if not isinstance(path, (str, bytes, os.PathLike)):
        raise InvalidArgumentError(
            f"a model is a bundled name (str, see dpc.available_models()) or the path of a .onnx file "
            f"(str or os.PathLike), got {path!r} ({type(path).__name__})"
        )
    s = os.fspath(path)
    if isinstance(s, bytes):
        s = os.fsdecode(s)
    if not isinstance(s, str):
        raise InvalidArgumentError(f"os.fspath({path!r}) gave {type(s).__name__}, not a str")
    if "\x00" in s:
        raise InvalidArgumentError(f"model name or path {s!r} contains a NUL character")
    return s


#: A model name as libdpc's search takes it (dpc_model_find): 1 .. 255 characters of
#: [A-Za-z0-9._-], not starting with '.'.
_NAME = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]{0,254}")


def _search_dirs() -> list[Path]:
    """The folders libdpc's model search reads, in its order: $DPC_MODEL_PATH's (separated by
    ':'), then the package's models folder (dpc_model_dir() of the package's libdpc)."""
    dirs = [Path(p) for p in os.environ.get("DPC_MODEL_PATH", "").split(":") if p]
    bundled = _core.model_dir()  # "" when the package has no models folder
    return dirs + ([Path(bundled)] if bundled else [])


def isa_supported(isa: str) -> bool:
    """Whether this build and CPU run ``isa``'s path ("auto", "scalar", "avx2", "avx512"). Every
    path gives the same bits; they differ in speed only."""
    return _core.isa_supported(_choice(isa, Isa, _ISA, "isa"))


def available_models() -> list[str]:
    """Names :func:`load` finds: every regular file ``NAME.onnx`` with a valid name in the folders
    of ``$DPC_MODEL_PATH`` and the package's models folder (libdpc's search, dpc_model_find)."""
    names = set()
    for d in _search_dirs():
        try:
            entries = list(os.scandir(d))
        except OSError:
            continue
        for e in entries:
            stem = e.name[: -len(".onnx")]
            try:
                regular = e.name.endswith(".onnx") and e.is_file()  # stat only: a FIFO is never opened
            except OSError:
                regular = False
            if regular and _NAME.fullmatch(stem):
                names.add(stem)
    return sorted(names)


def _is_name(s: str) -> bool:
    return bool(_NAME.fullmatch(s)) and not s.endswith(".onnx")


def model_path(name_or_path) -> Path:
    """Resolve a model path or name to a file path: a path (ending in ``.onnx``, or naming
    something that exists and is not a plain model name) is returned as it is; a name
    (``[A-Za-z0-9._-]``, e.g. ``"bnot-2d"``), unless a regular file of that name is in the working
    folder, is looked up by libdpc's search (dpc_model_find: the folders of ``$DPC_MODEL_PATH``,
    then the bundled models; regular files only, never opened while searching).
    :class:`ModelNotFoundError` (listing the bundled names) when there is no such model."""
    s = _check_path(name_or_path)
    if _is_name(s) and not os.path.isfile(s):
        try:
            return Path(_core.find_model(s))
        except ModelIOError:
            pass  # not found: below, with the bundled names
    elif _is_name(s) or s.endswith(".onnx") or os.path.lexists(s):
        return Path(s)  # a path: libdpc's loader reports a missing or non-regular file
    raise ModelNotFoundError(
        f"no model file or bundled model named {s!r}; bundled: {', '.join(available_models()) or '(none)'}"
    )


def uniform(seed: int, m: int, n: int) -> np.ndarray:
    """The input points libdpc filters for ``seed``: (m, n) float32, bit-exact with C's
    ``dpc_uniform`` (docs/model-format.md, "Input points")."""
    m, n, limit = _input_size(m, n, MAX_POINTS * 64)
    return _core.uniform(_args.seed(seed), m, n, limit)


def _input_size(m, n, most: int) -> tuple[int, int, float]:
    """Checked (m, n) of an input-point request and the byte limit (LimitError beyond it)."""
    m = _args.integer(m, "m", 1, most, limit=True)
    n = _args.integer(n, "n", 1, most, limit=True)
    limit = _max_bytes(None)
    if m * n * 4 > limit:
        raise LimitError(
            f"{m} x {n} floats would take {m * n * 4 / 2**30:.3g} GiB, more than the "
            f"limit of {limit / 2**30:.3g} GiB (DPC_MAX_OUTPUT_BYTES raises it)"
        )
    return m, n, limit


def stratified(seed: int, m: int, n: int) -> np.ndarray:
    """The stratified input points for ``seed`` (``input="stratified"``): the same uniform numbers
    placed one point per cell of a g^n grid, g^n <= m, in random order; (m, n) float32, bit-exact
    with C's ``dpc_stratified`` (docs/model-format.md, "Input points")."""
    _args.integer(m, "m", 1, MAX_POINTS, limit=True)
    m, n, limit = _input_size(m, n, MAX_POINTS)
    return _core.stratified(_args.seed(seed), m, n, limit)


def balance(points, radius: int = 3) -> np.ndarray:
    """The output balance of docs/model-format.md §5.1 on any point set in [0, 1)^n: a copy of
    ``points`` (m, n) float32 whose Fourier coefficients at every integer frequency
    0 < |q| <= K vanish, K = min(radius, the largest j with (4 j)^n <= m). A blue-noise set moves
    by about 0.5 % of its mean spacing; its power at those torus-scale frequencies, which smooth
    integrands see most, falls to float32 rounding. What libdpc's generator does after the
    cascade of a model with metadata ``dpc.balance`` (``Model.balance``), bit for bit."""
    x = np.asarray(points)
    if x.ndim != 2 or x.shape[0] < 1 or x.shape[1] < 1:
        raise InvalidArgumentError(f"points must be a non-empty (m, n) array, got shape {x.shape}")
    radius = _args.integer(radius, "radius", 0, 32)
    return _core.balance(np.ascontiguousarray(x, dtype=np.float32), radius)


class Model:
    """A loaded dpc model. Create with :func:`load`."""

    def __init__(
        self,
        path,
        *,
        isa: str = "auto",
        threads: int = DEFAULT_THREADS,
        backend: str = "auto",
        input: str = "auto",
        max_neighbours: float | None = None,
    ):  # noqa: A002
        isa = _choice(isa, Isa, _ISA, "isa")
        backend = _choice(backend, Backend, _BACKEND, "backend")
        input = _choice(input, Input, _INPUT, "input")  # noqa: A001
        threads = _args.threads(threads)
        if max_neighbours is None:
            max_neighbours = DEFAULT_MAX_NEIGHBOURS
        _args.positive_real(max_neighbours, "max_neighbours", " (math.inf: no bound)")
        self.path = Path(_check_path(path))
        self._h = _core.Model(os.fspath(self.path), isa, threads, backend, input, float(max_neighbours))
        info = self._h.info()
        self.dims: int = info["dims"]
        self.n_points: int = info["n_points"]
        self.layers: int = info["layers"]
        self.grid_axes: tuple[int, ...] = tuple(info["grid_axes"])
        self.grid_shape: tuple[int, ...] = tuple(info["grid_shape"])
        self.isa: str = info["isa"].name.lower()
        self.threads: int = info["threads"]
        self.backend: str = info["backend"].name.lower()  # "cpu" or "vulkan": what runs the cascade
        self.device: str = info["device"]  # "cpu", or the Vulkan device's name
        self.input: str = info["input"].name.lower()  # "uniform" or "stratified": what generate() filters
        self.neighbours: float = info["neighbours"]  # neighbours per point it asks for (max_neighbours)
        # the generator's output balance radius (metadata dpc.balance; 0: none): generate()
        # cancels each set's power at the integer frequencies 0 < |q| <= balance (dpc.balance)
        self.balance: int = info["balance"]
        self.metadata: dict[str, str] = dict(self._h.metadata())
        self.name: str = self.metadata.get("dpc.name", self.path.stem)
        # "progressive": generate() returns ordered points, the first n of a set of m being the
        # set of n for n = progressive_base * 2^j <= m, and each level's points in the order that
        # fills the emptiest place first (docs/progressive.md); "set" otherwise
        self.order: str = self.metadata.get("dpc.order", "set")
        self.progressive_base: int | None = (
            int(self.metadata["dpc.progressive_base"]) if self.order == "progressive" else None
        )
        # steps of the prefix relaxation after the levels (metadata dpc.relax; 0: none): every
        # prefix of progressive_base * 2^j points is blue noise of its size, but the first n points
        # are no longer the set of n (docs/model-format.md §6.1)
        self.relax: int = int(self.metadata.get("dpc.relax", "0"))

    def __repr__(self) -> str:
        return (
            f"dpc.Model({self.name!r}, dims={self.dims}, n_points={self.n_points}, "
            f"layers={self.layers}, isa={self.isa!r}, backend={self.backend!r})"
        )

    @staticmethod
    def _count(n_points) -> int:
        if n_points is None:
            return 0
        return _args.integer(n_points, "n_points", 1, MAX_POINTS, limit=True)

    def generate(
        self, seed: int = 0, n_points: int | None = None, *, max_bytes: float | None = None, progress=None
    ) -> np.ndarray:
        """One point set: (n_points or the trained count, dims) float32 in [0, 1).

        ``seed``: an integer in 0 .. 2^64 - 1. ``n_points``: a positive integer up to
        :data:`MAX_POINTS` (floats, strings and bools are refused: :class:`InvalidArgumentError`;
        too large: :class:`LimitError`, a subclass). ``max_bytes``: the largest output allowed
        (default 4 GiB or $DPC_MAX_OUTPUT_BYTES), checked before anything is allocated.
        ``progress(done, total)``: called on this thread while libdpc works (units: layers of
        sets). A large request runs off the calling thread, so Ctrl-C stops it with
        KeyboardInterrupt and no partial result."""
        return self._h.generate(_args.seed(seed), 1, self._count(n_points), False, _max_bytes(max_bytes), progress)

    def generate_batch(
        self, count: int, seed: int = 0, n_points: int | None = None, *, max_bytes: float | None = None, progress=None
    ) -> np.ndarray:
        """``count`` sets, set c from seed ``(seed + c) mod 2^64``: (count, m, dims) float32.
        The total, count x m x dims floats, is checked against ``max_bytes`` before allocation
        (see :meth:`generate`)."""
        count = _args.integer(count, "count", 1, (1 << 63) - 1, limit=True)
        return self._h.generate(_args.seed(seed), count, self._count(n_points), True, _max_bytes(max_bytes), progress)

    def generate_density(
        self, density, n_points: int | None = None, seed: int = 0, *, resolution: int = 512
    ) -> np.ndarray:
        """Blue noise that follows ``density``: (n_points or the trained count, 2) float32 in
        [0, 1)^2 (dpc_generate_density). ``density``: a 2-D array (row r covers y in
        [r/H, (r+1)/H)), a callable ``f(x, y)`` sampled on a ``resolution``-square grid, or an
        image (bright is dense; :func:`dpc.density.as_density` for ``invert`` and ``gamma``).
        A 2-D set model whose layers filter the plane as a whole is needed (bnot-2d, blue-2d,
        ...; others raise :class:`UnsupportedError`). The same bits on every CPU and thread
        count; bad densities raise :class:`InvalidArgumentError` before any work."""
        from .density import as_density

        grid = as_density(density, resolution=resolution)
        return self._h.generate_density(grid, _args.seed(seed), self._count(n_points))

    def filter(self, points) -> np.ndarray:
        """Run the cascade on your own (m, dims) points; returns a new float32 array."""
        pts = np.array(points, dtype=np.float32, order="C", copy=True)
        if pts.ndim != 2 or pts.shape[1] != self.dims:
            raise InvalidArgumentError(f"points must have shape (m, {self.dims}), got {pts.shape}")
        self._h.filter(pts)
        return pts


def load(
    path_or_name,
    *,
    isa: str = "auto",
    threads: int = DEFAULT_THREADS,
    backend: str = "auto",
    input: str = "auto",
    max_neighbours: float | None = None,
) -> Model:  # noqa: A002
    """Load a model file, or a bundled model by name (see :func:`available_models`).

    ``isa``, ``backend`` and ``input`` take names (below) or members of :class:`Isa`,
    :class:`Backend`, :class:`Input` (the enums of dpc.h).
    ``isa``: "auto" (best the CPU supports), "scalar", "avx2" or "avx512". ``threads``: worker threads per
    call (default 1, :data:`DEFAULT_THREADS`: the calling thread only, as in C; 0 = one per CPU);
    the output bits do not depend on it.
    ``backend``: "auto" (a GPU through Vulkan where libdpc has the Vulkan backend and the machine a
    hardware GPU, else the CPU), "cpu", or "vulkan" (any Vulkan device, software drivers included;
    :class:`UnsupportedError` saying why when there is none or the package was built without
    Vulkan). ``model.backend`` tells which one runs, ``model.device`` on what.
    ``input``: "auto" (default: what the model was trained on, its metadata ``dpc.input``, uniform
    without it; of the bundled models bnot-2d-stratified says stratified, the others uniform),
    "uniform", or "stratified" (one point per grid cell, see
    :func:`stratified`): for blue-noise models it keeps the lowest frequencies quiet at large
    point counts, where a local cascade cannot fix uniform input's large-scale density
    fluctuations; patterns that want low-frequency power (pink, green) lose it. ``model.input``
    tells which one runs.
    ``max_neighbours``: bound on the work the file may ask for, the expected neighbours per point
    of any layer (default 4096, :data:`DEFAULT_MAX_NEIGHBOURS`: every bundled model passes;
    ``math.inf``: no bound); a request beyond it raises :class:`LimitError`. For files you do
    not trust. ``model.neighbours`` is the model's own figure.

    Names are looked up by libdpc's model search (dpc_model_find, the one the C API and the
    Mitsuba plugin use): the folders of ``$DPC_MODEL_PATH`` (separated by ``:``), then the
    bundled models, regular files only; a path ending in ``.onnx`` or naming a file is loaded as
    it is (see :func:`model_path`). Neither a name nor a path may contain a NUL character, and
    anything but a str, bytes or os.PathLike raises :class:`InvalidArgumentError`."""
    return Model(
        model_path(path_or_name), isa=isa, threads=threads, backend=backend, input=input, max_neighbours=max_neighbours
    )
