#!/usr/bin/env python3
"""Write the small test models of tests/data from analytic kernel tables.

    PYTHONPATH=python python3 tests/data/make_models.py            # rewrites tests/data/*.onnx

The files are committed, so the C tests need no Python. Every table is a closed-form function
(repulsion core, attraction ring, a small deterministic wiggle so that neighbouring bins differ,
and a taper that makes the last bin 0), so re-running the script reproduces the same bytes.
Points move by a noticeable fraction of the mean spacing in every layer, so the parity tests
compare a real cascade, not an identity.

variants/ holds the same models encoded differently but equivalently (float_data, packed or
unpacked repeated fields, reversed field order, batch shape, defaults left out, unknown parts),
listed in variants/manifest.tsv: the reader must accept each and give the base model's points.

Models (docs/model-format.md):
  model_2d.onnx        2-D, one subspace xy, 4 layers, 1024 points
  model_3d_proj.onnx   3-D, subspaces xy, xz, yz (every dimension shared by two), 3 layers
  model_3d_mixed.onnx  3-D, full space xyz + 1-D subspace x (normalised sum), 3 layers
  model_grid_3to1.onnx 3-D, x and y gridded 32x32 (fixed), value z, 3 layers, 1024 points
  model_10d.onnx       10-D, five 2-D pairs, two 1-D, one 3-D and the full space, 3 layers
  model_2d_progressive.onnx  model_2d's layers as a progressive model (dpc.order, base 16: §6)
  model_2d_balanced.onnx     model_2d's layers with the output balance (dpc.balance = 3: §5.1)
  model_2d_progressive_balanced.onnx  model_2d_progressive, each level balanced (dpc.balance = 8)
  model_2d_progressive_relaxed.onnx  model_2d_progressive, then its prefixes relaxed (dpc.relax = 400: §6.1)

The metadata entries are stored with the optional keys first and the required keys last
(dpc.n_points is the very last field of the file), so that every proper prefix of a file lacks a
required entry or ends inside a length-delimited field: tests/c checks that the reader rejects
every truncation.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent


def _load_model_file():
    """python/dpc/model_file.py by path: `import dpc` would need the compiled extension."""
    spec = importlib.util.spec_from_file_location("dpc_model_file", ROOT / "python" / "dpc" / "model_file.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up by name
    spec.loader.exec_module(mod)
    return mod


mf = _load_model_file()
Layer, ModelSpec, subspace_mask = mf.Layer, mf.ModelSpec, mf.subspace_mask

REQUIRED_LAST = ["dpc.format_version", "dpc.grid_axes", "dpc.grid_shape", "dpc.dims", "dpc.n_points"]


def kernel(
    b: int,
    rho: float,
    *,
    rep: float,
    rep_w: float,
    att: float = 0.0,
    att_c: float = 1.5,
    att_w: float = 0.4,
    wiggle: float = 0.0,
    phase: float = 0.0,
) -> np.ndarray:
    """Kernel table w[q] = f(q * rho / (b - 1)); f takes the distance in units of the spacing.

    Negative values repel, positive attract (docs/model-format.md §3): a repulsion of peak
    strength ``rep`` at distance ``rep_w``, an attraction ring of strength ``att`` around
    ``att_c`` and a small wiggle. f(0) = 0 and f(rho) = 0, so a pair crossing the cut-off
    ``eps * h`` or the receptive radius changes the result only by a tiny amount; float32 (libdpc)
    and float64 (the reference) then agree closely even for pairs right at those thresholds."""
    s = np.linspace(0.0, rho, b)
    a = s / rep_w
    f = -rep * a * np.exp(0.5 - 0.5 * a * a)
    inner = 1.0 - np.exp(-((s / 0.3) ** 2))
    f += inner * att * np.exp(-(((s - att_c) / att_w) ** 2))
    f += inner * wiggle * np.sin(2.3 * s + phase)
    f *= (1.0 - (s / rho) ** 2) ** 2
    return f.astype(np.float32)


def model_2d() -> ModelSpec:
    xy = subspace_mask("xy")
    layers = [
        Layer([xy], [3.0], kernel(32, 3.0, rep=0.20, rep_w=0.9, att=0.03, att_c=1.6, wiggle=0.01)[None]),
        Layer(
            [xy],
            [2.5],
            kernel(48, 2.5, rep=0.15, rep_w=0.8, att=0.02, att_c=1.3, wiggle=0.008, phase=1.0)[None],
            eps=0.02,
        ),
        Layer([xy], [4.0], kernel(64, 4.0, rep=0.12, rep_w=1.0, att=0.025, att_c=1.9, wiggle=0.005, phase=2.0)[None]),
        Layer(
            [xy],
            [3.5],
            kernel(16, 3.5, rep=0.10, rep_w=1.1, att=0.02, att_c=1.7, wiggle=0.006, phase=0.5)[None],
            eps=0.0,
        ),
    ]
    return ModelSpec(
        dims=2,
        n_points=1024,
        layers=layers,
        name="test-2d",
        description="Test model: 2-D repulsion/attraction cascade, one subspace.",
        metadata={"dpc.loss": "none (analytic test kernels)", "test.kernels": "tests/data/make_models.py"},
    )


def model_3d_proj() -> ModelSpec:
    subs = [subspace_mask(s) for s in ("xy", "xz", "yz")]
    layers = []
    for li, (b, base_rho, eps) in enumerate([(32, 3.0, 1e-4), (24, 2.5, 0.03), (40, 4.0, 1e-4)]):
        rhos = [base_rho, base_rho + 0.5, base_rho + 1.0]
        kern = np.stack(
            [
                kernel(
                    b,
                    rhos[t],
                    rep=0.30 - 0.05 * t,
                    rep_w=0.9 + 0.1 * t,
                    att=0.02,
                    att_c=1.4 + 0.2 * t,
                    wiggle=0.006,
                    phase=li + 0.7 * t,
                )
                for t in range(3)
            ]
        )
        layers.append(Layer(subs, rhos, kern, eps=eps))
    return ModelSpec(
        dims=3,
        n_points=1024,
        layers=layers,
        name="test-3d-proj",
        description="Test model: 3-D, 2-D projections xy, xz, yz.",
    )


def model_3d_mixed() -> ModelSpec:
    subs = [subspace_mask("xyz"), subspace_mask("x")]
    specs = [(32, 2.5, 5.0, 1e-4), (48, 3.0, 4.0, 0.002), (20, 2.8, 6.0, 1e-4)]
    layers = []
    for li, (b, rho3, rho1, eps) in enumerate(specs):
        kern = np.stack(
            [
                kernel(b, rho3, rep=0.12, rep_w=0.9, att=0.015, att_c=1.5, wiggle=0.004, phase=li),
                kernel(b, rho1, rep=0.25, rep_w=1.0, att=0.03, att_c=2.0, wiggle=0.01, phase=li + 2.0),
            ]
        )
        layers.append(Layer(subs, [rho3, rho1], kern, eps=eps))
    return ModelSpec(
        dims=3,
        n_points=1024,
        layers=layers,
        name="test-3d-mixed",
        description="Test model: 3-D full space plus the 1-D subspace x.",
    )


def model_grid_3to1() -> ModelSpec:
    subs = [subspace_mask("z"), subspace_mask("xz"), subspace_mask("yz"), subspace_mask("xyz")]
    fixed = subspace_mask("xy")
    layers = []
    for li, (b, eps) in enumerate([(32, 1e-4), (40, 0.0), (24, 1e-4)]):
        rhos = [5.0, 3.0, 3.0, 2.5]
        amps = [0.25, 0.14, 0.14, 0.10]
        kern = np.stack(
            [
                kernel(b, rhos[t], rep=amps[t], rep_w=1.0, att=0.02, att_c=1.8, wiggle=0.006, phase=li + t)
                for t in range(4)
            ]
        )
        layers.append(Layer(subs, rhos, kern, eps=eps, fixed=fixed))
    return ModelSpec(
        dims=3,
        n_points=1024,
        layers=layers,
        grid_axes=[0, 1],
        grid_shape=[32, 32],
        name="test-grid-3to1",
        description="Test model: x, y on a 32x32 grid, one value dimension z.",
    )


def model_10d() -> ModelSpec:
    pairs = [subspace_mask([2 * p, 2 * p + 1]) for p in range(5)]
    subs = pairs + [subspace_mask([0]), subspace_mask([5]), subspace_mask([2, 5, 8]), subspace_mask(list(range(10)))]
    # rho per subspace; the full 10-D space has h = 1024^(-1/10) = 0.5, so rho 0.9 -> r = 0.45.
    rhos = [3.0, 2.5, 3.5, 3.0, 2.8, 5.0, 4.0, 2.5, 0.9]
    layers = []
    for li, (b, eps) in enumerate([(24, 1e-4), (32, 0.002), (16, 1e-4)]):
        rows = []
        for t, rho in enumerate(rhos):
            if t == len(rhos) - 1:  # full space: distances are ~0.5-0.9 h; gentle repulsion
                rows.append(kernel(b, rho, rep=0.3, rep_w=0.6, wiggle=0.01, phase=li))
            else:
                rows.append(
                    kernel(
                        b,
                        rho,
                        rep=0.25 + 0.02 * (t % 3),
                        rep_w=0.9,
                        att=0.02,
                        att_c=1.5,
                        wiggle=0.006,
                        phase=li + 0.5 * t,
                    )
                )
        layers.append(Layer(list(subs), list(rhos), np.stack(rows), eps=eps))
    return ModelSpec(
        dims=10,
        n_points=1024,
        layers=layers,
        name="test-10d",
        description="Test model: 10-D, pairs, 1-D, 3-D and full-space subspaces.",
    )


def variant(base: ModelSpec, name: str, description: str, **metadata: str) -> ModelSpec:
    """base's cascade under another name, with more metadata (same layers, same points)."""
    base.name, base.description = name, description
    base.metadata.update(metadata)
    return base


