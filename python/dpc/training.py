"""One PointFilter layer in float64, forward and backward: libdpc's training kernels
(``dpc_layer_forward_ex`` / ``dpc_layer_backward_ex``, declared in dpc/dpc_layer.h).

The public home of the layer ops a training framework needs (the ``dpc_train`` package's
``impl="c"`` filter and ``dpc.masks`` use them):

    >>> import numpy as np, dpc.training as T
    >>> x = np.random.default_rng(0).random((1024, 2))
    >>> w = np.zeros((1, 32))                                  # one subspace, 32 bins
    >>> y = T.layer_forward(x, w, subspaces=[0b11], radius=[4.0], eps=1e-4)
    >>> gx, gw = T.layer_backward(x, w, [0b11], [4.0], 1e-4, grad_y=np.ones_like(x))

Points are float64 ``(m, n)`` or ``(batch, m, n)`` in [0, 1); kernels ``(s, b)`` (values in
units of each subspace's mean spacing); subspaces are s bitmasks, radius s values rho_t (in
mean spacings), eps the cutoff (in spacings), fixed a bitmask of dimensions that never move.
Results are bit-identical for every thread count; ``isa`` picks the pair loop ("auto": the path
the inference engine would take, i.e. $DPC_ISA, else the best the CPU has); paths differ by
rounding only. Errors are dpc's typed exceptions.
"""

from __future__ import annotations

import numpy as np

from . import _args, _core
from ._model import _ISA, DEFAULT_THREADS, Isa, _choice
from .errors import InvalidArgumentError

__all__ = ["layer_forward", "layer_backward"]


def _isa(isa):
    return _choice(isa, Isa, _ISA, "isa")


def _array(a, name: str) -> np.ndarray:
    try:
        return np.ascontiguousarray(a, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InvalidArgumentError(f"{name} must be an array of numbers: {e}") from None


def _layer_args(x, kernels, subspaces, radius, eps, fixed) -> tuple:
    """The layer's arguments as _core takes them (both directions)."""
    return (
        _array(x, "x"),
        _array(kernels, "kernels"),
        list(subspaces),
        [float(r) for r in radius],
        float(eps),
        fixed,
    )


def _run_args(threads, isa) -> tuple:
    return _args.threads(threads), _isa(isa)


def layer_forward(
    x,
    kernels,
    subspaces,
    radius,
    eps: float = 0.0,
    fixed: int = 0,
    *,
    threads: int = DEFAULT_THREADS,
    isa: str = "auto",
) -> np.ndarray:
    """y = layer(x): a new float64 array of x's shape."""
    return _core.layer_forward(*_layer_args(x, kernels, subspaces, radius, eps, fixed), *_run_args(threads, isa))


def layer_backward(
    x,
    kernels,
    subspaces,
    radius,
    eps: float = 0.0,
    fixed: int = 0,
    *,
    grad_y,
    threads: int = DEFAULT_THREADS,
    isa: str = "auto",
) -> tuple[np.ndarray, np.ndarray]:
    """Gradients of a scalar loss L from grad_y = dL/dy: (dL/dx like x, dL/dkernels (s, b),
    summed over the sets of a batch)."""
    return _core.layer_backward(
        *_layer_args(x, kernels, subspaces, radius, eps, fixed), _array(grad_y, "grad_y"), *_run_args(threads, isa)
    )
