"""Export a trained cascade: the dpc model file (custom PointFilter nodes, built by
dpc.model_file) and an optional plain-ONNX variant (standard operators only, dense
all pairs per layer) that runs unchanged in stock onnxruntime."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from dpc import model_file

from .filter import mask_dims


def model_spec_from_checkpoint(st: dict, quality: dict | None = None, name: str | None = None):
    """A dpc.model_file.ModelSpec for a checkpoint dict (tables as trained, float32)."""
    from .trainer import cascade_from_checkpoint

    mf = model_file
    model, cfg = cascade_from_checkpoint(st)
    sp = model.spec
    tables = model.tables().detach().cpu().numpy().astype(np.float32)
    layers = [
        mf.Layer(subspaces=list(sp.masks), radius=list(sp.radius), kernels=tables[i], eps=sp.eps, fixed=sp.fixed)
        for i in range(sp.layers)
    ]
    quality = quality if quality is not None else st.get("quality", {})
    meta = {
        "dpc.loss": st.get("loss_source", ""),
        "dpc.config": json.dumps(st["config"], sort_keys=True),
        "dpc.train.steps": str(st["step"]),
        "dpc.train.wall_time_s": f"{float(st['wall_time']):.1f}",
        "dpc.train.torch": st.get("torch_version", ""),
        "dpc.quality": json.dumps(quality, sort_keys=True),
        "dpc.input": sp.input,  # the input points it was trained on: load it with that input
    }
    if sp.balance:  # the generator's last step (format §5.1)
        meta["dpc.balance"] = str(sp.balance)
    if sp.order == "progressive":  # libdpc generates it level by level (format §6)
        meta["dpc.order"] = "progressive"
        meta["dpc.progressive_base"] = str(sp.progressive_base)
    return mf.ModelSpec(
        dims=sp.dims,
        n_points=sp.n_points,
        layers=layers,
        grid_axes=list(sp.grid_axes),
        grid_shape=list(sp.grid_shape),
        name=name or cfg.pattern.name,
        description=cfg.pattern.description,
        metadata=meta,
    )


# ----------------------------------------------------------------------------------------
# Plain-ONNX export (standard operators only)
# ----------------------------------------------------------------------------------------


def build_standard_onnx(spec, ir_version: int = 8, opset: int = 17, batched: bool = False):
    """ModelProto computing the same cascade with standard ONNX operators (dense all pairs:
    O(m²) memory per layer). Input `points`: [m, n] float32, or [batch, m, n] with batched=True
    (ONNX graph inputs have a fixed rank). m is read from the input shape at run time, so the
    scale-aware radius follows the actual point count as in libdpc."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    n = spec.dims
    nodes, inits = [], []
    counter = [0]

    def const(value, dtype=np.float32):
        counter[0] += 1
        name = f"c{counter[0]}"
        inits.append(numpy_helper.from_array(np.asarray(value, dtype=dtype), name))
        return name

    def node(op, inputs, **attrs):
        counter[0] += 1
        out = f"t{counter[0]}"
        nodes.append(helper.make_node(op, inputs, [out], **attrs))
        return out

    half, one, zero = const(0.5), const(1.0), const(0.0)
    ax_last = const([-1], np.int64)
    ax_m3, ax_m2 = const([-3], np.int64), const([-2], np.int64)
    x = "points"
    for li, layer in enumerate(spec.layers):
        kern = np.asarray(layer.kernels, dtype=np.float32)
        b = kern.shape[1]
        count = np.zeros(n)
        for mask in layer.subspaces:
            count[mask_dims(mask, n)] += 1
        total = None
        for t, (mask, rho) in enumerate(zip(layer.subspaces, layer.radius)):
            dims = mask_dims(mask, n)
            k = len(dims)
            # spec.n_points is only a default: h_t must follow the actual m, so derive it from
            # the input shape at run time
            shape = node("Shape", [x])
            m_i = node("Gather", [shape, const(-2, np.int64)], axis=0)
            m_f = node("Cast", [m_i], to=TensorProto.FLOAT)
            h = node("Pow", [m_f, const(-1.0 / k)])
            r = node("Min", [node("Mul", [h, const(float(rho))]), half])
            e = node("Mul", [h, const(float(layer.eps))])
            xs = node("Gather", [x, const(dims, np.int64)], axis=-1)  # [.., m, k]
            xj = node("Unsqueeze", [xs, ax_m3])  # [.., 1, m, k]
            xi = node("Unsqueeze", [xs, ax_m2])  # [.., m, 1, k]
            diff = node("Sub", [xj, xi])  # x_j − x_i
            delta = node("Sub", [diff, node("Floor", [node("Add", [diff, half])])])
            d = node("Sqrt", [node("ReduceSum", [node("Mul", [delta, delta]), ax_last], keepdims=0)])  # [.., m, m]
            inside = node("And", [node("Greater", [d, e]), node("Less", [d, r])])
            dsafe = node("Where", [inside, d, one])
            u = node("Div", [node("Mul", [dsafe, const(float(b - 1))]), r])
            qf = node("Min", [node("Floor", [u]), const(float(b - 2))])
            f = node("Sub", [u, qf])
            qi = node("Cast", [qf], to=TensorProto.INT64)
            w = const(kern[t])
            w0 = node("Gather", [w, qi], axis=0)
            w1 = node("Gather", [w, node("Add", [qi, const(1, np.int64)])], axis=0)
            g = node("Add", [w0, node("Mul", [f, node("Sub", [w1, w0])])])
            coef = node("Where", [inside, node("Div", [node("Mul", [g, h]), dsafe]), zero])
            contrib = node("Mul", [node("Unsqueeze", [coef, ax_last]), delta])  # [.., m, m, k]
            acc = node("ReduceSum", [contrib, ax_m2], keepdims=0)  # [.., m, k]
            # scatter the k subspace dims into n dims, divided by c_k, fixed dims zeroed
            sel = np.zeros((k, n), dtype=np.float32)
            for a, dim in enumerate(dims):
                if not (layer.fixed >> dim) & 1:
                    sel[a, dim] = 1.0 / count[dim]
            part = node("MatMul", [acc, const(sel)])
            total = part if total is None else node("Add", [total, part])
        y = node("Add", [x, total])
        y = node("Sub", [y, node("Floor", [y])])
        ge1 = node("GreaterOrEqual", [y, one])
        x = node("Where", [ge1, zero, y])
        if li == len(spec.layers) - 1:
            nodes[-1].output[0] = "points_out"
            x = "points_out"
    shape = ["batch", "m", n] if batched else ["m", n]
    inp = helper.make_tensor_value_info("points", TensorProto.FLOAT, shape)
    out = helper.make_tensor_value_info("points_out", TensorProto.FLOAT, shape)
    graph = helper.make_graph(nodes, (spec.name or "dpc") + "_standard_ops", [inp], [out], inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", opset)], producer_name="dpc-train")
    model.ir_version = ir_version
    helper.set_model_props(model, {**spec.all_metadata(), "dpc.variant": "standard-ops"})
    onnx.checker.check_model(model)
    return model


def export(
    checkpoint,
    out,
    standard_ops: str | None = None,
    name: str | None = None,
    measure: bool = True,
    batched: bool = False,
) -> dict:
    """Write the dpc model file (and optionally the plain-ONNX variant); returns a summary."""
    from .lossprog import build_loss
    from .trainer import cascade_from_checkpoint, load_checkpoint, measure_quality

    st = load_checkpoint(checkpoint)
    quality = st.get("quality")
    if quality is None and measure:
        model, cfg = cascade_from_checkpoint(st)
        loss_fn, _ = build_loss(cfg.loss, cfg.pattern.points, cfg.pattern.dims, cfg.base_dir())
        quality = measure_quality(model, loss_fn, cfg)
    spec = model_spec_from_checkpoint(st, quality or {}, name)
    if standard_ops and spec.metadata.get("dpc.order") == "progressive":
        # standard ONNX has no way to hold earlier levels' points in place (format §6)
        raise ValueError("a progressive model has no standard-ops variant: export it without --standard-ops")
    # Both files are built in memory first, then each written atomically (temporary file in
    # its folder, fsync, rename): a failure leaves any existing file as it was, and no half file.
    data = model_file.build_onnx(spec).SerializeToString()
    std = build_standard_onnx(spec, batched=batched).SerializeToString() if standard_ops else None
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    from .trainer import atomic_write_bytes

    existed = Path(out).exists()
    atomic_write_bytes(Path(out), data)
    summary = {"model": str(out), "layers": len(spec.layers), "steps": st["step"], "quality": quality}
    if std is not None:
        try:
            Path(standard_ops).parent.mkdir(parents=True, exist_ok=True)
            atomic_write_bytes(Path(standard_ops), std)
        except BaseException:
            if not existed:  # the command failed: remove what it created
                Path(out).unlink(missing_ok=True)
            raise
        summary["standard_ops"] = str(standard_ops)
    return summary
