"""Write and read dpc model files (ONNX, docs/model-format.md) with the ``onnx`` package.

This is the one writer of the format: the test-model script, the training exporter and the
bundled-model scripts all go through :func:`write_model`. ``onnx`` is imported lazily so that
``import dpc`` works without it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

DOMAIN = "ai.dpc"
FORMAT_VERSION = 1
IR_VERSION = 8
DEFAULT_OPSET = 17


class ModelFileError(ValueError):
    """A model description or file that does not follow docs/model-format.md."""


@dataclass
class Layer:
    """One PointFilter node: kernels[t, q] for subspace t (bitmask subspaces[t])."""

    subspaces: list[int]
    radius: list[float]
    kernels: np.ndarray  # float32 [s, b]
    eps: float = 1e-4
    fixed: int = 0

    def __post_init__(self) -> None:
        self.kernels = np.ascontiguousarray(self.kernels, dtype=np.float32)
        self.subspaces = [int(s) for s in self.subspaces]
        self.radius = [float(r) for r in self.radius]
        if self.kernels.ndim != 2 or self.kernels.shape[0] != len(self.subspaces):
            raise ModelFileError("kernels must be [s, b] with s = len(subspaces)")
        if len(self.radius) != len(self.subspaces):
            raise ModelFileError("radius must have one entry per subspace")


@dataclass
class ModelSpec:
    """A whole cascade plus its metadata."""

    dims: int
    n_points: int
    layers: list[Layer]
    grid_axes: list[int] = field(default_factory=list)
    grid_shape: list[int] = field(default_factory=list)
    name: str = ""
    description: str = ""
    metadata: dict[str, str] = field(default_factory=dict)

    def all_metadata(self) -> dict[str, str]:
        meta = {
            "dpc.format_version": str(FORMAT_VERSION),
            "dpc.dims": str(self.dims),
            "dpc.n_points": str(self.n_points),
        }
        if self.grid_axes:
            meta["dpc.grid_axes"] = ",".join(str(a) for a in self.grid_axes)
            meta["dpc.grid_shape"] = ",".join(str(g) for g in self.grid_shape)
        if self.name:
            meta["dpc.name"] = self.name
        if self.description:
            meta["dpc.description"] = self.description
        meta.update({str(k): str(v) for k, v in self.metadata.items()})
        return meta


def subspace_mask(dims: str | list[int]) -> int:
    """Bitmask of a swizzle ("xz") or a list of dimension indices ([0, 2])."""
    if isinstance(dims, str):
        letters = "xyzwabcdefghijklmnopqrstuv"
        idx = [letters.index(c) for c in dims]
    else:
        idx = list(dims)
    mask = 0
    for k in idx:
        mask |= 1 << int(k)
    return mask


def build_onnx(spec: ModelSpec):
    """Return the onnx.ModelProto for spec (checked with onnx.checker)."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    if not spec.layers:
        raise ModelFileError("a model needs at least one layer")
    nodes, inits = [], []
    prev = "points"
    for k, layer in enumerate(spec.layers):
        out = "points_out" if k == len(spec.layers) - 1 else f"x{k + 1}"
        kname = f"kernels_{k}"
        inits.append(numpy_helper.from_array(layer.kernels.astype(np.float32), kname))
        attrs = dict(subspaces=layer.subspaces, radius=layer.radius, eps=float(layer.eps))
        if layer.fixed:
            attrs["fixed"] = int(layer.fixed)
        nodes.append(helper.make_node("PointFilter", [prev, kname], [out], name=f"filter_{k}", domain=DOMAIN, **attrs))
        prev = out
    x_in = helper.make_tensor_value_info("points", TensorProto.FLOAT, ["m", spec.dims])
    x_out = helper.make_tensor_value_info("points_out", TensorProto.FLOAT, ["m", spec.dims])
    graph = helper.make_graph(nodes, spec.name or "dpc_cascade", [x_in], [x_out], inits)
    model = helper.make_model(
        graph,
        opset_imports=[helper.make_opsetid("", DEFAULT_OPSET), helper.make_opsetid(DOMAIN, FORMAT_VERSION)],
        producer_name="dpc",
    )
    model.ir_version = IR_VERSION
    helper.set_model_props(model, spec.all_metadata())
    onnx.checker.check_model(model)
    return model


def write_model(spec: ModelSpec, path) -> None:
    """Write spec to path as a dpc model file."""
    import onnx

    onnx.save_model(build_onnx(spec), str(path))


def read_model(path) -> ModelSpec:
    """Read a dpc model file written by any conforming writer (Python side, needs onnx)."""
    import onnx
    from onnx import numpy_helper

    from .errors import ModelIOError
    from .pointio import open_regular

    with open_regular(path, "rb", ModelIOError) as fh:  # a FIFO or folder: refused, never read
        model = onnx.load_model_from_string(fh.read())
    meta = {p.key: p.value for p in model.metadata_props}
    inits = {t.name: numpy_helper.to_array(t) for t in model.graph.initializer}
    layers = []
    for node in model.graph.node:
        if node.domain != DOMAIN or node.op_type != "PointFilter":
            raise ModelFileError(f"unexpected node {node.domain}:{node.op_type}")
        attrs = {a.name: onnx.helper.get_attribute_value(a) for a in node.attribute}
        layers.append(
            Layer(
                subspaces=list(attrs["subspaces"]),
                radius=list(attrs["radius"]),
                kernels=inits[node.input[1]],
                eps=float(attrs.get("eps", 1e-4)),
                fixed=int(attrs.get("fixed", 0)),
            )
        )
    axes = [int(a) for a in meta.get("dpc.grid_axes", "").split(",") if a]
    shape = [int(g) for g in meta.get("dpc.grid_shape", "").split(",") if g]
    reserved = {
        "dpc.format_version",
        "dpc.dims",
        "dpc.n_points",
        "dpc.grid_axes",
        "dpc.grid_shape",
        "dpc.name",
        "dpc.description",
    }
    return ModelSpec(
        dims=int(meta["dpc.dims"]),
        n_points=int(meta["dpc.n_points"]),
        layers=layers,
        grid_axes=axes,
        grid_shape=shape,
        name=meta.get("dpc.name", ""),
        description=meta.get("dpc.description", ""),
        metadata={k: v for k, v in meta.items() if k not in reserved},
    )
