/* The hot loop of a filter layer, written once for every ISA path: the canonical evaluation
 * order of docs/model-format.md §3 ("Evaluation order") in GCC vector arithmetic. Every step is
 * an IEEE-754 float operation (or an exact integer one) in a fixed order, so every path that
 * includes this file gives the same bits.
 *
 * Canonical order: a query point's candidates form one run (its index ranges concatenated in
 * order); candidate c goes to lane c mod 8; each lane sums its terms in candidate order with
 * FMAs; the 8 lane sums are added in a fixed tree. A vector holds VW = 8 or 16 lanes: with 16,
 * lanes 0-7 belong to one query point and lanes 8-15 to the next, both over the same 8
 * candidates, so each lane still sees exactly the canonical operations.
 *
 * Included by cpu_kernel_scalar.c, cpu_kernel_avx2.c and cpu_kernel_avx512.c, which first define:
 *   KERNEL              the name of the entry point to define (a dpc_block_fn)
 *   LIST_KERNEL         the name of the list kernel to define (a dpc_list_fn)
 *   VW                  8 or 16, and the types vf (VW floats) and vi (VW int32s)
 *   FMA(a, b, c)        a * b + c rounded once, lane by lane
 *   table_regs          a kernel table prepared for LOOKUP
 *   LOAD_TABLE(T, w, n) prepare the n-entry table w into T
 *   LOOKUP(T, b)        the entries w[b[l]] (vf); every b[l] is in [0, n - 1]
 * and optionally VANY(m) (whether any lane of a mask is set), VLOAD8(p) (8 floats at p in each
 * 8-lane half), VPAIR(a, b), VRINT, VMIN and VIMIN (one instruction for the generic code below),
 * and with mask registers vmask, VMASK_ALL, VMASK_BELOW, VMASK_ANY, VWINDOW and VCOEF (below). */
#ifndef KERNEL
#error "define KERNEL, VW, vf, vi, FMA, table_regs, LOAD_TABLE and LOOKUP before including cpu_kernel_body.h"
#endif

#include <string.h>

#define CANON 8 /* canonical lanes per query */

static inline vf vsplat(float a) { return (vf){0} + a; }
static inline vi visplat(int32_t a) { return (vi){0} + a; }
static inline vf vselect(vi mask, vf a, vf b) { return (vf)(((vi)a & mask) | ((vi)b & ~mask)); }

/* The 8 candidates at p, in each query half; an ISA may give one instruction (VLOAD8: two 32-byte
 * copies read back as one 64-byte vector stall on store forwarding, 2.5x the AVX-512 layer time
 * on AMD Zen 4). */
#ifdef VLOAD8
#define vload8(p) VLOAD8(p)
#else
static inline vf vload8(const float *p) {
    vf v;
#if VW == 8
    memcpy(&v, p, sizeof v);
#else
    memcpy(&v, p, 8 * sizeof(float));
    memcpy((float *)&v + 8, p, 8 * sizeof(float));
#endif
    return v;
}
#endif
/* Query A's value in lanes 0-7 (and query B's in lanes 8-15). */
#ifdef VPAIR
#define vpair(a, b) VPAIR(a, b)
#else
static inline vf vpair(float a, float b) {
    vf v = vsplat(a);
#if VW == 16
    for (int l = 8; l < 16; l++) v[l] = b;
#else
    (void)b;
#endif
    return v;
}
#endif
/* Lanes whose candidate exists: lane mod 8 < left. */
static inline vi vlanes_below(uint32_t left) {
#if VW == 8
    const vi lane = {0, 1, 2, 3, 4, 5, 6, 7};
#else
    const vi lane = {0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7};
#endif
    return lane < visplat((int32_t)(left < CANON ? left : CANON));
}
#ifndef VMIN /* lane-wise minimum of finite floats / of ints; an ISA may give one instruction */
#define VMIN(a, b) vselect((a) < (b), (a), (b))
#define VIMIN(a, b) ((vi)vselect((a) < (b), (vf)(a), (vf)(b)))
#endif
#ifndef VANY
static inline int vany(vi m) {
    int32_t r = 0;
    for (int l = 0; l < VW; l++) r |= m[l];
    return r != 0;
}
#define VANY(m) vany(m)
#endif

