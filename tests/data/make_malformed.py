#!/usr/bin/env python3
"""Write hand-made malformed model files to tests/data/malformed/ (committed; the C tests read
them without Python).

    python3 tests/data/make_malformed.py          # after make_models.py

Each file breaks one rule of docs/model-format.md, either by editing the onnx protos of a valid
test model (wrong tensor types, missing attributes, bad metadata, broken chains, unknown operator
version, ...) or by byte surgery on the protobuf wire format (lengths pointing past the end,
overlong varints, huge lengths, deep nesting, ...). malformed/manifest.tsv lists, per file, the
status(es) the reader must return and why; where the spec allows two codes (e.g. a limit that
is a FORMAT or a LIMIT error) both are listed, separated by '|'.
"""

from __future__ import annotations

import copy
import random
from pathlib import Path

import numpy as np
import onnx
import pbwire as pb
from onnx import AttributeProto, TensorProto, helper

HERE = Path(__file__).resolve().parent
MODELS = HERE  # where the valid models are read from (--models)

FORMAT = "DPC_ERROR_FORMAT"
UNSUPPORTED = "DPC_ERROR_UNSUPPORTED"
LIMIT = "DPC_ERROR_LIMIT"

CASES: list[tuple[str, str, str, bytes]] = []  # (name, expected, why, bytes)


def base(name: str) -> onnx.ModelProto:
    return onnx.load(str(MODELS / f"{name}.onnx"))


def case(name: str, expected: str, why: str, data) -> None:
    if isinstance(data, onnx.ModelProto):
        data = data.SerializeToString(deterministic=True)
    assert all(n != name for n, *_ in CASES), name
    assert "\t" not in why and "\n" not in why
    CASES.append((name, expected, why, bytes(data)))


def attr(node, name):
    for a in node.attribute:
        if a.name == name:
            return a
    raise KeyError(name)


def drop_attr(node, name):
    keep = [a for a in node.attribute if a.name != name]
    del node.attribute[:]
    node.attribute.extend(keep)


def set_meta(model, key, value):
    for p in model.metadata_props:
        if p.key == key:
            if value is None:
                model.metadata_props.remove(p)
            else:
                p.value = value
            return
    if value is not None:
        e = model.metadata_props.add()
        e.key, e.value = key, value


def init(model, name):
    for t in model.graph.initializer:
        if t.name == name:
            return t
    raise KeyError(name)


def kernel_array(model, k=0) -> np.ndarray:
    return onnx.numpy_helper.to_array(init(model, model.graph.node[k].input[1]))


def replace_kernels(model, k, tensor):
    name = model.graph.node[k].input[1]
    t = init(model, name)
    t.CopyFrom(tensor)
    t.name = name


def set_shape(value_info, dims):
    shape = value_info.type.tensor_type.shape
    del shape.dim[:]
    for d in dims:
        dim = shape.dim.add()
        if isinstance(d, str):
            dim.dim_param = d
        else:
            dim.dim_value = d


# ------------------------------------------------------------------------------------------------
# Kernel tensors
# ------------------------------------------------------------------------------------------------