def model_2d_progressive() -> ModelSpec:
    return variant(
        model_2d(),
        "test-2d-progressive",
        "Test model: model_2d's cascade, generated level by level (format §6).",
        **{"dpc.order": "progressive", "dpc.progressive_base": "16"},
    )


def model_2d_balanced() -> ModelSpec:
    return variant(
        model_2d(),
        "test-2d-balanced",
        "Test model: model_2d's cascade, its output balanced at 0 < |q| <= 3 (format §5.1).",
        **{"dpc.balance": "3"},
    )


def model_2d_progressive_balanced() -> ModelSpec:
    return variant(
        model_2d_progressive(),
        "test-2d-progressive-balanced",
        "Test model: model_2d_progressive, each level's points balancing its prefix (format §5.1).",
        **{"dpc.balance": "8"},
    )


def model_2d_progressive_relaxed() -> ModelSpec:
    return variant(
        model_2d_progressive(),
        "test-2d-progressive-relaxed",
        "Test model: model_2d_progressive, then every prefix relaxed jointly (format §6.1, 400 steps).",
        **{"dpc.relax": "400"},
    )


MODELS = {
    "model_2d.onnx": model_2d,
    "model_2d_progressive.onnx": model_2d_progressive,
    "model_2d_balanced.onnx": model_2d_balanced,
    "model_2d_progressive_balanced.onnx": model_2d_progressive_balanced,
    "model_2d_progressive_relaxed.onnx": model_2d_progressive_relaxed,
    "model_3d_proj.onnx": model_3d_proj,
    "model_3d_mixed.onnx": model_3d_mixed,
    "model_grid_3to1.onnx": model_grid_3to1,
    "model_10d.onnx": model_10d,
}