/* Lane masks: which lanes hold a candidate (load) and which are in the window (in). By default
 * vectors of 0 / -1 in GCC vector arithmetic; an ISA with mask registers defines vmask and these
 * (AVX-512: __mmask16, compares and a zero-masked multiply straight into and out of them). */
#ifndef VMASK_ALL
typedef vi vmask;
#define VMASK_ALL visplat(-1)
#define VMASK_BELOW(left) vlanes_below(left)
#define VMASK_ANY(m) VANY(m)
#define VWINDOW(load, d2) ((load) & ((d2) > cut2) & ((d2) < rad2))
#define VCOEF(in, g, y) vselect(in, (g) * (y), vsplat(0.0f)) /* g * y where in, +0 elsewhere */
#endif

/* Minimum-image difference: t - rint(t) for |t| < 2^22, rint rounding half to even; by default
 * as two float additions (which the compiler may not fold without -ffast-math), or an ISA's
 * round-to-nearest-even instruction, the same value. */
#ifndef VRINT
static inline vf vrint(vf t) {
    const vf big = vsplat(12582912.0f); /* 1.5 * 2^23 */
    return (t + big) - big;
}
#define VRINT(t) vrint(t)
#endif
static inline vf vwrap(vf t) { return t - VRINT(t); }
/* The minimum image of t, or t itself where the caller promises |t| <= 1/2 (a local block: then
 * rint(t) = 0 and t - 0 = t, the same bits without the two operations). */
static inline __attribute__((always_inline)) vf vmin_image(vf t, int local) { return local ? t : vwrap(t); }

/* 1 / sqrt(x) for x >= 0, relative error about 1e-6: the magic-constant guess and corrected
 * Newton step of Moroz et al. (2018), then one plain Newton step. Only float multiplications and
 * FMAs, so every path agrees bit for bit; x = 0 gives a large finite y (and then d = x y = 0). */
static inline vf vrsqrt(vf x) {
    vf y = (vf)(visplat(0x5F1FFFF9) - ((vi)x >> 1));
    vf e = FMA(-(x * y), y, vsplat(2.38924456f));
    y = (vsplat(0.703952253f) * y) * e;
    e = FMA(-(vsplat(0.5f) * x * y), y, vsplat(1.5f));
    return y * e;
}

/* sqrt(x) from y ~ 1 / sqrt(x): d = x y, then one Newton step on d, which makes it correctly
 * rounded but for 5e-6 of an ulp (u = d (b - 1) / r passes d's error on to the bin position). */
static inline vf vsqrt(vf x, vf y) {
    const vf d = x * y;
    return FMA(vsplat(0.5f) * y, FMA(-d, d, x), d);
}

/* The 8 lane sums of each query half added in the canonical tree (l, l + 4), (l, l + 2), (0, 1),
 * in-register: the sum of half h ends in lane 8 h (the other lanes hold partial sums). */
static inline vf vtree(vf v) {
#if VW == 8
    v = v + __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3);
    v = v + __builtin_shufflevector(v, v, 2, 3, 0, 1, 6, 7, 4, 5);
    return v + __builtin_shufflevector(v, v, 1, 0, 3, 2, 5, 4, 7, 6);
#else
    v = v + __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3, 12, 13, 14, 15, 8, 9, 10, 11);
    v = v + __builtin_shufflevector(v, v, 2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9, 14, 15, 12, 13);
    return v + __builtin_shufflevector(v, v, 1, 0, 3, 2, 5, 4, 7, 6, 9, 8, 11, 10, 13, 12, 15, 14);
#endif
}
/* The canonical sums of the first `halves` query halves of a, to out[0], out[stride], ... */
static inline void vstore_sums(vf a, unsigned halves, float *out, unsigned stride) {
    const vf sum = vtree(a);
    for (unsigned h = 0; h < halves; h++) out[h * stride] = sum[h * CANON];
}