def tensor_cases():
    m = base("model_2d")
    w = kernel_array(m, 0)
    t = copy.deepcopy(m)
    replace_kernels(t, 0, onnx.numpy_helper.from_array(w.astype(np.float64)))
    case("kernels_double", FORMAT, "kernels initializer is DOUBLE, must be FLOAT", t)
    t = copy.deepcopy(m)
    replace_kernels(t, 0, onnx.numpy_helper.from_array((w * 1000).astype(np.int32)))
    case("kernels_int32", FORMAT, "kernels initializer is INT32, must be FLOAT", t)
    t = copy.deepcopy(m)
    replace_kernels(t, 0, onnx.numpy_helper.from_array(w.astype(np.float16)))
    case("kernels_float16", FORMAT, "kernels initializer is FLOAT16 (2 bytes per value)", t)

    t = copy.deepcopy(m)
    replace_kernels(t, 0, onnx.numpy_helper.from_array(np.vstack([w, w])))
    case("kernels_rows_mismatch", FORMAT, "kernels has 2 rows for 1 subspace", t)
    t = copy.deepcopy(m)
    replace_kernels(t, 0, onnx.numpy_helper.from_array(w.reshape(1, 1, -1)))
    case("kernels_rank3", FORMAT, "kernels has rank 3, must be [s, b]", t)
    t = copy.deepcopy(m)
    replace_kernels(t, 0, onnx.numpy_helper.from_array(w.reshape(-1)))
    case("kernels_rank1", FORMAT, "kernels has rank 1, must be [s, b]", t)
    t = copy.deepcopy(m)
    replace_kernels(t, 0, onnx.numpy_helper.from_array(w[:, :1].copy()))
    case("kernels_one_bin", FORMAT, "kernels has b = 1 bin, must be >= 2", t)
    t = copy.deepcopy(m)
    big = np.zeros((1, 65537), np.float32)
    replace_kernels(t, 0, onnx.numpy_helper.from_array(big))
    case("kernels_65537_bins", FORMAT, "kernels has b = 65537 bins, at most 65536", t)

    t = copy.deepcopy(m)
    tt = init(t, t.graph.node[0].input[1])
    tt.raw_data = tt.raw_data[:-4]
    case("kernels_raw_short", FORMAT, "raw_data holds one float less than dims say", t)
    t = copy.deepcopy(m)
    tt = init(t, t.graph.node[0].input[1])
    tt.raw_data = tt.raw_data + b"\0\0\0\0"
    case("kernels_raw_long", FORMAT, "raw_data holds one float more than dims say", t)
    t = copy.deepcopy(m)
    tt = init(t, t.graph.node[0].input[1])
    tt.raw_data = b""
    case("kernels_no_data", FORMAT, "kernels tensor has dims but neither raw_data nor float_data", t)
    t = copy.deepcopy(m)
    tt = init(t, t.graph.node[0].input[1])
    tt.ClearField("raw_data")
    tt.float_data.extend([float(v) for v in w.reshape(-1)[:-1]])
    case("kernels_float_data_short", FORMAT, "float_data holds one value less than dims say", t)

    for label, bad in (("nan", np.nan), ("inf", np.inf), ("neg_inf", -np.inf)):
        t = copy.deepcopy(m)
        w2 = w.copy()
        w2[0, 5] = bad
        replace_kernels(t, 0, onnx.numpy_helper.from_array(w2))
        case(f"kernel_{label}", FORMAT, f"a kernel value is {label} (raw_data)", t)
    t = copy.deepcopy(m)
    w2 = kernel_array(m, 2).copy()
    w2[0, -1] = np.nan
    tt = helper.make_tensor("k", TensorProto.FLOAT, w2.shape, w2.reshape(-1).tolist())
    replace_kernels(t, 2, tt)
    case("kernel_nan_float_data", FORMAT, "layer 2: a kernel value is NaN (float_data)", t)

    t = copy.deepcopy(m)
    t.graph.node[1].input[1] = "no_such_initializer"
    case("kernels_not_initializer", FORMAT, "node 1 kernels input names no initializer", t)


# ------------------------------------------------------------------------------------------------
# PointFilter attributes
# ------------------------------------------------------------------------------------------------


