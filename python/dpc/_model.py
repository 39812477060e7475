"""The Model class: a loaded libdpc model (immutable, shareable across threads)."""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

import numpy as np

from . import _core
from .errors import InvalidArgumentError, ModelNotFoundError

_ISA = {"auto": 0, "scalar": 1, "avx2": 2, "avx512": 3}
_ISA_NAME = {v: k for k, v in _ISA.items()}
_BACKEND = {"auto": 0, "cpu": 1, "vulkan": 2}
_BACKEND_NAME = {v: k for k, v in _BACKEND.items()}
_INPUT = {"auto": 0, "uniform": 1, "stratified": 2}
_INPUT_NAME = {v: k for k, v in _INPUT.items()}


def _bundled_dirs() -> list[Path]:
    dirs = []
    env = os.environ.get("DPC_MODEL_PATH")
    if env:
        dirs += [Path(p) for p in env.split(os.pathsep) if p]
    dirs.append(Path(str(resources.files("dpc") / "models")))
    return dirs


def available_models() -> list[str]:
    """Names of the bundled models (files ``NAME.onnx`` in the package's models folder and in
    the folders of ``$DPC_MODEL_PATH``)."""
    names = set()
    for d in _bundled_dirs():
        if d.is_dir():
            names.update(p.stem for p in d.glob("*.onnx"))
    return sorted(names)


def model_path(name_or_path) -> Path:
    """Resolve a file path or a bundled model name to a file path."""
    p = Path(name_or_path)
    if p.suffix == ".onnx" or p.exists():
        return p
    for d in _bundled_dirs():
        cand = d / f"{name_or_path}.onnx"
        if cand.is_file():
            return cand
    raise ModelNotFoundError(
        f"no model file or bundled model named {str(name_or_path)!r}; "
        f"bundled: {', '.join(available_models()) or '(none)'}")


def uniform(seed: int, m: int, n: int) -> np.ndarray:
    """The input points libdpc filters for ``seed``: (m, n) float32, bit-exact with C's
    ``dpc_uniform`` (docs/model-format.md, "Input points")."""
    return _core.uniform(int(seed) % (1 << 64), int(m), int(n))


def stratified(seed: int, m: int, n: int) -> np.ndarray:
    """The stratified input points for ``seed`` (``input="stratified"``): the same uniform numbers
    placed one point per cell of a g^n grid, g^n <= m, in random order; (m, n) float32, bit-exact
    with C's ``dpc_stratified`` (docs/model-format.md, "Input points")."""
    return _core.stratified(int(seed) % (1 << 64), int(m), int(n))


class Model:
    """A loaded dpc model. Create with :func:`load`."""

    def __init__(self, path, *, isa: str = "auto", threads: int = 0, backend: str = "auto",
                 input: str = "auto"):  # noqa: A002  (the C option's name)
        if isa not in _ISA:
            raise InvalidArgumentError(f"isa must be one of {sorted(_ISA)}, got {isa!r}")
        if backend not in _BACKEND:
            raise InvalidArgumentError(f"backend must be one of {sorted(_BACKEND)}, got {backend!r}")
        if input not in _INPUT:
            raise InvalidArgumentError(f"input must be one of {sorted(_INPUT)}, got {input!r}")
        if int(threads) < 0:
            raise InvalidArgumentError("threads must be >= 0 (0 = one per CPU)")
        self.path = Path(path)
        self._h = _core.Model(os.fspath(self.path), _ISA[isa], int(threads), _BACKEND[backend], _INPUT[input])
        info = self._h.info()
        self.dims: int = info["dims"]
        self.n_points: int = info["n_points"]
        self.layers: int = info["layers"]
        self.grid_axes: tuple[int, ...] = tuple(info["grid_axes"])
        self.grid_shape: tuple[int, ...] = tuple(info["grid_shape"])
        self.isa: str = _ISA_NAME[info["isa"]]
        self.threads: int = info["threads"]
        self.backend: str = _BACKEND_NAME[info["backend"]]  # "cpu" or "vulkan": what runs the cascade
        self.device: str = info["device"]  # "cpu", or the Vulkan device's name
        self.input: str = _INPUT_NAME[info["input"]]  # "uniform" or "stratified": what generate() filters
        self.metadata: dict[str, str] = dict(self._h.metadata())
        self.name: str = self.metadata.get("dpc.name", self.path.stem)

    def __repr__(self) -> str:
        return (f"dpc.Model({self.name!r}, dims={self.dims}, n_points={self.n_points}, "
                f"layers={self.layers}, isa={self.isa!r}, backend={self.backend!r})")

    @staticmethod
    def _count(n_points) -> int:
        if n_points is None:
            return 0
        n = int(n_points)
        if n <= 0:
            raise InvalidArgumentError(f"n_points must be positive, got {n_points}")
        return n

    def generate(self, seed: int = 0, n_points: int | None = None) -> np.ndarray:
        """One point set: (n_points or the trained count, dims) float32 in [0, 1)."""
        return self._h.generate(int(seed) % (1 << 64), self._count(n_points))

    def generate_batch(self, count: int, seed: int = 0, n_points: int | None = None) -> np.ndarray:
        """``count`` sets, set c from seed ``seed + c``: (count, m, dims) float32."""
        if int(count) <= 0:
            raise InvalidArgumentError(f"count must be positive, got {count}")
        return self._h.generate_batch(int(seed) % (1 << 64), int(count), self._count(n_points))

    def filter(self, points) -> np.ndarray:
        """Run the cascade on your own (m, dims) points; returns a new float32 array."""
        pts = np.array(points, dtype=np.float32, order="C", copy=True)
        if pts.ndim != 2 or pts.shape[1] != self.dims:
            raise InvalidArgumentError(f"points must have shape (m, {self.dims}), got {pts.shape}")
        self._h.filter(pts)
        return pts


def load(path_or_name, *, isa: str = "auto", threads: int = 0, backend: str = "auto",
         input: str = "auto") -> Model:  # noqa: A002
    """Load a model file, or a bundled model by name (see :func:`available_models`).

    ``isa``: "auto" (best the CPU supports), "scalar", "avx2" or "avx512". ``threads``: worker threads per
    call, 0 = one per CPU; the output bits do not depend on it.
    ``backend``: "auto" (a GPU through Vulkan where libdpc has the Vulkan backend and the machine a
    hardware GPU, else the CPU), "cpu", or "vulkan" (any Vulkan device, software drivers included;
    :class:`UnsupportedError` saying why when there is none or the package was built without
    Vulkan). ``model.backend`` tells which one runs, ``model.device`` on what.
    ``input``: "auto" (default: what the model was trained on, its metadata ``dpc.input``;
    uniform for the bundled models), "uniform", or "stratified" (one point per grid cell, see
    :func:`stratified`): for blue-noise models it keeps the lowest frequencies quiet at large
    point counts, where a local cascade cannot fix uniform input's large-scale density
    fluctuations; patterns that want low-frequency power (pink, green) lose it. ``model.input``
    tells which one runs."""
    return Model(model_path(path_or_name), isa=isa, threads=threads, backend=backend, input=input)
