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

/* K > 0: compile-time subspace size (kept in registers); K == 0: any size, from job->k. */
static inline __attribute__((always_inline)) void point_body(const dpc_sub_job *job,
                                                             const float *xi,
                                                             const uint32_t *ranges,
                                                             unsigned n_ranges, float *acc,
                                                             const unsigned K) {
    const unsigned k = K ? K : job->k;
    __m256 vacc[DPC_MAX_DIMS], vx[DPC_MAX_DIMS];
    for (unsigned q = 0; q < k; q++) {
        vacc[q] = _mm256_setzero_ps();
        vx[q] = _mm256_set1_ps(xi[q]);
    }
    const __m256 half = _mm256_set1_ps(0.5f), cutoff = _mm256_set1_ps(job->cutoff);
    const __m256 radius = _mm256_set1_ps(job->radius), scale = _mm256_set1_ps(job->scale);
    const __m256 umax = _mm256_set1_ps(job->umax);
    const __m256i qmax = _mm256_set1_epi32(job->qmax);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    for (unsigned r = 0; r < n_ranges; r++) {
        const uint32_t end = ranges[2 * r + 1];
        for (uint32_t j = ranges[2 * r]; j < end; j += 8) {
            const uint32_t left = end - j;
            __m256i load = _mm256_cmpgt_epi32(_mm256_set1_epi32(left < 8 ? (int)left : 8), lane);
            __m256 delta[DPC_MAX_DIMS];
            __m256 d2 = _mm256_setzero_ps();
            for (unsigned q = 0; q < k; q++) {
                __m256 c = _mm256_maskload_ps(job->coord[q] + j, load);
                __m256 t = _mm256_sub_ps(c, vx[q]);
                t = _mm256_sub_ps(t, _mm256_round_ps(_mm256_add_ps(t, half),
                                                     _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC));
                delta[q] = t;
                d2 = _mm256_fmadd_ps(t, t, d2);
            }
            const __m256 d = _mm256_sqrt_ps(d2);
            __m256 in = _mm256_and_ps(_mm256_cmp_ps(d, cutoff, _CMP_GT_OQ),
                                      _mm256_cmp_ps(d, radius, _CMP_LT_OQ));
            in = _mm256_and_ps(in, _mm256_castsi256_ps(load));
            if (_mm256_testz_ps(in, in)) continue;
            const __m256 u = _mm256_min_ps(_mm256_mul_ps(d, scale), umax);
            const __m256i b = _mm256_min_epi32(_mm256_cvttps_epi32(u), qmax);
            const __m256 f = _mm256_sub_ps(u, _mm256_cvtepi32_ps(b));
            const __m256 w = _mm256_i32gather_ps(job->w, b, 4);
            const __m256 dw = _mm256_i32gather_ps(job->dw, b, 4);
            /* Lanes outside the window may divide by zero; the mask clears them. */
            const __m256 coef = _mm256_and_ps(in, _mm256_div_ps(_mm256_fmadd_ps(f, dw, w), d));
            for (unsigned q = 0; q < k; q++) vacc[q] = _mm256_fmadd_ps(coef, delta[q], vacc[q]);
        }
    }
    for (unsigned q = 0; q < k; q++) acc[q] = hsum(vacc[q]);
}

void dpc_point_avx2(const dpc_sub_job *job, const float *xi, const uint32_t *ranges,
                    unsigned n_ranges, float *acc) {
    switch (job->k) {
    case 1: point_body(job, xi, ranges, n_ranges, acc, 1); break;
    case 2: point_body(job, xi, ranges, n_ranges, acc, 2); break;
    case 3: point_body(job, xi, ranges, n_ranges, acc, 3); break;
    default: point_body(job, xi, ranges, n_ranges, acc, 0); break;
    }
}