def attribute_cases():
    m = base("model_2d")
    t = copy.deepcopy(m)
    drop_attr(t.graph.node[1], "subspaces")
    case("missing_subspaces", FORMAT, "node 1 has no 'subspaces' attribute", t)
    t = copy.deepcopy(m)
    drop_attr(t.graph.node[0], "radius")
    case("missing_radius", FORMAT, "node 0 has no 'radius' attribute", t)
    t = copy.deepcopy(m)
    drop_attr(t.graph.node[0], "subspaces")
    t.graph.node[0].attribute.append(helper.make_attribute("subspaces", [3.0]))
    case("subspaces_as_floats", FORMAT, "'subspaces' is FLOATS, must be INTS", t)
    t = copy.deepcopy(m)
    drop_attr(t.graph.node[0], "radius")
    t.graph.node[0].attribute.append(helper.make_attribute("radius", [3]))
    case("radius_as_ints", FORMAT, "'radius' is INTS, must be FLOATS", t)
    t = copy.deepcopy(m)
    drop_attr(t.graph.node[0], "eps")
    t.graph.node[0].attribute.append(helper.make_attribute("eps", "0.1"))
    case("eps_as_string", FORMAT, "'eps' is a STRING, must be FLOAT", t)
    t = copy.deepcopy(m)
    drop_attr(t.graph.node[0], "subspaces")
    t.graph.node[0].attribute.append(helper.make_attribute("subspaces", [], attr_type=AttributeProto.INTS))
    case("subspaces_empty", FORMAT, "'subspaces' has no entries (s = 0)", t)
    t = copy.deepcopy(m)
    attr(t.graph.node[0], "radius").floats.append(3.0)
    case("radius_count_mismatch", FORMAT, "two radii for one subspace", t)

    for label, value in (
        ("zero", 0.0),
        ("negative", -2.0),
        ("nan", float("nan")),
        ("inf", float("inf")),
        ("above_1e6", 2e6),
    ):
        t = copy.deepcopy(m)
        attr(t.graph.node[1], "radius").floats[0] = value
        case(f"radius_{label}", FORMAT, f"radius is {value}, must be in (0, 1e6] and finite", t)
    for label, value in (("negative", -0.01), ("nan", float("nan")), ("inf", float("inf"))):
        t = copy.deepcopy(m)
        attr(t.graph.node[1], "eps").f = value
        case(f"eps_{label}", FORMAT, f"eps is {value}, must be finite and >= 0", t)

    t = copy.deepcopy(m)
    attr(t.graph.node[0], "subspaces").ints[0] = 0
    case("subspace_zero", FORMAT, "subspace bitmask 0 (empty subspace)", t)
    t = copy.deepcopy(m)
    attr(t.graph.node[0], "subspaces").ints[0] = 0b111
    case("subspace_bit_ge_n", FORMAT, "subspace mask 0b111 names dimension 2 of a 2-D model", t)
    t = copy.deepcopy(m)
    attr(t.graph.node[0], "subspaces").ints[0] = -(1 << 63) | 3
    case("subspace_bit63", FORMAT, "subspace mask has bit 63 set in a 2-D model", t)
    p = base("model_3d_proj")
    attr(p.graph.node[1], "subspaces").ints[2] = attr(p.graph.node[1], "subspaces").ints[0]
    case("subspaces_duplicate", FORMAT, "3-D model: one layer lists subspace xy twice", p)
    t = base("model_2d")
    t.graph.node[2].attribute.append(helper.make_attribute("fixed", 0b100))
    case("fixed_bit_ge_n", FORMAT, "'fixed' names dimension 2 of a 2-D model", t)

    # 65 distinct subspaces in the 10-D model (at most 64 per node)
    t = base("model_10d")
    node = t.graph.node[0]
    masks = list(range(1, 66))
    drop_attr(node, "subspaces")
    drop_attr(node, "radius")
    node.attribute.append(helper.make_attribute("subspaces", masks))
    node.attribute.append(helper.make_attribute("radius", [2.0] * 65))
    replace_kernels(t, 0, onnx.numpy_helper.from_array(np.zeros((65, 2), np.float32)))
    case("subspaces_65", FORMAT, "10-D model: a node with 65 subspaces (at most 64)", t)


# ------------------------------------------------------------------------------------------------
# Metadata
# ------------------------------------------------------------------------------------------------


