/* AVX-512F path: sixteen candidates per step, native lane masks, and the kernel table looked up
 * in registers (vpermt2ps) for tables of up to 32 bins, gathers beyond. Compiled with -mavx512f
 * for this file only; called only when cpuid reports AVX-512F (cpu_dispatch.c). */
#include <immintrin.h>

#include "cpu/cpu_kernels.h"

typedef __mmask16 lane_mask;
#define LANES 16
#define ANY(m) ((m) != 0)
#define LOAD_MASK(left) ((lane_mask)((left) >= 16 ? 0xffff : (1u << (left)) - 1))
#define WINDOW(d, load) ((load) & _mm512_cmp_ps_mask(d, cutoff, _CMP_GT_OQ) & _mm512_cmp_ps_mask(d, radius, _CMP_LT_OQ))
#define MASKED_COEF(in, g, inv) _mm512_maskz_mul_ps(in, g, inv)
#define ROUND(t) _mm512_roundscale_ps(t, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC)
#define RSQRT(x) _mm512_rsqrt14_ps(x)
#define REDUCE(v) _mm512_reduce_add_ps(v)

/* Concatenate the candidate ranges of each column into scratch (whole-vector copies: columns are
 * readable 16 floats past any range end, and scratch has room for the overrun). Returns the
 * candidate count, or 0 (nothing copied) when they exceed DPC_GATHER_CAP. */
static inline uint32_t concatenate(const dpc_sub_job *job, unsigned k, const uint32_t *ranges,
                                   unsigned n_ranges, float *scratch, const float **cols) {
    uint32_t total = 0;
    for (unsigned r = 0; r < n_ranges; r++) total += ranges[2 * r + 1] - ranges[2 * r];
    if (total > DPC_GATHER_CAP) return 0;
    for (unsigned q = 0; q < k; q++) {
        float *dst = scratch + q * DPC_GATHER_STRIDE;
        const float *src = job->coord[q];
        for (unsigned r = 0; r < n_ranges; r++) {
            const uint32_t a = ranges[2 * r], len = ranges[2 * r + 1] - a;
            for (uint32_t o = 0; o < len; o += 16) _mm512_storeu_ps(dst + o, _mm512_loadu_ps(src + a + o));
            dst += len;
        }
        _mm512_storeu_ps(dst, _mm512_setzero_ps()); /* lanes past the end read zeros */
        cols[q] = scratch + q * DPC_GATHER_STRIDE;
    }
    return total;
}

/* The loop over candidates, written once. FOR_DIMS(X) expands X(q) for each subspace dimension
 * q: with a fixed list (DIMS_1 .. DIMS_4) every per-dimension value is its own variable, so the
 * accumulators stay in registers; DIMS_N loops over arrays for larger subspaces.
 * Per candidate: toroidal difference, distance via rsqrt + one Newton step (relative error
 * ~1e-7; d2 = 0 lanes fail the window test), window eps < d < r, linear kernel lookup. */
/* One term's chain for the query whose values carry suffix S (empty for a lone query, A or B
 * in a pair): distance, window mask in##S, then coef##S = g(d) / d in the window, 0 outside. */
#define TERM_WINDOW(S)                                                                              \
    __m512 inv##S = RSQRT(d2##S);                                                                   \
    inv##S = _mm512_mul_ps(inv##S, _mm512_fmadd_ps(_mm512_mul_ps(neg_half, d2##S), _mm512_mul_ps(inv##S, inv##S), three_halves)); \
    const __m512 d##S = _mm512_mul_ps(d2##S, inv##S);                                               \
    const lane_mask in##S = WINDOW(d##S, load);
