/* ONNX model file -> dpc_cascade, per docs/model-format.md.
 *
 * Self-contained on purpose (no protobuf dependency): libdpc must load models inside renderers
 * that cannot take on a protobuf runtime. The reader keeps spans into the caller's buffer while
 * it validates, copies only what the cascade keeps, and never allocates more than the file's size
 * (plus the fixed caps in model.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/error.h"
#include "model/balance.h"
#include "model/model.h"
#include "model/protobuf.h"
#include "model/relax.h"

#define DPC_DOMAIN "ai.dpc"
#define MAX_INITIALIZERS 8192u

/* ONNX field numbers (onnx.proto) */
enum { MODEL_IR_VERSION = 1, MODEL_GRAPH = 7, MODEL_OPSET = 8, MODEL_META = 14 };
enum { GRAPH_NODE = 1, GRAPH_INIT = 5, GRAPH_INPUT = 11, GRAPH_OUTPUT = 12 };
enum { NODE_INPUT = 1, NODE_OUTPUT = 2, NODE_NAME = 3, NODE_OP = 4, NODE_ATTR = 5, NODE_DOMAIN = 7 };
enum { ATTR_NAME = 1, ATTR_F = 2, ATTR_I = 3, ATTR_FLOATS = 7, ATTR_INTS = 8, ATTR_TYPE = 20 };
enum { ATYPE_FLOAT = 1, ATYPE_INT = 2, ATYPE_FLOATS = 6, ATYPE_INTS = 7 };
enum {
    TENSOR_DIMS = 1,
    TENSOR_TYPE = 2,
    TENSOR_SEGMENT = 3,
    TENSOR_FLOAT_DATA = 4,
    TENSOR_NAME = 8,
    TENSOR_RAW = 9,
    TENSOR_EXTERNAL = 13,
    TENSOR_LOCATION = 14
};
enum { ONNX_FLOAT = 1 };

#define FAIL(...) dpc_fail(DPC_ERROR_FORMAT, __VA_ARGS__)
#define CHECK_WIRE(f, w, what)                                                                   \
    do {                                                                                         \
        if ((f).wire != (w)) return FAIL("%s has wire type %u, expected %u", what, (f).wire, w); \
    } while (0)

/* ---- small views ------------------------------------------------------------------------- */

typedef struct attr_values {
    int present;
    int64_t type;
    unsigned n; /* values collected (INTS / FLOATS) */
    int64_t ints[DPC_MAX_SUBSPACES];
    float floats[DPC_MAX_SUBSPACES];
    int has_i, has_f;
    int64_t i;
    float f;
} attr_values;

typedef struct node_view {
    pb_span op, domain, name;
    pb_span in[2], out;
    unsigned n_in, n_out;
    attr_values subspaces, radius, eps, fixed;
} node_view;

/* Read a repeated int64 field value (packed or not) into a. */
static dpc_status collect_ints(const pb_field *f, attr_values *a, const char *what) {
    if (f->wire == 0) {
        if (a->n >= DPC_MAX_SUBSPACES) return FAIL("%s has more than %u values", what, DPC_MAX_SUBSPACES);
        a->ints[a->n++] = (int64_t)f->value;
        return DPC_OK;
    }
    if (f->wire != 2) return FAIL("%s has wire type %u", what, f->wire);
    pb_span s = f->bytes;
    while (s.n) {
        uint64_t v;
        if (pb_read_varint(&s, &v) != PB_OK) return FAIL("%s: malformed packed integers", what);
        if (a->n >= DPC_MAX_SUBSPACES) return FAIL("%s has more than %u values", what, DPC_MAX_SUBSPACES);
        a->ints[a->n++] = (int64_t)v;
    }
    return DPC_OK;
}

