"""dpc: point patterns from Deep Point Correlation Design.

    >>> import dpc
    >>> model = dpc.load("repulsion-2d")          # a bundled model, or a path to a .onnx file
    >>> pts = model.generate(seed=0)               # (m, n) float32 in [0, 1)
    >>> sets = model.generate_batch(16, seed=0)    # (16, m, n)

Arrays follow scipy.stats.qmc: C-contiguous ``(m, n)`` points in [0, 1), batches ``(sets, m, n)``.
"""

from . import (
    density,  # densities for Model.generate_density (arrays, functions, images), docs/density.md
    importance,  # importance sampling a 2-D density with dpc's sets: points and their pdf
    masks,  # blue-noise threshold masks (and their designer, dpc.masks.design), docs/masks.md
    stratify,  # progressive sequences: (0,2)-stratification, joint relaxation; docs/progressive.md
    training,  # the float64 layer ops (dpc_layer_forward / _backward)
)
from ._core import __version__  # version of the linked libdpc (dpc.h; = the distribution's version)
from ._model import (
    DEFAULT_MAX_NEIGHBOURS,
    DEFAULT_MAX_OUTPUT_BYTES,
    DEFAULT_THREADS,
    MAX_POINTS,
    Backend,
    Input,
    Isa,
    Model,
    available_models,
    balance,
    isa_supported,
    load,
    model_path,
    stratified,
    uniform,
)
from ._sampler import Sampler
from .errors import (
    CancelledError,
    DpcError,
    InternalError,
    InvalidArgumentError,
    LimitError,
    ModelFormatError,
    ModelIOError,
    ModelNotFoundError,
    OutOfMemoryError,
    UnsupportedError,
)
from .masks import design as mask_design  # the annealed masks' designer, by its earlier name
from .masks import mask

__all__ = [
    "Model",
    "load",
    "uniform",
    "stratified",
    "balance",
    "available_models",
    "model_path",
    "Sampler",
    "isa_supported",
    "DpcError",
    "InvalidArgumentError",
    "ModelIOError",
    "ModelFormatError",
    "UnsupportedError",
    "OutOfMemoryError",
    "LimitError",
    "InternalError",
    "ModelNotFoundError",
    "CancelledError",
    "MAX_POINTS",
    "DEFAULT_MAX_NEIGHBOURS",
    "DEFAULT_MAX_OUTPUT_BYTES",
    "DEFAULT_THREADS",
    "Isa",
    "Backend",
    "Input",
    "training",
    "density",
    "importance",
    "mask_design",
    "masks",
    "stratify",
    "mask",
    "__version__",
]