#define TERM_COEF(S, SMALL_TABLE)                                                                   \
    const __m512 u##S = _mm512_min_ps(_mm512_mul_ps(d##S, scale), umax);                            \
    const __m512i b##S = _mm512_min_epi32(_mm512_cvttps_epi32(u##S), qmax);                         \
    const __m512 f##S = _mm512_sub_ps(u##S, _mm512_cvtepi32_ps(b##S));                              \
    __m512 w##S, dw##S;                                                                             \
    if (SMALL_TABLE) {                                                                              \
        w##S = _mm512_permutex2var_ps(w_lo, b##S, w_hi);                                            \
        dw##S = _mm512_permutex2var_ps(dw_lo, b##S, dw_hi);                                         \
    } else {                                                                                        \
        w##S = _mm512_mask_i32gather_ps(_mm512_setzero_ps(), in##S, b##S, job->w, 4);               \
        dw##S = _mm512_mask_i32gather_ps(_mm512_setzero_ps(), in##S, b##S, job->dw, 4);             \
    }                                                                                               \
    const __m512 coef##S = MASKED_COEF(in##S, _mm512_fmadd_ps(f##S, dw##S, w##S), inv##S);

#define CANDIDATE_LOOP(FOR_DIMS, SMALL_TABLE)                                                       \
    for (unsigned r = 0; r < nrg; r++) {                                                            \
        const uint32_t end = rg[2 * r + 1];                                                         \
        for (uint32_t j = rg[2 * r]; j < end; j += LANES) {                                         \
            const uint32_t left = end - j;                                                          \
            const lane_mask load = LOAD_MASK(left);                                                 \
            __m512 d2 = _mm512_setzero_ps();                                                        \
            FOR_DIMS(DIFF)                                                                          \
            TERM_WINDOW()                                                                           \
            if (!ANY(in)) continue;                                                                 \
            TERM_COEF(, SMALL_TABLE)                                                                \
            FOR_DIMS(ACCUMULATE)                                                                    \
        }                                                                                           \
    }

