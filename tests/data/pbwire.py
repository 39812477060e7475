"""A small protobuf wire-format encoder for the test-file scripts of tests/data.

The ``onnx`` package always serialises a message one way (known fields in field-number order,
repeated scalars packed or not as onnx.proto declares). Readers must accept every encoding the
wire format allows, and hostile files are not encodable with ``onnx`` at all, so the scripts
here write bytes themselves: :func:`encode` re-encodes any protobuf message with a chosen
packing of repeated scalars and field order, and the ``field_*`` helpers build raw fields.
"""

from __future__ import annotations

import struct

# google.protobuf FieldDescriptor.TYPE_* values used by onnx.proto
T_DOUBLE, T_FLOAT, T_INT64, T_UINT64, T_INT32, T_BOOL = 1, 2, 3, 4, 5, 8
T_STRING, T_MESSAGE, T_BYTES, T_UINT32, T_ENUM = 9, 11, 12, 13, 14
WT_VARINT, WT_I64, WT_LEN, WT_I32 = 0, 1, 2, 5


def varint(v: int) -> bytes:
    """Base-128 varint of v (negative int64 values as their 10-byte two's complement)."""
    if v < 0:
        v += 1 << 64
    if not 0 <= v < 1 << 64:
        raise ValueError("varint out of range")
    out = bytearray()
    while True:
        b = v & 0x7F
        v >>= 7
        if v:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def tag(number: int, wire: int) -> bytes:
    return varint((number << 3) | wire)


def field_varint(number: int, v: int) -> bytes:
    return tag(number, WT_VARINT) + varint(v)


def field_len(number: int, payload: bytes) -> bytes:
    return tag(number, WT_LEN) + varint(len(payload)) + payload


def field_i32(number: int, payload4: bytes) -> bytes:
    return tag(number, WT_I32) + payload4


def _scalar_wire(ftype: int) -> int:
    if ftype in (T_FLOAT,):
        return WT_I32
    if ftype in (T_DOUBLE,):
        return WT_I64
    return WT_VARINT


def _scalar_bytes(ftype: int, v) -> bytes:
    if ftype == T_FLOAT:
        return struct.pack("<f", v)
    if ftype == T_DOUBLE:
        return struct.pack("<d", v)
    if ftype in (T_INT64, T_UINT64, T_INT32, T_UINT32, T_ENUM, T_BOOL):
        return varint(int(v))
    raise ValueError(f"unsupported scalar type {ftype}")


def encode(msg, *, packed: str = "native", reverse: bool = False) -> bytes:
    """Serialise a protobuf message by hand.

    packed: "native" (as the .proto declares, what SerializeToString does), "all" (every
    repeated scalar packed) or "none" (every repeated scalar one field per value).
    reverse: write the fields of every message in decreasing field-number order."""
    parts = []
    fields = msg.ListFields()  # (descriptor, value), sorted by field number
    if reverse:
        fields = fields[::-1]
    for fd, value in fields:
        num, ftype = fd.number, fd.type
        values = list(value) if fd.is_repeated else [value]
        if ftype == T_MESSAGE:
            for v in values:
                parts.append(field_len(num, encode(v, packed=packed, reverse=reverse)))
        elif ftype in (T_STRING, T_BYTES):
            for v in values:
                parts.append(field_len(num, v.encode("utf-8") if isinstance(v, str) else bytes(v)))
        else:
            pack = fd.is_repeated and (packed == "all" or (packed == "native" and fd.is_packed))
            if pack:
                parts.append(field_len(num, b"".join(_scalar_bytes(ftype, v) for v in values)))
            else:
                for v in values:
                    parts.append(tag(num, _scalar_wire(ftype)) + _scalar_bytes(ftype, v))
    return b"".join(parts)
