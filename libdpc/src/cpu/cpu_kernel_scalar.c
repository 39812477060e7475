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
    const unsigned k = job->k;
    float delta[DPC_MAX_DIMS];
    for (unsigned q = 0; q < k; q++) acc[q] = 0.0f;
    for (unsigned r = 0; r < n_ranges; r++) {
        for (uint32_t j = ranges[2 * r]; j < ranges[2 * r + 1]; j++) {
            float d2 = 0.0f;
            for (unsigned q = 0; q < k; q++) {
                float t = job->coord[q][j] - xi[q];
                t -= round_even(t); /* minimum-image toroidal difference */
                delta[q] = t;
                d2 += t * t;
            }
            const float d = sqrtf(d2);
            if (!(d > job->cutoff && d < job->radius)) continue;
            float u = d * job->scale;
            u = u < job->umax ? u : job->umax;
            int32_t b = (int32_t)u;
            b = b < job->qmax ? b : job->qmax;
            const float f = u - (float)b;
            const float coef = (job->w[b] + f * job->dw[b]) / d;
            for (unsigned q = 0; q < k; q++) acc[q] += coef * delta[q];
        }
    }
}

void dpc_block_scalar(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges,
                      unsigned n_ranges, float *acc) {
    for (unsigned p = 0; p < count; p++) point(job, xs + p * job->k, ranges, n_ranges, acc + p * job->k);
}