#define DIFF(q)                                                                                     \
    __m512 t##q = _mm512_sub_ps(_mm512_loadu_ps(c##q + j), x##q);                                            \
    t##q = _mm512_sub_ps(t##q, ROUND(t##q));                                                           \
    d2 = _mm512_fmadd_ps(t##q, t##q, d2);
#define ACCUMULATE(q) a##q = _mm512_fmadd_ps(coef, t##q, a##q);
#define DECLARE(q)                                                                                  \
    const float *c##q = cols[q];                                                                    \
    __m512 x##q, a##q;
#define START(q)                                                                                    \
    x##q = _mm512_set1_ps(xi[q]);                                                                      \
    a##q = _mm512_setzero_ps();
#define FINISH(q) acc[q] = REDUCE(a##q);
#define DIMS_1(X) X(0)
#define DIMS_2(X) X(0) X(1)
#define DIMS_3(X) X(0) X(1) X(2)
#define DIMS_4(X) X(0) X(1) X(2) X(3)

/* Pick the candidate source: one concatenated run in scratch, or the ranges in place. */
#define GATHER(K)                                                                                   \
    const float *cols[DPC_MAX_DIMS];                                                                \
    for (unsigned q = 0; q < (K); q++) cols[q] = job->coord[q];                                     \
    uint32_t one_run[2] = {0, 0};                                                                   \
    const uint32_t *rg = ranges;                                                                    \
    unsigned nrg = n_ranges;                                                                        \
    if (scratch && nrg > 1 && (K) <= 4) {                                                           \
        one_run[1] = concatenate(job, (K), ranges, n_ranges, scratch, cols);                        \
        if (one_run[1]) {                                                                           \
            rg = one_run;                                                                           \
            nrg = 1;                                                                                \
        }                                                                                           \
    }

#define SETUP                                                                                       \
    const int bins = job->qmax + 2;                                                                 \
    const int small_table = bins <= 32;                                                             \
    __m512 w_lo = _mm512_setzero_ps(), w_hi = w_lo, dw_lo = w_lo, dw_hi = w_lo;                     \
    if (small_table) { /* the tail beyond `bins` is never selected */                               \
        const __mmask16 m_lo = (__mmask16)(bins >= 16 ? 0xffff : (1u << bins) - 1);                 \
        const __mmask16 m_hi = (__mmask16)(bins <= 16 ? 0 : bins >= 32 ? 0xffff : (1u << (bins - 16)) - 1); \
        w_lo = _mm512_maskz_loadu_ps(m_lo, job->w);                                                 \
        dw_lo = _mm512_maskz_loadu_ps(m_lo, job->dw);                                               \
        w_hi = _mm512_maskz_loadu_ps(m_hi, job->w + 16);                                            \
        dw_hi = _mm512_maskz_loadu_ps(m_hi, job->dw + 16);                                          \
    }                                                                                               \
    const __m512 cutoff = _mm512_set1_ps(job->cutoff), radius = _mm512_set1_ps(job->radius);        \
    const __m512 scale = _mm512_set1_ps(job->scale), umax = _mm512_set1_ps(job->umax);              \
    const __m512 three_halves = _mm512_set1_ps(1.5f), neg_half = _mm512_set1_ps(-0.5f);             \
    const __m512i qmax = _mm512_set1_epi32(job->qmax);                                                          \
    (void)bins;

/* Two query points against the same candidate vector: the chain from a candidate load to its
 * accumulation is long (round, rsqrt, Newton step, table lookup) and a point has only a few
 * vectors of candidates, so one point alone leaves the core waiting on latency. Each point's
 * operations are exactly those of CANDIDATE_LOOP, in the same order, so the sums have the same
 * bits whether a point runs in a pair or alone (a vector with no lane in the window adds +0). */
#define CANDIDATE_LOOP_PAIR(FOR_DIMS, SMALL_TABLE)                                                  \
    for (unsigned r = 0; r < nrg; r++) {                                                            \
        const uint32_t end = rg[2 * r + 1];                                                         \
        for (uint32_t j = rg[2 * r]; j < end; j += LANES) {                                         \
            const uint32_t left = end - j;                                                          \
            const lane_mask load = LOAD_MASK(left);                                                 \
            __m512 d2A = _mm512_setzero_ps(), d2B = d2A;                                            \
            FOR_DIMS(DIFF_PAIR)                                                                     \
            TERM_WINDOW(A)                                                                          \
            TERM_WINDOW(B)                                                                          \
            TERM_COEF(A, SMALL_TABLE)                                                               \
            TERM_COEF(B, SMALL_TABLE)                                                               \
            FOR_DIMS(ACCUMULATE_PAIR)                                                               \
        }                                                                                           \
    }
#define DIFF_PAIR(q)                                                                                \
    const __m512 cand##q = _mm512_loadu_ps(c##q + j);                                               \
    __m512 tA##q = _mm512_sub_ps(cand##q, xA##q), tB##q = _mm512_sub_ps(cand##q, xB##q);            \
    tA##q = _mm512_sub_ps(tA##q, ROUND(tA##q));                                                     \
    tB##q = _mm512_sub_ps(tB##q, ROUND(tB##q));                                                     \
    d2A = _mm512_fmadd_ps(tA##q, tA##q, d2A);                                                       \
    d2B = _mm512_fmadd_ps(tB##q, tB##q, d2B);
#define ACCUMULATE_PAIR(q)                                                                          \
    aA##q = _mm512_fmadd_ps(coefA, tA##q, aA##q);                                                   \
    aB##q = _mm512_fmadd_ps(coefB, tB##q, aB##q);
#define DECLARE_PAIR(q) __m512 xA##q, xB##q, aA##q, aB##q;
#define START_PAIR(q)                                                                               \
    xA##q = _mm512_set1_ps(xi[q]);                                                                  \
    xB##q = _mm512_set1_ps(xi[kdim + q]);                                                            \
    aA##q = _mm512_setzero_ps();                                                                    \
    aB##q = _mm512_setzero_ps();
#define FINISH_PAIR(q)                                                                              \
    acc[q] = REDUCE(aA##q);                                                                         \
    acc[kdim + q] = REDUCE(aB##q);

#define SMALL_KERNEL(NAME, DIMS, K)                                                                 \
    static void NAME(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges, \
                     unsigned n_ranges, float *accs, float *scratch) {                              \
        SETUP                                                                                       \
        GATHER(K)                                                                                   \
        DIMS(DECLARE)                                                                               \
        DIMS(DECLARE_PAIR)                                                                          \
        const unsigned kdim = (K); /* the second point's offset in xs and accs */                  \
        unsigned p = 0;                                                                             \
        for (; p + 2 <= count; p += 2) {                                                            \
            const float *xi = xs + p * (K);                                                         \
            float *acc = accs + p * (K);                                                            \
            DIMS(START_PAIR)                                                                        \
            if (small_table) { CANDIDATE_LOOP_PAIR(DIMS, 1) } else { CANDIDATE_LOOP_PAIR(DIMS, 0) } \
            DIMS(FINISH_PAIR)                                                                       \
        }                                                                                           \
        for (; p < count; p++) {                                                                    \
            const float *xi = xs + p * (K);                                                         \
            float *acc = accs + p * (K);                                                            \
            DIMS(START)                                                                             \
            CANDIDATE_LOOP_TABLE(DIMS)                                                              \
            DIMS(FINISH)                                                                            \
        }                                                                                           \
    }
/* Branch once per block on the table size, so each loop body has one lookup. */
#define CANDIDATE_LOOP_TABLE(DIMS)                                                                  \
    if (small_table) { CANDIDATE_LOOP(DIMS, 1) } else { CANDIDATE_LOOP(DIMS, 0) }

SMALL_KERNEL(kernel_1, DIMS_1, 1)
SMALL_KERNEL(kernel_2, DIMS_2, 2)
SMALL_KERNEL(kernel_3, DIMS_3, 3)
SMALL_KERNEL(kernel_4, DIMS_4, 4)

/* Any subspace size: per-dimension values in arrays (the per-candidate work is large enough here
 * that keeping accumulators in memory costs little). */
#undef DIFF
#undef ACCUMULATE
#define DIMS_N(X) for (unsigned q = 0; q < k; q++) { X(q) }
#define DIFF(q)                                                                                     \
    __m512 tq = _mm512_sub_ps(_mm512_loadu_ps(job->coord[q] + j), x[q]);                                     \
    tq = _mm512_sub_ps(tq, ROUND(tq));                                                                 \
    t[q] = tq;                                                                                      \
    d2 = _mm512_fmadd_ps(tq, tq, d2);
#define ACCUMULATE(q) a[q] = _mm512_fmadd_ps(coef, t[q], a[q]);

static void kernel_n(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges,
                     unsigned n_ranges, float *accs, float *scratch) {
    SETUP
    const unsigned k = job->k;
    (void)scratch; /* large subspaces run all pairs: one range, nothing to concatenate */
    const uint32_t *rg = ranges;
    const unsigned nrg = n_ranges;
    __m512 x[DPC_MAX_DIMS], a[DPC_MAX_DIMS], t[DPC_MAX_DIMS];
    for (unsigned p = 0; p < count; p++) {
        const float *xi = xs + p * k;
        float *acc = accs + p * k;
        for (unsigned q = 0; q < k; q++) {
            x[q] = _mm512_set1_ps(xi[q]);
            a[q] = _mm512_setzero_ps();
        }
        CANDIDATE_LOOP_TABLE(DIMS_N)
        for (unsigned q = 0; q < k; q++) acc[q] = REDUCE(a[q]);
    }
}

void dpc_block_avx512(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges,
                    unsigned n_ranges, float *accs, float *scratch) {
    switch (job->k) {
    case 1: kernel_1(job, xs, count, ranges, n_ranges, accs, scratch); break;
    case 2: kernel_2(job, xs, count, ranges, n_ranges, accs, scratch); break;
    case 3: kernel_3(job, xs, count, ranges, n_ranges, accs, scratch); break;
    case 4: kernel_4(job, xs, count, ranges, n_ranges, accs, scratch); break;
    default: kernel_n(job, xs, count, ranges, n_ranges, accs, scratch); break;
    }
}