/* The candidate run of a block of query points: its index ranges concatenated in order. A run
 * of one range is read in place; longer ones are copied into scratch in chunks of
 * DPC_GATHER_CAP candidates (a multiple of 8, so every candidate keeps its lane), or without
 * scratch read in place range by range, each from lane 0: the prefilter's ranges, all but the
 * last a multiple of 8 long, so that too is the concatenation's lane (cpu_near.h). */
typedef struct run {
    const uint32_t *ranges;
    unsigned n_ranges, r; /* the next range, and the position inside it */
    uint32_t at;
} run;

static inline uint32_t next_chunk(run *rn, const dpc_sub_job *job, unsigned k, float *scratch, const float **cols,
                                  uint32_t *first) {
    if (rn->r >= rn->n_ranges) return 0;
    if (rn->n_ranges == 1 || !scratch) {
        for (unsigned q = 0; q < k; q++) cols[q] = job->coord[q];
        *first = rn->ranges[2 * rn->r];
        rn->r++;
        return rn->ranges[2 * rn->r - 1] - *first;
    }
    uint32_t got = 0;    /* several ranges: the grid, which always passes scratch (k <= 4) */
    const float *col[4]; /* in locals: the copies' stores cannot change them */
    for (unsigned q = 0; q < 4; q++) col[q] = job->coord[q < k ? q : 0];
    while (rn->r < rn->n_ranges && got < DPC_GATHER_CAP) {
        const uint32_t a = rn->ranges[2 * rn->r] + rn->at, b = rn->ranges[2 * rn->r + 1];
        uint32_t len = b - a;
        if (len > DPC_GATHER_CAP - got) len = DPC_GATHER_CAP - got;
        /* whole 16-float copies, every dimension in one loop (ranges are short: a grid row holds a few
         * dozen points): columns are readable 16 floats past any range end and scratch has room for
         * the overrun */
        for (uint32_t o = 0; o < len; o += 16)
            for (unsigned q = 0; q < k; q++)
                memcpy(scratch + q * DPC_GATHER_STRIDE + got + o, col[q] + a + o, 16 * sizeof(float));
        got += len;
        if (a + len == b) rn->r++, rn->at = 0;
        else rn->at += len;
    }
    for (unsigned q = 0; q < k; q++) {
        memset(scratch + q * DPC_GATHER_STRIDE + got, 0, CANON * sizeof(float)); /* the last vector's tail */
        cols[q] = scratch + q * DPC_GATHER_STRIDE;
    }
    *first = 0;
    return got;
}

/* coef = g(d) / d of the lanes in the window (+0 elsewhere), from d2 and y ~ 1 / sqrt(d2): the
 * bin position, its bin and fraction, the table's interpolation, times y. */
static inline __attribute__((always_inline)) vf term_coef(vf d2, vf y, vmask in, vf scale, vf umax, vi qmax,
                                                          const table_regs *w_t, const table_regs *dw_t) {
    const vf u = VMIN(vsqrt(d2, y) * scale, umax);
    const vi b = VIMIN(__builtin_convertvector(u, vi), qmax);
    const vf f = u - __builtin_convertvector(b, vf);
    return VCOEF(in, FMA(f, LOOKUP(dw_t, b), LOOKUP(w_t, b)), y);
}
#define COEF(d2, y, in) term_coef(d2, y, in, scale, umax, qmax, &w_t, &dw_t)

#define SETUP                                                                                    \
    const vf cut2 = vsplat(job->cutoff * job->cutoff), rad2 = vsplat(job->radius * job->radius); \
    const vf scale = vsplat(job->scale), umax = vsplat(job->umax);                               \
    const vi qmax = visplat(job->qmax);                                                          \
    table_regs w_t, dw_t;                                                                        \
    LOAD_TABLE(&w_t, job->w, job->qmax + 2);                                                     \
    LOAD_TABLE(&dw_t, job->dw, job->qmax + 2);

/* The terms of one vector of candidates for the query lanes of suffix S, from d2 = |delta|^2:
 * the window eps < d < r tested on squares (cut2 < d2 < rad2, both squared in float), then
 * coef = g(d) / d and a += coef * delta for every dimension (ACC). A vector with no lane in the
 * window is skipped: it would add +0 to every sum, which leaves the sums' bits as they are. */