def metadata_cases():
    m = base("model_2d")
    for key in ("dpc.format_version", "dpc.dims", "dpc.n_points"):
        t = copy.deepcopy(m)
        set_meta(t, key, None)
        case(f"missing_{key.split('.')[1]}", FORMAT, f"required metadata '{key}' is absent", t)
    t = copy.deepcopy(m)
    set_meta(t, "dpc.format_version", "2")
    case("format_version_2", f"{UNSUPPORTED}|{FORMAT}", "metadata dpc.format_version is '2'", t)

    for label, value in (
        ("0", "0"),
        ("2pow26_plus1", str((1 << 26) + 1)),
        ("huge", "99999999999999999999999999"),
        ("negative", "-1024"),
        ("not_number", "1024x"),
        ("empty", ""),
        ("hex", "0x400"),
    ):
        t = copy.deepcopy(m)
        set_meta(t, "dpc.n_points", value)
        case(f"n_points_{label}", FORMAT, f"dpc.n_points is '{value}', must be 1..2^26", t)

    for label, n in (("0", 0), ("65", 65)):
        t = copy.deepcopy(m)
        set_meta(t, "dpc.dims", str(n))
        set_shape(t.graph.input[0], ["m", n])
        set_shape(t.graph.output[0], ["m", n])
        case(f"dims_{label}", FORMAT, f"dpc.dims = {n} with a matching [m, {n}] input; n must be 1..64", t)
    t = copy.deepcopy(m)
    set_meta(t, "dpc.dims", "3")
    case("dims_mismatch_shape", FORMAT, "dpc.dims is 3, the graph input is [m, 2]", t)
    t = copy.deepcopy(m)
    set_shape(t.graph.input[0], ["m", "n"])
    set_shape(t.graph.output[0], ["m", "n"])
    case("dims_symbolic", FORMAT, "the input's point dimension is symbolic, must be fixed", t)

    g = base("model_grid_3to1")
    for label, axes, shape, why in (
        ("grid_product_mismatch", "0,1", "32,33", "grid 32x33 = 1056 cells, dpc.n_points 1024"),
        ("grid_axes_out_of_range", "0,3", "32,32", "grid axis 3 in a 3-D model"),
        ("grid_axes_not_increasing", "1,0", "32,32", "grid axes must increase"),
        ("grid_axes_duplicate", "0,0", "32,32", "grid axis 0 listed twice"),
        ("grid_shape_count_mismatch", "0,1", "1024", "two grid axes, one grid_shape entry"),
        ("grid_shape_zero", "0,1", "0,32", "a grid_shape entry is 0"),
        ("grid_axes_without_shape", "0,1", None, "dpc.grid_axes without dpc.grid_shape"),
    ):
        t = copy.deepcopy(g)
        set_meta(t, "dpc.grid_axes", axes)
        set_meta(t, "dpc.grid_shape", shape)
        case(label, FORMAT, why, t)
    t = copy.deepcopy(g)
    set_meta(t, "dpc.grid_axes", None)
    case("grid_shape_without_axes", FORMAT, "dpc.grid_shape without dpc.grid_axes", t)
    t = copy.deepcopy(g)
    drop_attr(t.graph.node[1], "fixed")
    case("grid_fixed_missing", FORMAT, "gridded model: layer 1 has no 'fixed' attribute", t)
    t = copy.deepcopy(g)
    attr(t.graph.node[2], "fixed").i = 0b111
    case("grid_fixed_extra_dim", FORMAT, "gridded model: layer 2 also fixes the value dim z", t)

    t = copy.deepcopy(m)
    set_meta(t, "x" * 4097, "too long a key")
    case("metadata_key_4097", f"{FORMAT}|{LIMIT}", "a metadata key of 4097 bytes (<= 4 KiB)", t)
    t = copy.deepcopy(m)
    for i in range(1025 - len(t.metadata_props)):
        set_meta(t, f"extra.{i}", "v")
    assert len(t.metadata_props) == 1025
    case("metadata_1025_entries", f"{FORMAT}|{LIMIT}", f"{len(t.metadata_props)} metadata entries (at most 1024)", t)


# ------------------------------------------------------------------------------------------------
# Model, opsets and graph structure
# ------------------------------------------------------------------------------------------------


def set_opset(model, domain, version):
    for o in model.opset_import:
        if o.domain == domain:
            if version is None:
                model.opset_import.remove(o)
            else:
                o.version = version
            return
    raise KeyError(domain)


