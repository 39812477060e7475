/* The hot loop of a filter layer, compiled once per ISA from cpu_kernel_body.h and chosen at
 * load time. A kernel accumulates, for one point x_i, sum_j g(d_ij) * delta_ij / d_ij over
 * candidate neighbours given as index ranges into structure-of-arrays coordinates
 * (docs/model-format.md §3, without the final factor h_t). Every ISA path evaluates the canonical
 * order of float32 operations (format §3, "Evaluation order"), so all give the same bits. */
#ifndef DPC_CPU_KERNELS_H
#define DPC_CPU_KERNELS_H

#include <stddef.h>
#include <stdint.h>

#include "dpc/dpc.h"

typedef struct dpc_sub_job {
    unsigned k; /* dimensions in the subspace */
    /* coord[q][j]: dimension q of candidate j. Each column is readable (and finite) for 16 floats
     * past any range end, so SIMD kernels load whole vectors and mask the extra lanes. */
    const float *coord[DPC_MAX_DIMS];
    float radius;    /* r_t (absolute) */
    float cutoff;    /* e_t (absolute) */
    float scale;     /* (b - 1) / r_t */
    float umax;      /* b - 1 */
    int32_t qmax;    /* b - 2 */
    const float *w;  /* kernel table, b values */
    const float *dw; /* w[q+1] - w[q] */
    /* The list kernel's rows (dpc_list_fn): row[j * row_stride + q] is coordinate q of point j,
     * zero for q >= k; row_stride a multiple of 16. NULL where no list kernel runs. */
    const float *row;
    unsigned row_stride;
} dpc_sub_job;

/* Sums for `count` query points that share the candidate ranges (the points of one cell, or a
 * block of points for all pairs, or one point's prefiltered ranges): xs[p * k + q] is dimension
 * q of query p, the sums go to acc[p * k + q]. ranges[2r], ranges[2r+1]: half-open candidate
 * index range r. scratch (k <= 4 columns of DPC_GATHER_STRIDE floats, or NULL): SIMD kernels
 * copy up to DPC_GATHER_CAP candidates of several ranges into one run there, so vectors are
 * full and the loop has one predictable trip count; the sums are those of the ranges in order.
 * Without scratch, several ranges are read in place and each but the last must be a multiple of
 * 8 long (cpu_near.h), so candidates keep their lanes in the concatenation. local (k <= 4): the
 * caller promises that every candidate differs from every query by at most 1/2 in each
 * coordinate without going round the torus (a grid cell away from the domain's edges), so the
 * minimum-image step is skipped: the same bits, two operations fewer per dimension. */
#define DPC_BLOCK_MAX 64u
#define DPC_GATHER_CAP 4096u
#define DPC_GATHER_STRIDE (DPC_GATHER_CAP + 32u)
typedef void dpc_block_kernel(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges,
                              unsigned n_ranges, int local, float *acc, float *scratch);
typedef dpc_block_kernel *dpc_block_fn;

dpc_block_kernel dpc_block_scalar;
/* Sums for one query point x (k floats) over an explicit candidate list: cand[0 .. n), ascending
 * indices without repeats, holding every point in the window eps < d < r (the neighbour lists of
 * cpu_lists.h), read from job->row. Each candidate's term is computed with the block kernel's
 * operations (the same bits) and added to its canonical lane (index mod 8) in ascending index
 * order: the sums of all pairs [0, m) bit for bit, since every candidate left out is outside the
 * window and would add +0 (and a sum that starts at +0 never becomes -0, so adding +0 or -0
 * changes no bit either). */
typedef void dpc_list_kernel(const dpc_sub_job *job, const float *x, const uint32_t *cand, unsigned n, float *acc);
typedef dpc_list_kernel *dpc_list_fn;
dpc_list_kernel dpc_list_scalar;
#if defined(DPC_HAVE_AVX2)
dpc_list_kernel dpc_list_scalar_fma, dpc_list_avx2, dpc_list_avx512;
dpc_block_kernel dpc_block_scalar_fma, dpc_block_avx2, dpc_block_avx512;
#endif

#endif
