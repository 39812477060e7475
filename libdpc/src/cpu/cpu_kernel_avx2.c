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

/* One body for every subspace size: KMAX is the array size (4 for the specialised small sizes,
 * so the compiler keeps accumulators in registers; DPC_MAX_DIMS for the generic path), K > 0 a
 * compile-time size, K == 0 the run-time job->k. */
#define POINT_BODY(KMAX, K)                                                                         \
    const unsigned k = (K) ? (K) : job->k;                                                          \
    const float *coord[KMAX];                                                                       \
    for (unsigned q = 0; q < k; q++) coord[q] = job->coord[q];                                      \
    const float *w_tab = job->w, *dw_tab = job->dw;                                                 \
    const __m256 cutoff = _mm256_set1_ps(job->cutoff), three_halves = _mm256_set1_ps(1.5f);         \
    const __m256 neg_half = _mm256_set1_ps(-0.5f);                                                  \
    const __m256 radius = _mm256_set1_ps(job->radius), scale = _mm256_set1_ps(job->scale);          \
    const __m256 umax = _mm256_set1_ps(job->umax);                                                  \
    const __m256i qmax = _mm256_set1_epi32(job->qmax);                                              \
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);                                 \
    for (unsigned p = 0; p < count; p++) {                                                        \
    const float *xi = xs + p * k;                                                                   \
    float *acc = accs + p * k;                                                                      \
    __m256 vacc[KMAX], vx[KMAX];                                                                     \
    for (unsigned q = 0; q < k; q++) {                                                              \
        vacc[q] = _mm256_setzero_ps();                                                              \
        vx[q] = _mm256_set1_ps(xi[q]);                                                              \
    }                                                                                               \
    for (unsigned r = 0; r < n_ranges; r++) {                                                       \
        const uint32_t end = ranges[2 * r + 1];                                                     \
        for (uint32_t j = ranges[2 * r]; j < end; j += 8) {                                         \
            const uint32_t left = end - j;                                                          \
            __m256i load = _mm256_cmpgt_epi32(_mm256_set1_epi32(left < 8 ? (int)left : 8), lane);   \
            __m256 delta[KMAX];                                                                     \
            __m256 d2 = _mm256_setzero_ps();                                                        \
            for (unsigned q = 0; q < k; q++) {                                                      \
                __m256 t = _mm256_sub_ps(_mm256_loadu_ps(coord[q] + j), vx[q]);                     \
                t = _mm256_sub_ps(t, _mm256_round_ps(t, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC)); \
                delta[q] = t;                                                                       \
                d2 = _mm256_fmadd_ps(t, t, d2);                                                     \
            }                                                                                       \
            /* 1/d from rsqrt plus one Newton step (relative error ~1e-7), not sqrt + div.          \
             * d2 = 0 gives inf/NaN here; those lanes fail the window test below. */               \
            __m256 inv = _mm256_rsqrt_ps(d2);                                                       \
            inv = _mm256_mul_ps(inv, _mm256_fmadd_ps(_mm256_mul_ps(neg_half, d2),                   \
                                                     _mm256_mul_ps(inv, inv), three_halves));       \
            const __m256 d = _mm256_mul_ps(d2, inv);                                                \
            __m256 in = _mm256_and_ps(_mm256_cmp_ps(d, cutoff, _CMP_GT_OQ),                         \
                                      _mm256_cmp_ps(d, radius, _CMP_LT_OQ));                        \
            in = _mm256_and_ps(in, _mm256_castsi256_ps(load));                                      \
            if (_mm256_testz_ps(in, in)) continue;                                                  \
            const __m256 u = _mm256_min_ps(_mm256_mul_ps(d, scale), umax);                          \
            const __m256i b = _mm256_min_epi32(_mm256_cvttps_epi32(u), qmax);                       \
            const __m256 f = _mm256_sub_ps(u, _mm256_cvtepi32_ps(b));                               \
            const __m256 w = _mm256_i32gather_ps(w_tab, b, 4);                                      \
            const __m256 dw = _mm256_i32gather_ps(dw_tab, b, 4);                                    \
            const __m256 coef = _mm256_and_ps(in, _mm256_mul_ps(_mm256_fmadd_ps(f, dw, w), inv));   \
            for (unsigned q = 0; q < k; q++) vacc[q] = _mm256_fmadd_ps(coef, delta[q], vacc[q]);    \
        }                                                                                           \
    }                                                                                               \
    for (unsigned q = 0; q < k; q++) acc[q] = hsum(vacc[q]);                                      \
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

void dpc_block_avx2(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges,
                    unsigned n_ranges, float *accs) {
    switch (job->k) {
    case 1: point_small(job, xs, count, ranges, n_ranges, accs, 1); break;
    case 2: point_small(job, xs, count, ranges, n_ranges, accs, 2); break;
    case 3: point_small(job, xs, count, ranges, n_ranges, accs, 3); break;
    case 4: point_small(job, xs, count, ranges, n_ranges, accs, 4); break;
    default: point_generic(job, xs, count, ranges, n_ranges, accs); break;
    }
}
