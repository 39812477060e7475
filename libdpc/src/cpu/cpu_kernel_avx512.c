/* AVX-512F path: sixteen candidates per step, native lane masks, and the kernel table looked up
 * in registers (vpermps / vpermt2ps) for tables of up to 32 bins, gathers beyond. Compiled with
 * -mavx512f for this file only; called only when cpuid reports AVX-512F (cpu_dispatch.c). */
#include <immintrin.h>

#include "cpu/cpu_kernels.h"

#define POINT_BODY(KMAX, K)                                                                         \
    const unsigned k = (K) ? (K) : job->k;                                                          \
    const float *coord[KMAX];                                                                       \
    for (unsigned q = 0; q < k; q++) coord[q] = job->coord[q];                                      \
    const int bins = job->qmax + 2;                                                                 \
    /* Tables of <= 32 bins live in two registers; the tail beyond `bins` is never selected. */     \
    __m512 w_lo = _mm512_setzero_ps(), w_hi = w_lo, dw_lo = w_lo, dw_hi = w_lo;                     \
    if (bins <= 32) {                                                                               \
        __mmask16 m_lo = (__mmask16)(bins >= 16 ? 0xffff : (1u << bins) - 1);                       \
        __mmask16 m_hi = (__mmask16)(bins <= 16 ? 0 : bins >= 32 ? 0xffff : (1u << (bins - 16)) - 1); \
        w_lo = _mm512_maskz_loadu_ps(m_lo, job->w);                                                 \
        dw_lo = _mm512_maskz_loadu_ps(m_lo, job->dw);                                               \
        w_hi = _mm512_maskz_loadu_ps(m_hi, job->w + 16);                                            \
        dw_hi = _mm512_maskz_loadu_ps(m_hi, job->dw + 16);                                          \
    }                                                                                               \
    const __m512 cutoff = _mm512_set1_ps(job->cutoff), radius = _mm512_set1_ps(job->radius);        \
    const __m512 scale = _mm512_set1_ps(job->scale), umax = _mm512_set1_ps(job->umax);              \
    const __m512 three_halves = _mm512_set1_ps(1.5f), neg_half = _mm512_set1_ps(-0.5f);             \
    const __m512i qmax = _mm512_set1_epi32(job->qmax);                                              \
    for (unsigned p = 0; p < count; p++) {                                                        \
    const float *xi = xs + p * k;                                                                   \
    float *acc = accs + p * k;                                                                      \
    __m512 vacc[KMAX], vx[KMAX];                                                                     \
    for (unsigned q = 0; q < k; q++) {                                                              \
        vacc[q] = _mm512_setzero_ps();                                                              \
        vx[q] = _mm512_set1_ps(xi[q]);                                                              \
    }                                                                                               \
    for (unsigned r = 0; r < n_ranges; r++) {                                                       \
        const uint32_t end = ranges[2 * r + 1];                                                     \
        for (uint32_t j = ranges[2 * r]; j < end; j += 16) {                                        \
            const uint32_t left = end - j;                                                          \
            const __mmask16 load = (__mmask16)(left >= 16 ? 0xffff : (1u << left) - 1);            \
            __m512 delta[KMAX];                                                                     \
            __m512 d2 = _mm512_setzero_ps();                                                        \
            for (unsigned q = 0; q < k; q++) {                                                      \
                __m512 t = _mm512_sub_ps(_mm512_loadu_ps(coord[q] + j), vx[q]);                     \
                t = _mm512_sub_ps(t, _mm512_roundscale_ps(t, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC)); \
                delta[q] = t;                                                                       \
                d2 = _mm512_fmadd_ps(t, t, d2);                                                     \
            }                                                                                       \
            /* 1/d from rsqrt14 plus one Newton step; d2 = 0 lanes fail the window test. */        \
            __m512 inv = _mm512_rsqrt14_ps(d2);                                                     \
            inv = _mm512_mul_ps(inv, _mm512_fmadd_ps(_mm512_mul_ps(neg_half, d2),                   \
                                                     _mm512_mul_ps(inv, inv), three_halves));       \
            const __m512 d = _mm512_mul_ps(d2, inv);                                                \
            const __mmask16 in = load & _mm512_cmp_ps_mask(d, cutoff, _CMP_GT_OQ) &                 \
                                 _mm512_cmp_ps_mask(d, radius, _CMP_LT_OQ);                         \
            if (!in) continue;                                                                      \
            const __m512 u = _mm512_min_ps(_mm512_mul_ps(d, scale), umax);                          \
            const __m512i b = _mm512_min_epi32(_mm512_cvttps_epi32(u), qmax);                       \
            const __m512 f = _mm512_sub_ps(u, _mm512_cvtepi32_ps(b));                               \
            __m512 w, dw;                                                                           \
            if (bins <= 32) {                                                                       \
                w = _mm512_permutex2var_ps(w_lo, b, w_hi);                                          \
                dw = _mm512_permutex2var_ps(dw_lo, b, dw_hi);                                       \
            } else {                                                                                \
                w = _mm512_mask_i32gather_ps(_mm512_setzero_ps(), in, b, job->w, 4);                \
                dw = _mm512_mask_i32gather_ps(_mm512_setzero_ps(), in, b, job->dw, 4);              \
            }                                                                                       \
            const __m512 coef = _mm512_maskz_mul_ps(in, _mm512_fmadd_ps(f, dw, w), inv);            \
            for (unsigned q = 0; q < k; q++) vacc[q] = _mm512_fmadd_ps(coef, delta[q], vacc[q]);    \
        }                                                                                           \
    }                                                                                               \
    for (unsigned q = 0; q < k; q++) acc[q] = _mm512_reduce_add_ps(vacc[q]);                      \
    }

static inline __attribute__((always_inline)) void point_small(const dpc_sub_job *job, const float *xs,
                                                              unsigned count, const uint32_t *ranges,
                                                              unsigned n_ranges, float *accs,
                                                              const unsigned K) {
    POINT_BODY(4, K)
}

static void point_generic(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges,
                          unsigned n_ranges, float *accs) {
    POINT_BODY(DPC_MAX_DIMS, 0)
}

void dpc_block_avx512(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges,
                    unsigned n_ranges, float *accs) {
    switch (job->k) {
    case 1: point_small(job, xs, count, ranges, n_ranges, accs, 1); break;
    case 2: point_small(job, xs, count, ranges, n_ranges, accs, 2); break;
    case 3: point_small(job, xs, count, ranges, n_ranges, accs, 3); break;
    case 4: point_small(job, xs, count, ranges, n_ranges, accs, 4); break;
    default: point_generic(job, xs, count, ranges, n_ranges, accs); break;
    }
}