def graph_cases():
    m = base("model_2d")
    t = copy.deepcopy(m)
    set_opset(t, "ai.dpc", 2)
    case("opset_dpc_v2", UNSUPPORTED, "ai.dpc opset version 2 (this reader reads 1)", t)
    t = copy.deepcopy(m)
    set_opset(t, "ai.dpc", 0)
    case("opset_dpc_v0", UNSUPPORTED, "ai.dpc opset version 0", t)
    t = copy.deepcopy(m)
    set_opset(t, "ai.dpc", None)
    case("opset_dpc_missing", FORMAT, "opset_import lacks the ai.dpc domain", t)
    for label, v in (("2", 2), ("14", 14)):
        t = copy.deepcopy(m)
        t.ir_version = v
        case(f"ir_version_{label}", f"{FORMAT}|{UNSUPPORTED}", f"ir_version {v}, must be 3..13", t)
    t = copy.deepcopy(m)
    t.ClearField("ir_version")
    case("ir_version_missing", f"{FORMAT}|{UNSUPPORTED}", "no ir_version", t)
    t = copy.deepcopy(m)
    t.ClearField("graph")
    case("no_graph", FORMAT, "model has no graph", t)

    t = copy.deepcopy(m)
    t.graph.node[2].input[0] = t.graph.input[0].name
    case("chain_broken", FORMAT, "node 2 reads the graph input instead of node 1's output", t)
    t = copy.deepcopy(m)
    t.graph.node[0].input[0] = t.graph.node[0].output[0]
    case("chain_self_loop", FORMAT, "node 0 reads its own output", t)
    t = copy.deepcopy(m)
    t.graph.node[-1].output[0] = "dangling"
    case("chain_output_mismatch", FORMAT, "the last node's output is not the graph output", t)
    t = copy.deepcopy(m)
    nodes = list(t.graph.node)
    nodes[1], nodes[2] = nodes[2], nodes[1]
    del t.graph.node[:]
    t.graph.node.extend(nodes)
    case("chain_nodes_swapped", FORMAT, "nodes 1 and 2 stored out of chain order", t)
    t = copy.deepcopy(m)
    t.graph.node[1].op_type = "Relu"
    case("node_wrong_op", FORMAT, "node 1 is ai.dpc:Relu", t)
    t = copy.deepcopy(m)
    t.graph.node[1].domain = "ai.other"
    case("node_wrong_domain", FORMAT, "node 1 is ai.other:PointFilter", t)
    t = copy.deepcopy(m)
    del t.graph.node[0].input[1]
    case("node_one_input", FORMAT, "node 0 has one input", t)
    t = copy.deepcopy(m)
    t.graph.node[0].input.append(t.graph.node[0].input[1])
    case("node_three_inputs", FORMAT, "node 0 has three inputs", t)
    t = copy.deepcopy(m)
    t.graph.node[0].output.append("extra_out")
    case("node_two_outputs", FORMAT, "node 0 has two outputs", t)
    t = copy.deepcopy(m)
    del t.graph.node[:]
    case("no_nodes", FORMAT, "graph has no nodes", t)
    t = copy.deepcopy(m)
    nodes = []
    prev = t.graph.input[0].name
    for k in range(4097):
        out = t.graph.output[0].name if k == 4096 else f"{k}"
        nodes.append(
            helper.make_node("PointFilter", [prev, "kernels_0"], [out], domain="ai.dpc", subspaces=[3], radius=[3.0])
        )
        prev = out
    del t.graph.node[:]
    t.graph.node.extend(nodes)
    case("nodes_4097", f"{FORMAT}|{LIMIT}", "4097 PointFilter nodes (at most 4096)", t)

    t = copy.deepcopy(m)
    t.graph.input.append(copy.deepcopy(t.graph.input[0]))
    t.graph.input[1].name = "second"
    case("two_inputs", FORMAT, "graph has two inputs", t)
    t = copy.deepcopy(m)
    del t.graph.input[:]
    case("no_input", FORMAT, "graph has no input", t)
    t = copy.deepcopy(m)
    del t.graph.output[:]
    case("no_output", FORMAT, "graph has no output", t)
    t = copy.deepcopy(m)
    t.graph.input[0].type.tensor_type.elem_type = TensorProto.DOUBLE
    case("input_double", FORMAT, "graph input is DOUBLE, must be FLOAT", t)
    t = copy.deepcopy(m)
    t.graph.output[0].type.tensor_type.elem_type = TensorProto.INT32
    case("output_int32", FORMAT, "graph output is INT32, must be FLOAT", t)
    t = copy.deepcopy(m)
    set_shape(t.graph.input[0], [2])
    case("input_rank1", FORMAT, "graph input has rank 1, must be [m, n] or [batch, m, n]", t)
    t = copy.deepcopy(m)
    set_shape(t.graph.input[0], [1, 1, "m", 2])
    case("input_rank4", FORMAT, "graph input has rank 4", t)
    t = copy.deepcopy(m)
    set_shape(t.graph.output[0], ["m", 3])
    case("output_shape_mismatch", FORMAT, "graph output is [m, 3], input [m, 2]", t)


# ------------------------------------------------------------------------------------------------
# Byte surgery on the wire format
# ------------------------------------------------------------------------------------------------


