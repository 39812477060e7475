/* Portable reference path: the formula of docs/model-format.md §3, one pair at a time. */
#include <math.h>

#include "cpu/cpu_kernels.h"

/* Round half to even without libm: adding and subtracting 1.5 * 2^23 leaves the nearest integer
 * for |t| < 2^22 under the default rounding mode. Same result as _mm256_round_ps(NEAREST). */
static inline float round_even(float t) {
    const float big = 12582912.0f; /* (t + big) - big is not folded without -ffast-math */
    return (t + big) - big;
}

static void point(const dpc_sub_job *job, const float *xi, const uint32_t *ranges, unsigned n_ranges,
                  float *acc) {
    /* Job fields and sums in locals: the compiler cannot prove `acc` does not alias them. */
    const unsigned k = job->k;
    const float cutoff = job->cutoff, radius = job->radius, scale = job->scale, umax = job->umax;
    const int32_t qmax = job->qmax;
    const float *w = job->w, *dw = job->dw;
    float delta[DPC_MAX_DIMS], sum[DPC_MAX_DIMS], x[DPC_MAX_DIMS];
    for (unsigned q = 0; q < k; q++) {
        sum[q] = 0.0f;
        x[q] = xi[q];
    }
    for (unsigned r = 0; r < n_ranges; r++) {
        for (uint32_t j = ranges[2 * r]; j < ranges[2 * r + 1]; j++) {
            float d2 = 0.0f;
            for (unsigned q = 0; q < k; q++) {
                float t = job->coord[q][j] - x[q];
                t -= round_even(t); /* minimum-image toroidal difference */
                delta[q] = t;
                d2 += t * t;
            }
            const float d = sqrtf(d2);
            if (!(d > cutoff && d < radius)) continue;
            float u = d * scale;
            u = u < umax ? u : umax;
            int32_t b = (int32_t)u;
            b = b < qmax ? b : qmax;
            const float f = u - (float)b;
            const float coef = (w[b] + f * dw[b]) / d;
            for (unsigned q = 0; q < k; q++) sum[q] += coef * delta[q];
        }
    }
    for (unsigned q = 0; q < k; q++) acc[q] = sum[q];
}

void dpc_block_scalar(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges,
                      unsigned n_ranges, float *acc, float *scratch) {
    (void)scratch; /* one candidate at a time: reading the ranges in place gives the same sums */
    for (unsigned p = 0; p < count; p++) point(job, xs + p * job->k, ranges, n_ranges, acc + p * job->k);
}
