/* AVX2 + FMA path: eight candidates per step. Compiled with -mavx2 -mfma for this file only;
 * called only when cpuid reports both (cpu_dispatch.c). */
#include <immintrin.h>

#include "cpu/cpu_kernels.h"

static inline float hsum(__m256 v) {
    /* Fixed reduction order so results do not depend on anything but the inputs. */
    __m128 lo = _mm256_castps256_ps128(v), hi = _mm256_extractf128_ps(v, 1);
    __m128 s = _mm_add_ps(lo, hi);
    s = _mm_add_ps(s, _mm_movehl_ps(s, s));
    s = _mm_add_ss(s, _mm_shuffle_ps(s, s, 1));
    return _mm_cvtss_f32(s);
}

typedef __m256 lane_mask;
#define LANES 8
#define ANY(m) (!_mm256_testz_ps(m, m))
#define LOAD_MASK(left) _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32((left) < 8 ? (int)(left) : 8), lane))
#define WINDOW(d, load) _mm256_and_ps(load, _mm256_and_ps(_mm256_cmp_ps(d, cutoff, _CMP_GT_OQ), _mm256_cmp_ps(d, radius, _CMP_LT_OQ)))
#define MASKED_COEF(in, g, inv) _mm256_and_ps(in, _mm256_mul_ps(g, inv))
#define ROUND(t) _mm256_round_ps(t, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC)
#define RSQRT(x) _mm256_rsqrt_ps(x)
#define REDUCE(v) hsum(v)

/* A table of up to 32 bins held in four registers, looked up by permutes: bits 0-2 of the bin
 * index pick the entry within each group of 8, bits 3 and 4 (moved to the sign bit) pick the
 * group. The same values as a gather, at about 20% less time per layer on AMD Zen 5. */
static inline __m256 table32(const __m256 t[4], __m256i b) {
    const __m256 bit3 = _mm256_castsi256_ps(_mm256_slli_epi32(b, 28));
    const __m256 bit4 = _mm256_castsi256_ps(_mm256_slli_epi32(b, 27));
    const __m256 lo = _mm256_blendv_ps(_mm256_permutevar8x32_ps(t[0], b), _mm256_permutevar8x32_ps(t[1], b), bit3);
    const __m256 hi = _mm256_blendv_ps(_mm256_permutevar8x32_ps(t[2], b), _mm256_permutevar8x32_ps(t[3], b), bit3);
    return _mm256_blendv_ps(lo, hi, bit4);
}

/* Load a table of `bins` <= 32 floats into four registers, zeros past its end (never read). */
static inline void load_table32(const float *src, int bins, __m256 t[4]) {
    const __m256i lane8 = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    for (int g = 0; g < 4; g++) {
        const __m256i keep = _mm256_cmpgt_epi32(_mm256_set1_epi32(bins - 8 * g), lane8);
        t[g] = _mm256_maskload_ps(src + 8 * g, keep);
    }
}

/* Concatenate the candidate ranges of each column into scratch (whole-vector copies: columns are
 * readable 8 floats past any range end, and scratch has room for the overrun). Returns the
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
            for (uint32_t o = 0; o < len; o += 8) _mm256_storeu_ps(dst + o, _mm256_loadu_ps(src + a + o));
            dst += len;
        }
        _mm256_storeu_ps(dst, _mm256_setzero_ps()); /* lanes past the end read zeros */
        cols[q] = scratch + q * DPC_GATHER_STRIDE;
    }
    return total;
}

/* The loop over candidates, written once. FOR_DIMS(X) expands X(q) for each subspace dimension
 * q: with a fixed list (DIMS_1 .. DIMS_4) every per-dimension value is its own variable, so the
 * accumulators stay in registers; DIMS_N loops over arrays for larger subspaces.
 * Per candidate: toroidal difference, distance via rsqrt + one Newton step (relative error
 * ~1e-7; d2 = 0 lanes fail the window test), window eps < d < r, linear kernel lookup. */