#define TERM_ACC(S, ACC)                                          \
    {                                                             \
        const vmask in##S = VWINDOW(load, d2##S);                 \
        if (VMASK_ANY(in##S)) {                                   \
            const vf coef##S = COEF(d2##S, vrsqrt(d2##S), in##S); \
            ACC                                                   \
        }                                                         \
    }

/* Small subspaces (K <= 4): every per-dimension value its own variable. Each vector of lanes
 * (suffix A, and B when two vectors run side by side) carries VW / 8 query points; a lone last
 * point fills both halves of a 16-lane vector and keeps one. */
#define DIMS_1(X) X(0)
#define DIMS_2(X) X(0) X(1)
#define DIMS_3(X) X(0) X(1) X(2)
#define DIMS_4(X) X(0) X(1) X(2) X(3)
#define LOADC(q) const vf c##q = vload8(cols[q] + j);
#define DIFF(S, q)                                              \
    const vf t##S##q = vmin_image(c##q - x##S##q, local_block); \
    d2##S = FMA(t##S##q, t##S##q, d2##S);
#define ACC(S, q) a##S##q = FMA(coef##S, t##S##q, a##S##q);
#define DIFF_A(q) DIFF(A, q)
#define DIFF_B(q) DIFF(B, q)
#define DIFF_C(q) DIFF(C, q)
#define ACC_A(q) ACC(A, q)
#define ACC_B(q) ACC(B, q)
#define ACC_C(q) ACC(C, q)
#define STEP(S, DIMS)              \
    {                              \
        vf d2##S = vsplat(0.0f);   \
        DIMS(DIFF_##S)             \
        TERM_ACC(S, DIMS(ACC_##S)) \
    }
/* One chunk of the run: full vectors first (every lane loads: the mask is a constant the
 * compiler folds away), then the last, partial one: the same operations on every lane as one
 * loop would do. */
#define CHUNK_LOOP(DIMS, STEPS)                      \
    {                                                \
        uint32_t o = 0;                              \
        for (; o + CANON <= len; o += CANON) {       \
            const uint32_t j = first + o;            \
            const vmask load = VMASK_ALL;            \
            DIMS(LOADC)                              \
            STEPS                                    \
        }                                            \
        if (o < len) {                               \
            const uint32_t j = first + o;            \
            const vmask load = VMASK_BELOW(len - o); \
            DIMS(LOADC)                              \
            STEPS                                    \
        }                                            \
    }

/* The same loop software-pipelined: the front of a vector's terms (differences, window, 1/sqrt)
 * is issued one vector ahead of its back (bins, lookup, sums), so the work in the scheduler's
 * window has its inputs ready instead of waiting on one long dependency chain (the layer's time
 * falls by a tenth to a quarter on AMD Zen 4: docs/performance.md). The terms and the
 * order of the FMAs into each lane's sum are the loop's, so are the bits; a vector with no lane
 * in the window is not skipped here but adds +0 to every sum, which changes no bit (a sum starts
 * at +0 and never becomes -0). Front state: n* (this vector), back state: p* (the one before). */
#define PIPE_DECL_T(S, q) vf pt##S##q, nt##S##q;
#define PIPE_DECL_TA(q) PIPE_DECL_T(A, q)
#define PIPE_DECL_TB(q) PIPE_DECL_T(B, q)
#define PIPE_DECL_TC(q) PIPE_DECL_T(C, q)
#define PIPE_DECL(S, DIMS)           \
    DIMS(PIPE_DECL_T##S)             \
    vf pd2##S, py##S, nd2##S, ny##S; \
    vmask pin##S, nin##S;
#define FRONT_DIFF(S, q)                                \
    nt##S##q = vmin_image(c##q - x##S##q, local_block); \
    nd2##S = FMA(nt##S##q, nt##S##q, nd2##S);
#define FRONT_DIFF_A(q) FRONT_DIFF(A, q)
#define FRONT_DIFF_B(q) FRONT_DIFF(B, q)
#define FRONT_DIFF_C(q) FRONT_DIFF(C, q)
#define FRONT(S, DIMS)                  \
    {                                   \
        nd2##S = vsplat(0.0f);          \
        DIMS(FRONT_DIFF_##S)            \
        nin##S = VWINDOW(load, nd2##S); \
        ny##S = vrsqrt(nd2##S);         \
    }
#define PASS_T(S, q) pt##S##q = nt##S##q;
#define PASS_TA(q) PASS_T(A, q)
#define PASS_TB(q) PASS_T(B, q)
#define PASS_TC(q) PASS_T(C, q)
#define PASS(S, DIMS)    \
    {                    \
        DIMS(PASS_T##S)  \
        pd2##S = nd2##S; \
        py##S = ny##S;   \
        pin##S = nin##S; \
    }
#define BACK_ACC(S, q) a##S##q = FMA(coef##S, pt##S##q, a##S##q);
#define BACK_ACC_A(q) BACK_ACC(A, q)
#define BACK_ACC_B(q) BACK_ACC(B, q)
#define BACK_ACC_C(q) BACK_ACC(C, q)
#define BACK(S, DIMS)                                   \
    {                                                   \
        const vf coef##S = COEF(pd2##S, py##S, pin##S); \
        DIMS(BACK_ACC_##S)                              \
    }
#define CHUNK_PIPE(DIMS, FRONTS, BACKS, PASSES)                             \
    {                                                                       \
        {                                                                   \
            const uint32_t j = first;                                       \
            const vmask load = len >= CANON ? VMASK_ALL : VMASK_BELOW(len); \
            DIMS(LOADC)                                                     \
            FRONTS                                                          \
            PASSES                                                          \
        }                                                                   \
        uint32_t o = CANON;                                                 \
        for (; o + CANON <= len; o += CANON) {                              \
            const uint32_t j = first + o;                                   \
            const vmask load = VMASK_ALL;                                   \
            DIMS(LOADC)                                                     \
            FRONTS                                                          \
            BACKS                                                           \
            PASSES                                                          \
        }                                                                   \
        if (o < len) {                                                      \
            const uint32_t j = first + o;                                   \
            const vmask load = VMASK_BELOW(len - o);                        \
            DIMS(LOADC)                                                     \
            FRONTS                                                          \
            BACKS                                                           \
            PASSES                                                          \
        }                                                                   \
        BACKS                                                               \
    }
#ifndef PIPE_MAX_K /* the largest subspace whose pipelined loop fits the ISA's registers */
#define PIPE_MAX_K 4
#endif
#define PAIR_LOOP(K, DIMS)                                                                                        \
    if (K <= PIPE_MAX_K) {                                                                                        \
        PIPE_DECL(A, DIMS)                                                                                        \
        PIPE_DECL(B, DIMS)                                                                                        \
        CHUNK_PIPE(DIMS, FRONT(A, DIMS) FRONT(B, DIMS), BACK(A, DIMS) BACK(B, DIMS), PASS(A, DIMS) PASS(B, DIMS)) \
    } else CHUNK_LOOP(DIMS, STEP(A, DIMS) STEP(B, DIMS))
#define TRIPLE_LOOP(K, DIMS)                                                                                      \
    if (K <= PIPE_MAX_K) {                                                                                        \
        PIPE_DECL(A, DIMS)                                                                                        \
        PIPE_DECL(B, DIMS)                                                                                        \
        PIPE_DECL(C, DIMS)                                                                                        \
        CHUNK_PIPE(DIMS, FRONT(A, DIMS) FRONT(B, DIMS) FRONT(C, DIMS), BACK(A, DIMS) BACK(B, DIMS) BACK(C, DIMS), \
                   PASS(A, DIMS) PASS(B, DIMS) PASS(C, DIMS))                                                     \
    } else CHUNK_LOOP(DIMS, STEP(A, DIMS) STEP(B, DIMS) STEP(C, DIMS))
#define ONE_LOOP(K, DIMS)                                              \
    if (K <= PIPE_MAX_K) {                                             \
        PIPE_DECL(A, DIMS)                                             \
        CHUNK_PIPE(DIMS, FRONT(A, DIMS), BACK(A, DIMS), PASS(A, DIMS)) \
    } else CHUNK_LOOP(DIMS, STEP(A, DIMS))

#define QPV (VW / CANON) /* query points per vector */
/* Query vector v: queries v QPV and min(v QPV + QPV - 1, count - 1) (a lone last point fills
 * both halves of a 16-lane vector and keeps one), its lane sums in sums[v K + q]. */
#define LAST_OF(v) ((v)*QPV + QPV - 1 < count ? (v)*QPV + QPV - 1 : count - 1)
#define DECL(S, q, V)                                                            \
    const vf x##S##q = vpair(xs[(V)*QPV * kdim + q], xs[LAST_OF(V) * kdim + q]); \
    vf a##S##q = sums[(V)*kdim + q];
#define DECL_A(q) DECL(A, q, v)
#define DECL_B(q) DECL(B, q, v + 1)
#define DECL_C(q) DECL(C, q, v + 2)
#define KEEP_A(q) sums[v * kdim + q] = aA##q;
#define KEEP_B(q) sums[(v + 1) * kdim + q] = aB##q;
#define KEEP_C(q) sums[(v + 2) * kdim + q] = aC##q;

/* The candidate run is read chunk by chunk (one chunk, gathered once, for nearly every cell)
 * and every query vector goes over each chunk, two or three side by side (more work in flight:
 * an odd count starts with three, 0.98x the time of a pair and the last alone on AMD Zen 5),
 * a single one alone; the lane sums carry over from chunk to chunk in sums[]. */
#define SMALL_KERNEL(NAME, K, DIMS, LOCAL)                                                                   \
    static void NAME(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges,        \
                     unsigned n_ranges, float *accs, float *scratch) {                                       \
        SETUP                                                                                                \
        const int local_block = LOCAL;                                                                       \
        const unsigned kdim = K, nv = (count + QPV - 1) / QPV;                                               \
        vf sums[DPC_BLOCK_MAX / QPV * K];                                                                    \
        for (unsigned i = 0; i < nv * kdim; i++) sums[i] = vsplat(0.0f);                                     \
        run rn = {ranges, n_ranges, 0, 0};                                                                   \
        const float *cols[4];                                                                                \
        uint32_t first, len;                                                                                 \
        while ((len = next_chunk(&rn, job, kdim, scratch, cols, &first)) != 0) {                             \
            unsigned v = 0;                                                                                  \
            if (nv % 2 && nv >= 3) { /* odd: three side by side, then pairs */                               \
                DIMS(DECL_A)                                                                                 \
                DIMS(DECL_B) DIMS(DECL_C) TRIPLE_LOOP(K, DIMS) DIMS(KEEP_A) DIMS(KEEP_B) DIMS(KEEP_C) v = 3; \
            } else if (nv % 2) {                                                                             \
                DIMS(DECL_A) ONE_LOOP(K, DIMS) DIMS(KEEP_A) v = 1;                                           \
            }                                                                                                \
            for (; v < nv; v += 2) {                                                                         \
                DIMS(DECL_A) DIMS(DECL_B) PAIR_LOOP(K, DIMS) DIMS(KEEP_A) DIMS(KEEP_B)                       \
            }                                                                                                \
        }                                                                                                    \
        for (unsigned v = 0; v < nv; v++) {                                                                  \
            const unsigned here = count - v * QPV < QPV ? count - v * QPV : QPV;                             \
            for (unsigned q = 0; q < kdim; q++)                                                              \
                vstore_sums(sums[v * kdim + q], here, accs + v * QPV * kdim + q, kdim);                      \
        }                                                                                                    \
    }

SMALL_KERNEL(kernel_1, 1, DIMS_1, 0)
SMALL_KERNEL(kernel_2, 2, DIMS_2, 0)
SMALL_KERNEL(kernel_3, 3, DIMS_3, 0)
SMALL_KERNEL(kernel_4, 4, DIMS_4, 0)
SMALL_KERNEL(kernel_1_local, 1, DIMS_1, 1)
SMALL_KERNEL(kernel_2_local, 2, DIMS_2, 1)
SMALL_KERNEL(kernel_3_local, 3, DIMS_3, 1)
SMALL_KERNEL(kernel_4_local, 4, DIMS_4, 1)

/* The back of kernel_n's vector in flight (pd2, py, pin) with its differences T. */
#define BACK_N(T)                                                        \
    if (VMASK_ANY(pin)) {                                                \
        const vf coef = COEF(pd2, py, pin);                              \
        for (unsigned q = 0; q < k; q++) a[q] = FMA(coef, (T)[q], a[q]); \
    }
/* Any subspace size: per-dimension values in arrays. Large subspaces run all pairs: one range,
 * or the prefilter's ranges, read in place (no scratch). Pipelined like the small kernels (the
 * front of the next vector before the back of this one, across range boundaries too), the
 * differences of the two vectors in flight in two buffers; a vector with no lane in the window
 * skips its back (it would add +0 to every sum). */
static void kernel_n(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges, unsigned n_ranges,
                     float *accs, float *scratch) {
    SETUP
    const unsigned k = job->k;
    vf x[DPC_MAX_DIMS], a[DPC_MAX_DIMS], t[2][DPC_MAX_DIMS];
    for (unsigned p = 0; p < count; p += QPV) {
        const unsigned here = count - p < QPV ? count - p : QPV;
        for (unsigned q = 0; q < k; q++) {
            x[q] = vpair(xs[p * k + q], xs[(p + here - 1) * k + q]);
            a[q] = vsplat(0.0f);
        }
        run rn = {ranges, n_ranges, 0, 0};
        const float *cols[DPC_MAX_DIMS];
        uint32_t first, len;
        unsigned cur = 0, pending = 0;
        vf pd2 = vsplat(0.0f), py = vsplat(0.0f);
        vmask pin = VMASK_BELOW(0);
        while ((len = next_chunk(&rn, job, k, scratch, cols, &first)) != 0) {
            for (uint32_t o = 0; o < len; o += CANON) {
                const vmask load = VMASK_BELOW(len - o);
                vf d2 = vsplat(0.0f);
                for (unsigned q = 0; q < k; q++) {
                    t[cur][q] = vwrap(vload8(cols[q] + first + o) - x[q]);
                    d2 = FMA(t[cur][q], t[cur][q], d2);
                }
                const vmask in = VWINDOW(load, d2);
                const vf y = vrsqrt(d2);
                if (pending) BACK_N(t[cur ^ 1]);
                pd2 = d2, py = y, pin = in, cur ^= 1, pending = 1;
            }
        }
        if (pending) BACK_N(t[cur ^ 1]);
        for (unsigned q = 0; q < k; q++) vstore_sums(a[q], here, accs + p * k + q, k);
    }
}

/* ---- one query point over an explicit candidate list (dpc_list_fn, cpu_kernels.h) ---------- */

/* The list kernel works on rows (job->row: each point's k coordinates, zero-padded to
 * job->row_stride, a multiple of 16): one vector holds VW dimensions of one candidate. Its term
 * is the block kernel's lane operations done once, in scalar float arithmetic (the same IEEE
 * operations in the same order, so the same bits); it is then added to the candidate's canonical
 * lane (index mod 8) as one vector FMA over the dimensions. */
static inline float s_fma(float a, float b, float c) { return __builtin_fmaf(a, b, c); }

/* vrsqrt and vsqrt of one value. */
static inline float s_rsqrt(float x) {
    int32_t xi;
    memcpy(&xi, &x, sizeof xi);
    const int32_t yi = 0x5F1FFFF9 - (xi >> 1);
    float y;
    memcpy(&y, &yi, sizeof y);
    float e = s_fma(-(x * y), y, 2.38924456f);
    y = (0.703952253f * y) * e;
    e = s_fma(-(0.5f * x * y), y, 1.5f);
    return y * e;
}

#define LIST_GROUP 8 /* candidates whose distances are summed side by side (independent FMA chains) */

static inline vf vload_row(const float *p) {
    vf v;
    memcpy(&v, p, sizeof v);
    return v;
}

void LIST_KERNEL(const dpc_sub_job *job, const float *xs, const uint32_t *cand, unsigned n, float *accs) {
    const unsigned k = job->k, stride = job->row_stride, chunks = (k + VW - 1) / VW;
    const float cut2 = job->cutoff * job->cutoff, rad2 = job->radius * job->radius;
    float xrow[DPC_MAX_DIMS + 16];
    memcpy(xrow, xs, k * sizeof(float));
    for (unsigned q = k; q < chunks * VW; q++) xrow[q] = 0.0f; /* only what the vectors read: no memset */
    vf x[DPC_MAX_DIMS / 8], lane[DPC_MAX_DIMS / 8][CANON];     /* [chunk][canonical lane]: zeroed as far as used */
    for (unsigned c = 0; c < chunks; c++) {
        x[c] = vload_row(xrow + c * VW);
        for (unsigned l = 0; l < CANON; l++) lane[c][l] = vsplat(0.0f);
    }
    for (unsigned i0 = 0; i0 < n; i0 += LIST_GROUP) { /* a group's squared distances side by side */
        const unsigned g_n = n - i0 < LIST_GROUP ? n - i0 : LIST_GROUP;
        vf t[LIST_GROUP][DPC_MAX_DIMS / 8];
        float d2[LIST_GROUP];
        for (unsigned g = 0; g < g_n; g++) {
            const float *row = job->row + (size_t)cand[i0 + g] * stride;
            for (unsigned c = 0; c < chunks; c++) t[g][c] = vwrap(vload_row(row + c * VW) - x[c]);
            d2[g] = 0.0f;
        }
        for (unsigned q = 0; q < k; q++)
            for (unsigned g = 0; g < g_n; g++) d2[g] = s_fma(t[g][q / VW][q % VW], t[g][q / VW][q % VW], d2[g]);
        for (unsigned g = 0; g < g_n; g++) {
            if (!(d2[g] > cut2 && d2[g] < rad2)) continue; /* outside the window: +0 to every sum */
            const float y = s_rsqrt(d2[g]), d = d2[g] * y;
            const float dist = s_fma(0.5f * y, s_fma(-d, d, d2[g]), d);
            const float u0 = dist * job->scale, u = u0 < job->umax ? u0 : job->umax;
            const int32_t b0 = (int32_t)u, b = b0 < job->qmax ? b0 : job->qmax;
            const float f = u - (float)b;
            const vf cv = vsplat(s_fma(f, job->dw[b], job->w[b]) * y);
            const unsigned l = cand[i0 + g] % CANON;
            for (unsigned c = 0; c < chunks; c++) lane[c][l] = FMA(cv, t[g][c], lane[c][l]);
        }
    }
    for (unsigned c = 0; c < chunks; c++) { /* the canonical tree (vtree), all dimensions at once */
        const vf sum = ((lane[c][0] + lane[c][4]) + (lane[c][2] + lane[c][6])) +
                       ((lane[c][1] + lane[c][5]) + (lane[c][3] + lane[c][7]));
        const unsigned here = k - c * VW < VW ? k - c * VW : VW;
        for (unsigned l = 0; l < here; l++) accs[c * VW + l] = sum[l];
    }
}

void KERNEL(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges, unsigned n_ranges,
            int local, float *accs, float *scratch) {
    if (local) { /* grid blocks only: k <= 4 */
        switch (job->k) {
        case 1: kernel_1_local(job, xs, count, ranges, n_ranges, accs, scratch); return;
        case 2: kernel_2_local(job, xs, count, ranges, n_ranges, accs, scratch); return;
        case 3: kernel_3_local(job, xs, count, ranges, n_ranges, accs, scratch); return;
        case 4: kernel_4_local(job, xs, count, ranges, n_ranges, accs, scratch); return;
        default: break; /* larger subspaces wrap every difference: the promise changes no bit there */
        }
    }
    switch (job->k) {
    case 1: kernel_1(job, xs, count, ranges, n_ranges, accs, scratch); break;
    case 2: kernel_2(job, xs, count, ranges, n_ranges, accs, scratch); break;
    case 3: kernel_3(job, xs, count, ranges, n_ranges, accs, scratch); break;
    case 4: kernel_4(job, xs, count, ranges, n_ranges, accs, scratch); break;
    default: kernel_n(job, xs, count, ranges, n_ranges, accs, scratch); break;
    }
}