def split_fields(data: bytes):
    """Top-level fields of a message as (number, wire, header_bytes, payload) tuples."""
    out, i = [], 0

    def rd(i):
        v, s = 0, 0
        while True:
            b = data[i]
            v |= (b & 0x7F) << s
            i += 1
            s += 7
            if not b & 0x80:
                return v, i

    while i < len(data):
        start = i
        key, i = rd(i)
        num, wire = key >> 3, key & 7
        if wire == 0:
            _, j = rd(i)
            out.append((num, wire, data[start:i], data[i:j]))
            i = j
        elif wire == 2:
            n, j = rd(i)
            out.append((num, wire, data[start:j], data[j : j + n]))
            i = j + n
        elif wire == 5:
            out.append((num, wire, data[start:i], data[i : i + 4]))
            i += 4
        elif wire == 1:
            out.append((num, wire, data[start:i], data[i : i + 8]))
            i += 8
        else:
            raise ValueError("unexpected wire type")
    return out


def join_fields(fields) -> bytes:
    return b"".join(h + p for _, _, h, p in fields)


def with_field(fields, number, new_bytes_fn):
    """Rebuild a message, replacing every field `number` by new_bytes_fn(header, payload)."""
    return b"".join(new_bytes_fn(h, p) if n == number else h + p for n, _, h, p in fields)