static dpc_status collect_floats(const pb_field *f, attr_values *a, const char *what) {
    if (f->wire == 5) {
        if (a->n >= DPC_MAX_SUBSPACES) return FAIL("%s has more than %u values", what, DPC_MAX_SUBSPACES);
        a->floats[a->n++] = pb_float_from_bits((uint32_t)f->value);
        return DPC_OK;
    }
    if (f->wire != 2) return FAIL("%s has wire type %u", what, f->wire);
    if (f->bytes.n % 4) return FAIL("%s: packed floats length %zu is not a multiple of 4", what, f->bytes.n);
    for (size_t k = 0; k < f->bytes.n; k += 4) {
        if (a->n >= DPC_MAX_SUBSPACES) return FAIL("%s has more than %u values", what, DPC_MAX_SUBSPACES);
        const uint8_t *p = f->bytes.p + k;
        a->floats[a->n++] =
            pb_float_from_bits((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24);
    }
    return DPC_OK;
}

static dpc_status parse_attribute(pb_span s, node_view *nv) {
    pb_field f;
    int r;
    pb_span name = {NULL, 0};
    attr_values tmp;
    memset(&tmp, 0, sizeof tmp);
    tmp.present = 1;
    /* Two passes: the name may come after the values. */
    pb_span s2 = s;
    while ((r = pb_next(&s2, &f)) == PB_OK)
        if (f.number == ATTR_NAME) {
            CHECK_WIRE(f, 2, "attribute name");
            name = f.bytes;
        }
    if (r == PB_BAD) return FAIL("malformed attribute");
    attr_values *dst;
    const char *what;
    if (pb_span_eq(name, "subspaces")) dst = &nv->subspaces, what = "attribute 'subspaces'";
    else if (pb_span_eq(name, "radius")) dst = &nv->radius, what = "attribute 'radius'";
    else if (pb_span_eq(name, "eps")) dst = &nv->eps, what = "attribute 'eps'";
    else if (pb_span_eq(name, "fixed")) dst = &nv->fixed, what = "attribute 'fixed'";
    else return DPC_OK; /* unknown attributes are ignored (format §2) */
    if (dst->present) return FAIL("%s given twice", what);
    while ((r = pb_next(&s, &f)) == PB_OK) {
        dpc_status st = DPC_OK;
        switch (f.number) {
        case ATTR_TYPE:
            CHECK_WIRE(f, 0, "attribute type");
            tmp.type = (int64_t)f.value;
            break;
        case ATTR_I:
            CHECK_WIRE(f, 0, what);
            tmp.has_i = 1;
            tmp.i = (int64_t)f.value;
            break;
        case ATTR_F:
            CHECK_WIRE(f, 5, what);
            tmp.has_f = 1;
            tmp.f = pb_float_from_bits((uint32_t)f.value);
            break;
        case ATTR_INTS:
            tmp.type = tmp.type ? tmp.type : ATYPE_INTS;
            st = collect_ints(&f, &tmp, what);
            break;
        case ATTR_FLOATS:
            tmp.type = tmp.type ? tmp.type : ATYPE_FLOATS;
            st = collect_floats(&f, &tmp, what);
            break;
        default: break;
        }
        if (st != DPC_OK) return st;
    }
    if (r == PB_BAD) return FAIL("malformed %s", what);
    if (!tmp.type) tmp.type = tmp.has_i ? ATYPE_INT : tmp.has_f ? ATYPE_FLOAT : 0;
    *dst = tmp;
    return DPC_OK;
}

static dpc_status parse_node(pb_span s, node_view *nv) {
    pb_field f;
    int r;
    memset(nv, 0, sizeof *nv);
    while ((r = pb_next(&s, &f)) == PB_OK) {
        dpc_status st = DPC_OK;
        switch (f.number) {
        case NODE_INPUT:
            CHECK_WIRE(f, 2, "node input");
            if (nv->n_in < 2) nv->in[nv->n_in] = f.bytes;
            nv->n_in++;
            break;
        case NODE_OUTPUT:
            CHECK_WIRE(f, 2, "node output");
            nv->out = f.bytes;
            nv->n_out++;
            break;
        case NODE_NAME:
            CHECK_WIRE(f, 2, "node name");
            nv->name = f.bytes;
            break;
        case NODE_OP:
            CHECK_WIRE(f, 2, "node op_type");
            nv->op = f.bytes;
            break;
        case NODE_DOMAIN:
            CHECK_WIRE(f, 2, "node domain");
            nv->domain = f.bytes;
            break;
        case NODE_ATTR:
            CHECK_WIRE(f, 2, "node attribute");
            st = parse_attribute(f.bytes, nv);
            break;
        default: break;
        }
        if (st != DPC_OK) return st;
    }
    return r == PB_BAD ? FAIL("malformed node") : DPC_OK;
}

/* ---- tensors ----------------------------------------------------------------------------- */

typedef struct tensor_view {
    pb_span name, raw;
    int64_t type;
    unsigned n_dims;
    uint64_t dims[4];
    unsigned n_float_fields; /* float_data entries (packed spans or single values) */
    int external;
} tensor_view;

static dpc_status parse_tensor_header(pb_span s, tensor_view *t) {
    pb_field f;
    int r;
    memset(t, 0, sizeof *t);
    while ((r = pb_next(&s, &f)) == PB_OK) {
        switch (f.number) {
        case TENSOR_DIMS:
            if (f.wire == 0) {
                if (t->n_dims >= 4) return FAIL("tensor has more than 4 dimensions");
                t->dims[t->n_dims++] = f.value;
            } else if (f.wire == 2) {
                pb_span p = f.bytes;
                while (p.n) {
                    uint64_t v;
                    if (pb_read_varint(&p, &v) != PB_OK) return FAIL("malformed tensor dims");
                    if (t->n_dims >= 4) return FAIL("tensor has more than 4 dimensions");
                    t->dims[t->n_dims++] = v;
                }
            } else {
                return FAIL("tensor dims have wire type %u", f.wire);
            }
            break;
        case TENSOR_TYPE:
            CHECK_WIRE(f, 0, "tensor data_type");
            t->type = (int64_t)f.value;
            break;
        case TENSOR_NAME:
            CHECK_WIRE(f, 2, "tensor name");
            t->name = f.bytes;
            break;
        case TENSOR_RAW:
            CHECK_WIRE(f, 2, "tensor raw_data");
            t->raw = f.bytes;
            break;
        case TENSOR_FLOAT_DATA: t->n_float_fields++; break;
        case TENSOR_SEGMENT: return FAIL("segmented tensors are not supported");
        case TENSOR_EXTERNAL: t->external = 1; break;
        case TENSOR_LOCATION:
            if (f.value != 0) t->external = 1;
            break;
        default: break;
        }
    }
    return r == PB_BAD ? FAIL("malformed tensor") : DPC_OK;
}

static int all_finite(const float *v, size_t n) {
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

/* Copy the tensor's n float values into dst (from raw_data or float_data). */
static dpc_status read_tensor_floats(pb_span s, const tensor_view *t, float *dst, size_t n) {
    if (t->raw.p != NULL) {
        if (t->n_float_fields) return FAIL("tensor has both raw_data and float_data");
        if (t->raw.n != n * 4) return FAIL("tensor raw_data has %zu bytes, expected %zu", t->raw.n, n * 4);
        for (size_t i = 0; i < n; i++) {
            const uint8_t *p = t->raw.p + 4 * i;
            dst[i] =
                pb_float_from_bits((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24);
        }
        return DPC_OK;
    }
    size_t got = 0;
    pb_field f;
    int r;
    while ((r = pb_next(&s, &f)) == PB_OK) {
        if (f.number != TENSOR_FLOAT_DATA) continue;
        if (f.wire == 5) {
            if (got >= n) return FAIL("tensor has more float_data values than its dims allow");
            dst[got++] = pb_float_from_bits((uint32_t)f.value);
        } else if (f.wire == 2) {
            if (f.bytes.n % 4 || f.bytes.n / 4 > n - got) return FAIL("tensor float_data does not match its dims");
            for (size_t k = 0; k < f.bytes.n; k += 4) {
                const uint8_t *p = f.bytes.p + k;
                dst[got++] = pb_float_from_bits((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
                                                (uint32_t)p[3] << 24);
            }
        } else {
            return FAIL("tensor float_data has wire type %u", f.wire);
        }
    }
    if (r == PB_BAD) return FAIL("malformed tensor");
    if (got != n) return FAIL("tensor has %zu values, expected %zu", got, n);
    return DPC_OK;
}

/* ---- value info (graph input / output) --------------------------------------------------- */

/* Checks a ValueInfoProto: FLOAT tensor of rank 2 or 3 whose last dimension is dims. */
static dpc_status check_value_info(pb_span s, const char *what, uint32_t dims, pb_span *name) {
    pb_field f;
    int r;
    pb_span type = {NULL, 0};
    name->p = NULL;
    name->n = 0;
    while ((r = pb_next(&s, &f)) == PB_OK) {
        if (f.number == 1) {
            CHECK_WIRE(f, 2, "value name");
            *name = f.bytes;
        }
        if (f.number == 2) {
            CHECK_WIRE(f, 2, "value type");
            type = f.bytes;
        }
    }
    if (r == PB_BAD) return FAIL("malformed graph %s", what);
    pb_span tensor = {NULL, 0};
    while ((r = pb_next(&type, &f)) == PB_OK)
        if (f.number == 1 && f.wire == 2) tensor = f.bytes; /* TypeProto.tensor_type */
    if (r == PB_BAD || tensor.p == NULL) return FAIL("graph %s is not a tensor", what);
    int64_t elem = -1;
    pb_span shape = {NULL, 0};
    int has_shape = 0;
    while ((r = pb_next(&tensor, &f)) == PB_OK) {
        if (f.number == 1) {
            CHECK_WIRE(f, 0, "elem_type");
            elem = (int64_t)f.value;
        }
        if (f.number == 2) {
            CHECK_WIRE(f, 2, "shape");
            shape = f.bytes;
            has_shape = 1;
        }
    }
    if (r == PB_BAD) return FAIL("malformed graph %s type", what);
    if (elem != ONNX_FLOAT) return FAIL("graph %s must be FLOAT (1), has element type %lld", what, (long long)elem);
    if (!has_shape) return FAIL("graph %s has no shape", what);
    unsigned rank = 0;
    int64_t last = -1;
    while ((r = pb_next(&shape, &f)) == PB_OK) {
        if (f.number != 1) continue;
        CHECK_WIRE(f, 2, "shape dim");
        rank++;
        last = -1;
        pb_span d = f.bytes;
        pb_field g;
        int r2;
        while ((r2 = pb_next(&d, &g)) == PB_OK)
            if (g.number == 1 && g.wire == 0) last = (int64_t)g.value;
        if (r2 == PB_BAD) return FAIL("malformed graph %s shape", what);
    }
    if (r == PB_BAD) return FAIL("malformed graph %s shape", what);
    if (rank != 2 && rank != 3) return FAIL("graph %s must have rank 2 or 3, has %u", what, rank);
    if (last != (int64_t)dims) return FAIL("graph %s: last dimension must be the point dimension %u", what, dims);
    return DPC_OK;
}

/* ---- metadata ---------------------------------------------------------------------------- */

static char *copy_span(pb_span s) {
    char *c = (char *)malloc(s.n + 1);
    if (c) {
        if (s.n) memcpy(c, s.p, s.n);
        c[s.n] = '\0';
    }
    return c;
}

/* Strict decimal: 1..10 digits, value <= max. */
static int parse_uint(const char *s, uint64_t max, uint64_t *out) {
    uint64_t v = 0;
    size_t n = 0;
    for (; s[n]; n++) {
        if (s[n] < '0' || s[n] > '9' || n >= 10) return 0;
        v = v * 10 + (uint64_t)(s[n] - '0');
    }
    if (n == 0 || v > max) return 0;
    *out = v;
    return 1;
}

/* "a,b,c" of decimals -> out[], returns count or -1. */
static int parse_uint_list(const char *s, uint64_t max, uint32_t *out, int cap) {
    int n = 0;
    char buf[16];
    while (*s) {
        size_t len = strcspn(s, ",");
        if (len == 0 || len >= sizeof buf || n >= cap) return -1;
        memcpy(buf, s, len);
        buf[len] = '\0';
        uint64_t v;
        if (!parse_uint(buf, max, &v)) return -1;
        out[n++] = (uint32_t)v;
        s += len;
        if (*s == ',') {
            s++;
            if (!*s) return -1;
        }
    }
    return n;
}

const char *dpc_cascade_meta(const dpc_cascade *c, const char *key) {
    for (size_t i = 0; i < c->n_meta; i++)
        if (strcmp(c->meta_keys[i], key) == 0) return c->meta_values[i];
    return NULL;
}

static dpc_status parse_metadata(const pb_span *entries, size_t n, dpc_cascade *c) {
    c->meta_keys = (char **)calloc(n ? n : 1, sizeof(char *));
    c->meta_values = (char **)calloc(n ? n : 1, sizeof(char *));
    if (!c->meta_keys || !c->meta_values) return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory reading metadata");
    for (size_t i = 0; i < n; i++) {
        pb_span s = entries[i], key = {NULL, 0}, value = {NULL, 0};
        pb_field f;
        int r;
        while ((r = pb_next(&s, &f)) == PB_OK) {
            if (f.number == 1) {
                CHECK_WIRE(f, 2, "metadata key");
                key = f.bytes;
            }
            if (f.number == 2) {
                CHECK_WIRE(f, 2, "metadata value");
                value = f.bytes;
            }
        }
        if (r == PB_BAD) return FAIL("malformed metadata entry %zu", i);
        if (key.n == 0 || key.n > DPC_MAX_META_KEY)
            return FAIL("metadata entry %zu: key length %zu out of range", i, key.n);
        if (value.n > DPC_MAX_META_VALUE) return FAIL("metadata entry %zu: value longer than 1 MiB", i);
        if (memchr(key.p, 0, key.n) || (value.n && memchr(value.p, 0, value.n)))
            return FAIL("metadata entry %zu contains a NUL byte", i);
        c->meta_keys[i] = copy_span(key);
        c->meta_values[i] = copy_span(value);
        c->n_meta = i + 1;
        if (!c->meta_keys[i] || !c->meta_values[i])
            return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory reading metadata");
        for (size_t j = 0; j < i; j++)
            if (strcmp(c->meta_keys[j], c->meta_keys[i]) == 0)
                return FAIL("metadata key '%s' appears twice", c->meta_keys[i]);
    }
    const char *v;
    uint64_t x;
    if (!(v = dpc_cascade_meta(c, "dpc.format_version"))) return FAIL("metadata 'dpc.format_version' is missing");
    if (!parse_uint(v, 1000000, &x)) return FAIL("metadata 'dpc.format_version' is not a number: '%.40s'", v);
    if (x != DPC_FORMAT_VERSION)
        return dpc_fail(DPC_ERROR_UNSUPPORTED, "model format version %llu, this libdpc reads version %d",
                        (unsigned long long)x, DPC_FORMAT_VERSION);
    if (!(v = dpc_cascade_meta(c, "dpc.dims"))) return FAIL("metadata 'dpc.dims' is missing");
    if (!parse_uint(v, DPC_MAX_DIMS, &x) || x == 0)
        return FAIL("metadata 'dpc.dims' must be 1..%d, is '%.40s'", DPC_MAX_DIMS, v);
    c->dims = (uint32_t)x;
    if (!(v = dpc_cascade_meta(c, "dpc.n_points"))) return FAIL("metadata 'dpc.n_points' is missing");
    if (!parse_uint(v, DPC_MAX_POINTS, &x) || x == 0)
        return FAIL("metadata 'dpc.n_points' must be 1..%u, is '%.40s'", DPC_MAX_POINTS, v);
    c->n_points = (uint32_t)x;
    const char *axes = dpc_cascade_meta(c, "dpc.grid_axes");
    const char *shape = dpc_cascade_meta(c, "dpc.grid_shape");
    if (!axes != !shape) return FAIL("metadata 'dpc.grid_axes' and 'dpc.grid_shape' must come together");
    if (axes) {
        int na = parse_uint_list(axes, DPC_MAX_DIMS - 1, c->grid_axis, DPC_MAX_DIMS);
        int ns = parse_uint_list(shape, DPC_MAX_POINTS, c->grid_shape, DPC_MAX_DIMS);
        if (na <= 0 || ns != na) return FAIL("metadata grid axes '%.40s' and shape '%.40s' do not match", axes, shape);
        uint64_t prod = 1;
        for (int g = 0; g < na; g++) {
            if (c->grid_axis[g] >= c->dims || (g && c->grid_axis[g] <= c->grid_axis[g - 1]))
                return FAIL("metadata 'dpc.grid_axes' must be increasing dimension indices below %u", c->dims);
            if (c->grid_shape[g] == 0) return FAIL("metadata 'dpc.grid_shape' has a zero");
            prod *= c->grid_shape[g];
            if (prod > DPC_MAX_POINTS) return FAIL("grid has more than %u cells", DPC_MAX_POINTS);
        }
        if ((size_t)na >= c->dims) return FAIL("a gridded model needs at least one free dimension");
        if (prod != c->n_points)
            return FAIL("grid cell count %llu differs from dpc.n_points %u", (unsigned long long)prod, c->n_points);
        c->grid_dims = (uint32_t)na;
    }
    const char *order = dpc_cascade_meta(c, "dpc.order");
    const char *base = dpc_cascade_meta(c, "dpc.progressive_base");
    if (order && strcmp(order, "set") != 0) {
        if (strcmp(order, "progressive") != 0)
            return FAIL("metadata 'dpc.order' is '%.40s': 'set' or 'progressive'", order);
        if (!base || !parse_uint(base, DPC_MAX_POINTS, &x) || x == 0)
            return FAIL("a progressive model needs metadata 'dpc.progressive_base' in 1..%u", DPC_MAX_POINTS);
        if (c->grid_dims) return FAIL("a progressive model has no grid axes");
        c->progressive_base = (uint32_t)x;
    } else if (base) {
        return FAIL("metadata 'dpc.progressive_base' belongs to a model with dpc.order = 'progressive'");
    }
    const char *balance = dpc_cascade_meta(c, "dpc.balance");
    if (balance) {
        if (!parse_uint(balance, DPC_BALANCE_MAX_K, &x) || x == 0)
            return FAIL("metadata 'dpc.balance' is '%.40s': an integer radius in 1..%u", balance, DPC_BALANCE_MAX_K);
        if (c->grid_dims) return FAIL("metadata 'dpc.balance' belongs to a model without grid axes");
        if (!dpc_balance_frequencies((uint32_t)x, c->dims))
            return FAIL("metadata 'dpc.balance' = %u holds more than %u frequencies in %u dimensions", (unsigned)x,
                        DPC_BALANCE_MAX_FREQS, c->dims);
        c->balance = (uint32_t)x;
    }
    const char *relax = dpc_cascade_meta(c, "dpc.relax");
    if (relax) {
        if (!parse_uint(relax, DPC_RELAX_MAX_STEPS, &x) || x == 0)
            return FAIL("metadata 'dpc.relax' is '%.40s': a step count in 1..%u", relax, DPC_RELAX_MAX_STEPS);
        if (!c->progressive_base || c->dims != 2)
            return FAIL("metadata 'dpc.relax' belongs to a 2-D model with dpc.order = 'progressive'");
        if (c->balance) return FAIL("metadata 'dpc.relax' and 'dpc.balance' exclude each other");
        c->relax = (uint32_t)x;
    }
    return DPC_OK;
}

/* ---- layers ------------------------------------------------------------------------------ */

static dpc_status build_layer(const node_view *nv, unsigned k, pb_span tensor_msg, dpc_cascade *c, uint64_t grid_mask,
                              size_t *kernel_total) {
    dpc_layer *L = &c->layers[k];
    const uint64_t all = c->dims == 64 ? ~0ull : ((1ull << c->dims) - 1);
    if (!nv->subspaces.present || nv->subspaces.type != ATYPE_INTS || nv->subspaces.n == 0)
        return FAIL("layer %u: attribute 'subspaces' (INTS) is missing or empty", k);
    if (!nv->radius.present || nv->radius.type != ATYPE_FLOATS)
        return FAIL("layer %u: attribute 'radius' (FLOATS) is missing", k);
    if (nv->radius.n != nv->subspaces.n)
        return FAIL("layer %u: %u radii for %u subspaces", k, nv->radius.n, nv->subspaces.n);
    L->n_sub = nv->subspaces.n;
    for (unsigned t = 0; t < L->n_sub; t++) {
        uint64_t m = (uint64_t)nv->subspaces.ints[t];
        if (m == 0 || (m & ~all))
            return FAIL("layer %u: subspace %u mask 0x%llx is empty or names a dimension >= %u", k, t,
                        (unsigned long long)m, c->dims);
        for (unsigned u = 0; u < t; u++)
            if (L->masks[u] == m) return FAIL("layer %u: subspace mask 0x%llx appears twice", k, (unsigned long long)m);
        L->masks[t] = m;
        float r = nv->radius.floats[t];
        if (!(r > 0.0f && r <= 1e6f)) return FAIL("layer %u: radius %u must be in (0, 1e6], is %g", k, t, (double)r);
        L->radius[t] = r;
    }
    L->eps = 1e-4f;
    if (nv->eps.present) {
        if (nv->eps.type != ATYPE_FLOAT || !nv->eps.has_f) return FAIL("layer %u: attribute 'eps' must be a FLOAT", k);
        if (!(nv->eps.f >= 0.0f && nv->eps.f <= 1e6f))
            return FAIL("layer %u: eps must be in [0, 1e6], is %g", k, (double)nv->eps.f);
        L->eps = nv->eps.f;
    }
    L->fixed = 0;
    if (nv->fixed.present) {
        if (nv->fixed.type != ATYPE_INT || !nv->fixed.has_i)
            return FAIL("layer %u: attribute 'fixed' must be an INT", k);
        if ((uint64_t)nv->fixed.i & ~all) return FAIL("layer %u: 'fixed' names a dimension >= %u", k, c->dims);
        L->fixed = (uint64_t)nv->fixed.i;
    }
    if (c->grid_dims && L->fixed != grid_mask)
        return FAIL("layer %u: 'fixed' (0x%llx) must equal the grid axes (0x%llx)", k, (unsigned long long)L->fixed,
                    (unsigned long long)grid_mask);

    tensor_view t;
    dpc_status st = parse_tensor_header(tensor_msg, &t);
    if (st != DPC_OK) return st;
    if (t.external) return FAIL("layer %u: kernels stored as external data are not supported", k);
    if (t.type != ONNX_FLOAT) return FAIL("layer %u: kernels must be FLOAT (1), are type %lld", k, (long long)t.type);
    if (t.n_dims != 2 || t.dims[0] != L->n_sub || t.dims[1] < 2 || t.dims[1] > DPC_MAX_BINS)
        return FAIL("layer %u: kernels must have shape [%u, b] with 2 <= b <= %u", k, L->n_sub, DPC_MAX_BINS);
    L->bins = (uint32_t)t.dims[1];
    size_t n = (size_t)L->n_sub * L->bins;
    if (n > DPC_MAX_KERNEL_VALUES - *kernel_total)
        return FAIL("model has more than %u kernel values", DPC_MAX_KERNEL_VALUES);
    /* Bound the allocation by the bytes actually present: 4 per value at least. */
    if (t.raw.p ? t.raw.n != n * 4 : tensor_msg.n < n * 4)
        return FAIL("layer %u: kernel data is shorter than its shape [%u, %u]", k, L->n_sub, L->bins);
    *kernel_total += n;
    L->kernels = (float *)malloc(n * sizeof(float));
    L->slopes = (float *)malloc(n * sizeof(float));
    if (!L->kernels || !L->slopes) return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for layer %u kernels", k);
    if ((st = read_tensor_floats(tensor_msg, &t, L->kernels, n)) != DPC_OK) return st;
    if (!all_finite(L->kernels, n)) return FAIL("layer %u: kernels contain a non-finite value", k);
    for (unsigned s = 0; s < L->n_sub; s++) {
        const float *w = L->kernels + (size_t)s * L->bins;
        float *dw = L->slopes + (size_t)s * L->bins;
        for (unsigned q = 0; q + 1 < L->bins; q++) dw[q] = w[q + 1] - w[q];
        dw[L->bins - 1] = 0.0f;
        if (!all_finite(dw, L->bins)) return FAIL("layer %u: kernel slopes overflow", k);
    }
    return DPC_OK;
}

/* ---- the model --------------------------------------------------------------------------- */

typedef struct graph_view {
    pb_span *nodes, *inits, input, output;
    size_t n_nodes, n_inits, n_inputs, n_outputs;
} graph_view;

static dpc_status scan_graph(pb_span g, graph_view *gv) {
    pb_field f;
    int r;
    pb_span s = g;
    memset(gv, 0, sizeof *gv);
    while ((r = pb_next(&s, &f)) == PB_OK) {
        if (f.number == GRAPH_NODE) {
            CHECK_WIRE(f, 2, "graph node");
            gv->n_nodes++;
        }
        if (f.number == GRAPH_INIT) {
            CHECK_WIRE(f, 2, "graph initializer");
            gv->n_inits++;
        }
        if (f.number == GRAPH_INPUT) {
            CHECK_WIRE(f, 2, "graph input");
            gv->input = f.bytes;
            gv->n_inputs++;
        }
        if (f.number == GRAPH_OUTPUT) {
            CHECK_WIRE(f, 2, "graph output");
            gv->output = f.bytes;
            gv->n_outputs++;
        }
    }
    if (r == PB_BAD) return FAIL("malformed graph");
    if (gv->n_nodes == 0) return FAIL("graph has no nodes");
    if (gv->n_nodes > DPC_MAX_LAYERS)
        return FAIL("graph has %zu nodes, at most %u are allowed", gv->n_nodes, DPC_MAX_LAYERS);
    if (gv->n_inits > MAX_INITIALIZERS)
        return FAIL("graph has %zu initializers, at most %u are allowed", gv->n_inits, MAX_INITIALIZERS);
    if (gv->n_inputs != 1 || gv->n_outputs != 1)
        return FAIL("graph must have exactly one input and one output (has %zu and %zu)", gv->n_inputs, gv->n_outputs);
    gv->nodes = (pb_span *)malloc(gv->n_nodes * sizeof(pb_span));
    gv->inits = (pb_span *)malloc((gv->n_inits ? gv->n_inits : 1) * sizeof(pb_span));
    if (!gv->nodes || !gv->inits) return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory reading the graph");
    size_t a = 0, b = 0;
    s = g;
    while (pb_next(&s, &f) == PB_OK) {
        if (f.number == GRAPH_NODE) gv->nodes[a++] = f.bytes;
        if (f.number == GRAPH_INIT) gv->inits[b++] = f.bytes;
    }
    return DPC_OK;
}

static dpc_status find_initializer(const graph_view *gv, pb_span name, pb_span *out) {
    for (size_t i = 0; i < gv->n_inits; i++) {
        pb_span s = gv->inits[i];
        pb_field f;
        int r;
        while ((r = pb_next(&s, &f)) == PB_OK)
            if (f.number == TENSOR_NAME && f.wire == 2 && pb_spans_equal(f.bytes, name)) {
                *out = gv->inits[i];
                return DPC_OK;
            }
        if (r == PB_BAD) return FAIL("malformed initializer %zu", i);
    }
    return FAIL("kernels initializer '%.*s' not found", (int)(name.n > 64 ? 64 : name.n), (const char *)name.p);
}

static dpc_status parse_model(pb_span file, dpc_cascade *c, graph_view *gv, pb_span **meta) {
    pb_field f;
    int r;
    pb_span s = file, graph = {NULL, 0};
    int64_t ir = -1, dpc_opset = -1;
    size_t n_graph = 0, n_meta = 0;
    while ((r = pb_next(&s, &f)) == PB_OK) {
        switch (f.number) {
        case MODEL_IR_VERSION:
            CHECK_WIRE(f, 0, "ir_version");
            ir = (int64_t)f.value;
            break;
        case MODEL_GRAPH:
            CHECK_WIRE(f, 2, "graph");
            graph = f.bytes;
            n_graph++;
            break;
        case MODEL_META:
            CHECK_WIRE(f, 2, "metadata_props");
            n_meta++;
            break;
        case MODEL_OPSET: {
            CHECK_WIRE(f, 2, "opset_import");
            pb_span o = f.bytes, domain = {NULL, 0};
            pb_field g;
            int r2;
            int64_t version = -1;
            while ((r2 = pb_next(&o, &g)) == PB_OK) {
                if (g.number == 1) {
                    CHECK_WIRE(g, 2, "opset domain");
                    domain = g.bytes;
                }
                if (g.number == 2) {
                    CHECK_WIRE(g, 0, "opset version");
                    version = (int64_t)g.value;
                }
            }
            if (r2 == PB_BAD) return FAIL("malformed opset_import");
            if (pb_span_eq(domain, DPC_DOMAIN)) {
                if (dpc_opset != -1) return FAIL("opset_import lists '%s' twice", DPC_DOMAIN);
                dpc_opset = version;
            }
            break;
        }
        default: break;
        }
    }
    if (r == PB_BAD) return FAIL("not an ONNX model: malformed protobuf at byte %zu", (size_t)(s.p - file.p));
    if (ir < 3 || ir > 13) return FAIL("ONNX ir_version must be 3..13, is %lld", (long long)ir);
    if (n_graph != 1) return FAIL("ONNX model must have exactly one graph, has %zu", n_graph);
    if (dpc_opset == -1) return FAIL("opset_import does not list the '%s' domain: not a dpc model", DPC_DOMAIN);
    if (dpc_opset != DPC_FORMAT_VERSION)
        return dpc_fail(DPC_ERROR_UNSUPPORTED, "model uses '%s' operator version %lld, this libdpc reads version %d",
                        DPC_DOMAIN, (long long)dpc_opset, DPC_FORMAT_VERSION);
    if (n_meta > DPC_MAX_META)
        return FAIL("model has %zu metadata entries, at most %u are allowed", n_meta, DPC_MAX_META);
    *meta = (pb_span *)malloc((n_meta ? n_meta : 1) * sizeof(pb_span));
    if (!*meta) return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory reading metadata");
    size_t i = 0;
    s = file;
    while (pb_next(&s, &f) == PB_OK)
        if (f.number == MODEL_META) (*meta)[i++] = f.bytes;
    dpc_status st = parse_metadata(*meta, n_meta, c);
    if (st != DPC_OK) return st;

    if ((st = scan_graph(graph, gv)) != DPC_OK) return st;
    pb_span in_name, out_name;
    if ((st = check_value_info(gv->input, "input", c->dims, &in_name)) != DPC_OK) return st;
    if ((st = check_value_info(gv->output, "output", c->dims, &out_name)) != DPC_OK) return st;

    uint64_t grid_mask = 0;
    for (uint32_t g = 0; g < c->grid_dims; g++) grid_mask |= 1ull << c->grid_axis[g];
    c->layers = (dpc_layer *)calloc(gv->n_nodes, sizeof(dpc_layer));
    if (!c->layers) return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for layers");
    c->n_layers = (uint32_t)gv->n_nodes;
    pb_span prev = in_name;
    size_t kernel_total = 0;
    for (uint32_t k = 0; k < c->n_layers; k++) {
        node_view nv;
        if ((st = parse_node(gv->nodes[k], &nv)) != DPC_OK) return st;
        if (!pb_span_eq(nv.domain, DPC_DOMAIN) || !pb_span_eq(nv.op, "PointFilter"))
            return FAIL("node %u is '%.*s:%.*s', expected '%s:PointFilter'", k,
                        (int)(nv.domain.n > 64 ? 64 : nv.domain.n), (const char *)nv.domain.p,
                        (int)(nv.op.n > 64 ? 64 : nv.op.n), (const char *)nv.op.p, DPC_DOMAIN);
        if (nv.n_in != 2 || nv.n_out != 1)
            return FAIL("node %u must have 2 inputs and 1 output (has %u and %u)", k, nv.n_in, nv.n_out);
        if (!pb_spans_equal(nv.in[0], prev))
            return FAIL("node %u does not read the previous node's output: the graph is not a chain", k);
        pb_span tensor = {NULL, 0};
        if ((st = find_initializer(gv, nv.in[1], &tensor)) != DPC_OK) return st;
        if ((st = build_layer(&nv, k, tensor, c, grid_mask, &kernel_total)) != DPC_OK) return st;
        prev = nv.out;
    }
    if (!pb_spans_equal(prev, out_name)) return FAIL("the last node's output is not the graph output");
    return DPC_OK;
}

dpc_status dpc_cascade_parse(const uint8_t *data, size_t size, dpc_cascade *out) {
    memset(out, 0, sizeof *out);
    if (size > DPC_MAX_FILE_BYTES) return dpc_fail(DPC_ERROR_LIMIT, "model file larger than 1 GiB");
    if (size == 0) return FAIL("empty model file");
    pb_span file = {data, size};
    graph_view gv;
    memset(&gv, 0, sizeof gv);
    pb_span *meta = NULL;
    dpc_status st = parse_model(file, out, &gv, &meta);
    free(gv.nodes);
    free(gv.inits);
    free(meta);
    if (st != DPC_OK) dpc_cascade_release(out);
    return st;
}

void dpc_cascade_release(dpc_cascade *c) {
    if (!c) return;
    if (c->layers)
        for (uint32_t k = 0; k < c->n_layers; k++) {
            free(c->layers[k].kernels);
            free(c->layers[k].slopes);
        }
    free(c->layers);
    for (size_t i = 0; i < c->n_meta; i++) {
        free(c->meta_keys[i]);
        free(c->meta_values[i]);
    }
    free(c->meta_keys);
    free(c->meta_values);
    memset(c, 0, sizeof *c);
}