def build(spec: ModelSpec):
    """mf.build_onnx, then the metadata reordered so that the required keys come last."""
    proto = mf.build_onnx(spec)
    entries = [(p.key, p.value) for p in proto.metadata_props]
    rank = {k: i for i, k in enumerate(REQUIRED_LAST)}
    entries.sort(key=lambda kv: rank.get(kv[0], -1))  # stable: optional keys keep their order
    del proto.metadata_props[:]
    for k, v in entries:
        e = proto.metadata_props.add()
        e.key, e.value = k, v
    return proto


def _variants(out: Path) -> list[tuple[str, str, str, bytes]]:
    """Files that encode a base model differently but equivalently: the reader must accept each
    one and produce exactly the base model's points. (name, base, why, bytes)."""

    import onnx
    import pbwire as pb
    from onnx import helper

    def load(name):
        return onnx.load(str(out / name))

    def kernels_to_float_data(m):
        for t in m.graph.initializer:
            w = onnx.numpy_helper.to_array(t)
            t.ClearField("raw_data")
            t.float_data.extend(w.reshape(-1).tolist())
        return m

    v = []
    m = kernels_to_float_data(load("model_2d.onnx"))
    v.append(("float_data", "model_2d.onnx", "kernels in float_data (packed) instead of raw_data", pb.encode(m)))
    v.append(
        (
            "float_data_unpacked",
            "model_2d.onnx",
            "kernels in float_data with one fixed32 field per value",
            pb.encode(m, packed="none"),
        )
    )
    m = kernels_to_float_data(load("model_3d_proj.onnx"))
    v.append(
        (
            "packed_repeated",
            "model_3d_proj.onnx",
            "every repeated scalar packed (attribute ints/floats, tensor dims)",
            pb.encode(m, packed="all"),
        )
    )
    v.append(
        (
            "fields_reversed",
            "model_3d_mixed.onnx",
            "every message's fields written in decreasing field-number order",
            pb.encode(load("model_3d_mixed.onnx"), reverse=True),
        )
    )
    m = load("model_2d.onnx")
    for vi in (m.graph.input[0], m.graph.output[0]):
        dims = vi.type.tensor_type.shape.dim
        dims.insert(0, onnx.TensorShapeProto.Dimension(dim_param="batch"))
    v.append(("batch_shape", "model_2d.onnx", "graph input/output declared [batch, m, n]", m.SerializeToString()))
    m = load("model_10d.onnx")
    for node in m.graph.node:
        eps = [a for a in node.attribute if a.name == "eps"]
        if eps and eps[0].f == np.float32(1e-4):
            node.attribute.remove(eps[0])  # the default
        node.attribute.append(helper.make_attribute("fixed", 0))
        node.attribute.append(helper.make_attribute("future_attr", [1.5, 2.5]))
        node.doc_string = "a PointFilter"
    m.graph.initializer.append(onnx.numpy_helper.from_array(np.ones((3, 3), np.float32), "unused"))
    e = m.metadata_props.add()
    e.key, e.value = "vendor.note", "unknown keys are kept"
    m.producer_version = "9.9"
    m.doc_string = "variant with optional and unknown parts"
    v.append(
        (
            "extras_and_defaults",
            "model_10d.onnx",
            "eps 1e-4 left to its default, fixed=0, unknown attribute/initializer/metadata",
            m.SerializeToString(),
        )
    )
    m = load("model_grid_3to1.onnx")
    m.ir_version = 3
    keep = [o for o in m.opset_import if o.domain == "ai.dpc"]
    del m.opset_import[:]
    m.opset_import.extend(keep)
    v.append(
        (
            "ir3_dpc_opset_only",
            "model_grid_3to1.onnx",
            "ir_version 3 and no default-domain opset",
            m.SerializeToString(),
        )
    )
    m = load("model_2d.onnx")
    m.ir_version = 13
    nested = b""
    for _ in range(3000):
        nested = pb.field_len(1, nested)
    v.append(
        (
            "ir13_unknown_deep_field",
            "model_2d.onnx",
            "ir_version 13 and an unknown top-level field 99 nesting 3000 levels deep (skipped without recursing)",
            m.SerializeToString() + pb.field_len(99, nested),
        )
    )
    return v


def main() -> None:
    import onnx

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=HERE, help="output folder (default: tests/data)")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name, make in MODELS.items():
        proto = build(make())
        onnx.checker.check_model(proto)
        path = args.out / name
        onnx.save_model(proto, str(path))
        print(f"{path}: {path.stat().st_size} bytes")
    vdir = args.out / "variants"
    vdir.mkdir(exist_ok=True)
    lines = ["# file\tbase model (same points)\thow it differs"]
    for name, base, why, data in _variants(args.out):
        (vdir / f"{name}.onnx").write_bytes(data)
        lines.append(f"{name}.onnx\t{base}\t{why}")
    (vdir / "manifest.tsv").write_text("\n".join(lines) + "\n")
    print(f"{vdir}: {len(lines) - 1} variants")


if __name__ == "__main__":
    main()
