/* A bounded reader of the protobuf wire format: just what the ONNX reader needs. Every length
 * is checked against the bytes that remain; nothing here allocates or recurses. */
#ifndef DPC_MODEL_PROTOBUF_H
#define DPC_MODEL_PROTOBUF_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

typedef struct pb_span {
    const uint8_t *p;
    size_t n;
} pb_span;

typedef struct pb_field {
    uint32_t number;
    uint32_t wire;  /* 0 varint, 1 fixed64, 2 length-delimited, 5 fixed32 */
    uint64_t value; /* varint, fixed64 or fixed32 payload */
    pb_span bytes;  /* payload of a length-delimited field */
} pb_field;

enum { PB_END = 0, PB_OK = 1, PB_BAD = -1 };

/* Read a varint from *s (max 10 bytes, no overflow past 64 bits). */
static inline int pb_read_varint(pb_span *s, uint64_t *out) {
    uint64_t v = 0;
    for (unsigned i = 0; i < 10; i++) {
        if (s->n == 0) return PB_BAD;
        uint8_t b = *s->p++;
        s->n--;
        if (i == 9 && b > 1) return PB_BAD; /* more than 64 bits */
        v |= (uint64_t)(b & 0x7f) << (7 * i);
        if (!(b & 0x80)) {
            *out = v;
            return PB_OK;
        }
    }
    return PB_BAD;
}

/* Next field of a message: PB_OK, PB_END at the clean end, PB_BAD on malformed bytes. */
static inline int pb_next(pb_span *s, pb_field *f) {
    if (s->n == 0) return PB_END;
    uint64_t tag;
    if (pb_read_varint(s, &tag) != PB_OK) return PB_BAD;
    if (tag >> 3 == 0 || tag >> 3 > 0x1fffffff) return PB_BAD;
    f->number = (uint32_t)(tag >> 3);
    f->wire = (uint32_t)(tag & 7);
    f->value = 0;
    f->bytes.p = NULL;
    f->bytes.n = 0;
    switch (f->wire) {
    case 0: return pb_read_varint(s, &f->value);
    case 1:
        if (s->n < 8) return PB_BAD;
        f->value = 0;
        for (int i = 7; i >= 0; i--) f->value = (f->value << 8) | s->p[i];
        s->p += 8;
        s->n -= 8;
        return PB_OK;
    case 2: {
        uint64_t len;
        if (pb_read_varint(s, &len) != PB_OK || len > s->n) return PB_BAD;
        f->bytes.p = s->p;
        f->bytes.n = (size_t)len;
        s->p += len;
        s->n -= (size_t)len;
        return PB_OK;
    }
    case 5:
        if (s->n < 4) return PB_BAD;
        f->value = (uint32_t)s->p[0] | (uint32_t)s->p[1] << 8 | (uint32_t)s->p[2] << 16 | (uint32_t)s->p[3] << 24;
        s->p += 4;
        s->n -= 4;
        return PB_OK;
    default: /* groups (3, 4) and reserved wire types are not used by ONNX */ return PB_BAD;
    }
}

static inline float pb_float_from_bits(uint32_t bits) {
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}

static inline int pb_span_eq(pb_span a, const char *lit) {
    size_t n = strlen(lit);
    return a.n == n && (n == 0 || memcmp(a.p, lit, n) == 0);
}

static inline int pb_spans_equal(pb_span a, pb_span b) {
    return a.n == b.n && (a.n == 0 || memcmp(a.p, b.p, a.n) == 0);
}

#endif