#define CANDIDATE_LOOP(FOR_DIMS, SMALL_TABLE)                                                         \
    for (unsigned r = 0; r < nrg; r++) {                                                            \
        const uint32_t end = rg[2 * r + 1];                                                     \
        for (uint32_t j = rg[2 * r]; j < end; j += LANES) {                                     \
            const uint32_t left = end - j;                                                          \
            const lane_mask load = LOAD_MASK(left);                                                 \
            __m256 d2 = _mm256_setzero_ps();                                                              \
            FOR_DIMS(DIFF)                                                                          \
            __m256 inv = RSQRT(d2);                                                                    \
            inv = _mm256_mul_ps(inv, _mm256_fmadd_ps(_mm256_mul_ps(neg_half, d2), _mm256_mul_ps(inv, inv), three_halves)); \
            const __m256 d = _mm256_mul_ps(d2, inv);                                                      \
            const lane_mask in = WINDOW(d, load);                                                   \
            if (!ANY(in)) continue;                                                                 \
            const __m256 u = _mm256_min_ps(_mm256_mul_ps(d, scale), umax);                                   \
            const __m256i b = _mm256_min_epi32(_mm256_cvttps_epi32(u), qmax);                                              \
            const __m256 f = _mm256_sub_ps(u, _mm256_cvtepi32_ps(b));                                        \
            __m256 w, dw;                                                                           \
            if (SMALL_TABLE) {                                                                      \
                w = table32(w_t, b);                                                                \
                dw = table32(dw_t, b);                                                              \
            } else {                                                                                \
                w = _mm256_i32gather_ps(job->w, b, 4);                                              \
                dw = _mm256_i32gather_ps(job->dw, b, 4);                                            \
            }                                                                                       \
            const __m256 coef = MASKED_COEF(in, _mm256_fmadd_ps(f, dw, w), inv);                          \
            FOR_DIMS(ACCUMULATE)                                                                    \
        }                                                                                           \
    }

#define DIFF(q)                                                                                     \
    __m256 t##q = _mm256_sub_ps(_mm256_loadu_ps(c##q + j), x##q);                                            \
    t##q = _mm256_sub_ps(t##q, ROUND(t##q));                                                           \
    d2 = _mm256_fmadd_ps(t##q, t##q, d2);
#define ACCUMULATE(q) a##q = _mm256_fmadd_ps(coef, t##q, a##q);
#define DECLARE(q)                                                                                  \
    const float *c##q = cols[q];                                                                    \
    __m256 x##q, a##q;
#define START(q)                                                                                    \
    x##q = _mm256_set1_ps(xi[q]);                                                                      \
    a##q = _mm256_setzero_ps();
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
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);                                 \
    const __m256 cutoff = _mm256_set1_ps(job->cutoff), radius = _mm256_set1_ps(job->radius);        \
    const __m256 scale = _mm256_set1_ps(job->scale), umax = _mm256_set1_ps(job->umax);              \
    const __m256 three_halves = _mm256_set1_ps(1.5f), neg_half = _mm256_set1_ps(-0.5f);             \
    const __m256i qmax = _mm256_set1_epi32(job->qmax);                                                          \
    const int small_table = bins <= 32;                                                             \
    __m256 w_t[4], dw_t[4];                                                                         \
    if (small_table) {                                                                              \
        load_table32(job->w, bins, w_t);                                                            \
        load_table32(job->dw, bins, dw_t);                                                          \
    }

#define SMALL_KERNEL(NAME, DIMS, K)                                                                 \
    static void NAME(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges, \
                     unsigned n_ranges, float *accs, float *scratch) {                              \
        SETUP                                                                                       \
        GATHER(K)                                                                                   \
        DIMS(DECLARE)                                                                               \
        for (unsigned p = 0; p < count; p++) {                                                      \
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
    __m256 tq = _mm256_sub_ps(_mm256_loadu_ps(job->coord[q] + j), x[q]);                                     \
    tq = _mm256_sub_ps(tq, ROUND(tq));                                                                 \
    t[q] = tq;                                                                                      \
    d2 = _mm256_fmadd_ps(tq, tq, d2);
#define ACCUMULATE(q) a[q] = _mm256_fmadd_ps(coef, t[q], a[q]);

static void kernel_n(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges,
                     unsigned n_ranges, float *accs, float *scratch) {
    SETUP
    const unsigned k = job->k;
    (void)scratch; /* large subspaces run all pairs: one range, nothing to concatenate */
    const uint32_t *rg = ranges;
    const unsigned nrg = n_ranges;
    __m256 x[DPC_MAX_DIMS], a[DPC_MAX_DIMS], t[DPC_MAX_DIMS];
    for (unsigned p = 0; p < count; p++) {
        const float *xi = xs + p * k;
        float *acc = accs + p * k;
        for (unsigned q = 0; q < k; q++) {
            x[q] = _mm256_set1_ps(xi[q]);
            a[q] = _mm256_setzero_ps();
        }
        CANDIDATE_LOOP_TABLE(DIMS_N)
        for (unsigned q = 0; q < k; q++) acc[q] = REDUCE(a[q]);
    }
}

void dpc_block_avx2(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges,
                    unsigned n_ranges, float *accs, float *scratch) {
    switch (job->k) {
    case 1: kernel_1(job, xs, count, ranges, n_ranges, accs, scratch); break;
    case 2: kernel_2(job, xs, count, ranges, n_ranges, accs, scratch); break;
    case 3: kernel_3(job, xs, count, ranges, n_ranges, accs, scratch); break;
    case 4: kernel_4(job, xs, count, ranges, n_ranges, accs, scratch); break;
    default: kernel_n(job, xs, count, ranges, n_ranges, accs, scratch); break;
    }
}