def raw_cases():
    good = (MODELS / "model_2d.onnx").read_bytes()
    top = split_fields(good)
    assert join_fields(top) == good
    graph_payload = next(p for n, _, _, p in top if n == 7)

    case("raw_empty", FORMAT, "zero bytes", b"")
    case("raw_text", FORMAT, "a line of text, not protobuf", b"this is not an ONNX model\n")
    rng = random.Random(20190611)
    case("raw_random", FORMAT, "2048 random bytes (fixed seed)", bytes(rng.randrange(256) for _ in range(2048)))
    case(
        "raw_trailing_garbage",
        FORMAT,
        "a valid model followed by 0xff bytes (unterminated varint)",
        good + b"\xff" * 12,
    )
    case("raw_field_number_0", FORMAT, "a valid model followed by a field with number 0", good + b"\x00\x00")
    case("raw_wire_type_7", FORMAT, "a valid model followed by a field of wire type 7", good + pb.tag(99, 7) + b"\x00")
    case(
        "raw_wire_type_group",
        FORMAT,
        "a valid model followed by a start-group field (ONNX has none)",
        good + pb.tag(99, 3) + pb.tag(99, 4),
    )

    case(
        "raw_graph_len_past_end",
        FORMAT,
        "graph length 1000 bytes beyond the end of the file",
        with_field(top, 7, lambda h, p: pb.tag(7, 2) + pb.varint(len(p) + 1000) + p),
    )
    case(
        "raw_graph_len_2pow62",
        FORMAT,
        "graph length 2^62",
        with_field(top, 7, lambda h, p: pb.tag(7, 2) + pb.varint(1 << 62) + p),
    )
    case(
        "raw_graph_len_10byte_max",
        FORMAT,
        "graph length is the 10-byte varint 2^64-1",
        with_field(top, 7, lambda h, p: pb.tag(7, 2) + pb.varint((1 << 64) - 1) + p),
    )
    case(
        "raw_graph_len_11byte",
        FORMAT,
        "graph length is an 11-byte (overlong) varint",
        with_field(top, 7, lambda h, p: pb.tag(7, 2) + b"\xff" * 10 + b"\x01" + p),
    )
    case(
        "raw_ir_version_overlong",
        FORMAT,
        "ir_version is an 11-byte varint",
        with_field(top, 1, lambda h, p: pb.tag(1, 0) + b"\x88" + b"\x80" * 9 + b"\x00"),
    )
    case(
        "raw_ir_version_65bit",
        FORMAT,
        "ir_version varint has more than 64 bits",
        with_field(top, 1, lambda h, p: pb.tag(1, 0) + b"\x88" + b"\x80" * 8 + b"\x7f"),
    )
    case(
        "raw_graph_as_varint",
        FORMAT,
        "graph (field 7) encoded with wire type 0",
        with_field(top, 7, lambda h, p: pb.field_varint(7, 5)),
    )
    case(
        "raw_ir_version_as_bytes",
        FORMAT,
        "ir_version (field 1) encoded as length-delimited",
        with_field(top, 1, lambda h, p: pb.field_len(1, b"\x08")),
    )

    # Inside the graph: the first initializer's raw_data length exceeds its tensor.
    def bad_tensor_len(tensor_payload: bytes, new_len: int) -> bytes:
        tf = split_fields(tensor_payload)
        return with_field(tf, 9, lambda h, p: pb.tag(9, 2) + pb.varint(new_len) + p)

    def graph_with_first_init(fn) -> bytes:
        gf = split_fields(graph_payload)
        done, parts = False, []
        for n, _, h, p in gf:
            if n == 5 and not done:
                parts.append(pb.field_len(5, fn(p)))
                done = True
            else:
                parts.append(h + p)
        new_graph = b"".join(parts)
        return with_field(top, 7, lambda h, p: pb.field_len(7, new_graph))

    case(
        "raw_tensor_data_len_past_end",
        FORMAT,
        "kernels raw_data length 2^40, the tensor is a few hundred bytes",
        graph_with_first_init(lambda p: bad_tensor_len(p, 1 << 40)),
    )

    def tensor_dims(p: bytes, dims) -> bytes:
        tf = [f for f in split_fields(p) if f[0] != 1]
        return b"".join(pb.field_varint(1, d) for d in dims) + join_fields(tf)

    case(
        "raw_tensor_dims_huge",
        FORMAT,
        "kernels dims [1, 2^40] with 32 floats of data",
        graph_with_first_init(lambda p: tensor_dims(p, [1, 1 << 40])),
    )
    case(
        "raw_tensor_dims_product_overflow",
        FORMAT,
        "kernels dims [2^32, 2^32 + 32]: the product overflows 64 bits",
        graph_with_first_init(lambda p: tensor_dims(p, [1 << 32, (1 << 32) + 32])),
    )
    case(
        "raw_tensor_dims_negative",
        FORMAT,
        "kernels dims [1, -32]",
        graph_with_first_init(lambda p: tensor_dims(p, [1, -32])),
    )
    case(
        "raw_tensor_100_dims",
        FORMAT,
        "kernels tensor with 100 dims of 1",
        graph_with_first_init(lambda p: tensor_dims(p, [1] * 98 + [1, 32])),
    )

    # The first metadata entry's key length points past the end of the entry.
    first_meta = True

    def bad_entry(h, p):
        nonlocal first_meta
        if not first_meta:
            return h + p
        first_meta = False
        ef = split_fields(p)
        inner = with_field(ef, 1, lambda h2, p2: pb.tag(1, 2) + pb.varint(len(p2) + 50) + p2)
        return pb.field_len(14, inner)

    case(
        "raw_metadata_key_len_past_entry",
        FORMAT,
        "a metadata entry whose key length runs 50 bytes past the entry",
        with_field(top, 14, bad_entry),
    )

    # Deep nesting: the graph is a chain of 3000 nested length-delimited field-1 messages.
    nested = b""
    for _ in range(3000):
        nested = pb.field_len(1, nested)
    case(
        "raw_deep_nesting_graph",
        FORMAT,
        "the graph is 3000 levels of nested field-1 messages (garbage nodes)",
        with_field(top, 7, lambda h, p: pb.field_len(7, nested)),
    )


def main() -> None:
    global MODELS
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--models", type=Path, default=HERE, help="folder of the valid test models")
    ap.add_argument("--out", type=Path, default=HERE / "malformed", help="output folder")
    args = ap.parse_args()
    MODELS = args.models
    OUT = args.out
    tensor_cases()
    attribute_cases()
    metadata_cases()
    graph_cases()
    raw_cases()
    OUT.mkdir(parents=True, exist_ok=True)
    for old in OUT.glob("*.onnx"):
        old.unlink()
    lines = ["# file\texpected status (alternatives separated by |)\twhat is wrong"]
    total = 0
    for name, expected, why, data in CASES:
        (OUT / f"{name}.onnx").write_bytes(data)
        lines.append(f"{name}.onnx\t{expected}\t{why}")
        total += len(data)
    (OUT / "manifest.tsv").write_text("\n".join(lines) + "\n")
    print(f"{len(CASES)} malformed files, {total} bytes, in {OUT}")


if __name__ == "__main__":
    main()
