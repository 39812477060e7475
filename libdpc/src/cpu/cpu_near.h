/* The neighbour prefilter of large all-pairs subspaces (cpu_near.c, cpu_near_avx2.c). */
#ifndef DPC_CPU_NEAR_H
#define DPC_CPU_NEAR_H

#include <stddef.h>
#include <stdint.h>

#include "dpc/dpc.h"

/* Large all-pairs subspaces (k >= 5, where no cell grid pays: a
 * 10-D radius is nearly half the torus on every axis, yet only a few points lie in its ball).
 * Coordinates are coded c = floor(256 x) (exact: x in [0, 1)), two subspace dimensions per
 * 16-bit lane. For a query i, a point j passes when
 *     sum_q max(|wrap(c_jq - c_iq)| - 1, 0)^2 <= limit,   wrap: the difference mod 256 in [-128, 127],
 * a lower bound of (256 x the torus distance)^2, so every point within the radius passes when
 * limit >= (256 r)^2. The output is the 8-aligned candidate blocks [8b, 8b + 8) (cut at m) that
 * hold a passing point, as merged ascending index ranges: each but the last is a multiple of 8
 * long, so every candidate keeps its canonical lane j mod 8 and the kernel's sums are bit for
 * bit those of all pairs (a block with no point in the window adds nothing to any lane). */
typedef struct dpc_near_job {
    unsigned pairs;                        /* ceil(k / 2) */
    const uint8_t *code[DPC_MAX_DIMS / 2]; /* code[p][2j + e]: c of subspace dimension 2p + e of point j
                                            * (0 for the missing one of odd k); readable 128 bytes past 2m */
    uint32_t m;
    uint32_t limit; /* below 65535 */
} dpc_near_job;
/* The ranges of query `query` (< m) into ranges[2r], ranges[2r + 1]; returns their count, or
 * cap + 1 if more than cap would be needed (then the caller scans all pairs). */
typedef unsigned (*dpc_near_fn)(const dpc_near_job *job, uint32_t query, uint32_t *ranges, unsigned cap);

unsigned dpc_near_scalar(const dpc_near_job *job, uint32_t query, uint32_t *ranges, unsigned cap);
#if defined(DPC_HAVE_AVX2)
unsigned dpc_near_avx2(const dpc_near_job *job, uint32_t query, uint32_t *ranges, unsigned cap);
#endif

/* The same test, the passing points themselves: the indices j >= from (query included when it
 * is among them), ascending, into out; returns their count, or cap + 1 if more than cap pass. */
typedef unsigned (*dpc_near_points_fn)(const dpc_near_job *job, uint32_t query, uint32_t from, uint32_t *out,
                                       unsigned cap);
unsigned dpc_near_points_scalar(const dpc_near_job *job, uint32_t query, uint32_t from, uint32_t *out, unsigned cap);
#if defined(DPC_HAVE_AVX2)
unsigned dpc_near_points_avx2(const dpc_near_job *job, uint32_t query, uint32_t from, uint32_t *out, unsigned cap);
unsigned dpc_near_points_avx512(const dpc_near_job *job, uint32_t query, uint32_t from, uint32_t *out, unsigned cap);
#endif

/* Append block b (cut at m) to the ranges, merged with the last one when adjacent; returns 0 when
 * a new range would exceed cap. */
static inline int dpc_near_add_block(uint32_t *ranges, unsigned *n, unsigned cap, uint32_t b, uint32_t m) {
    const uint32_t lo = 8 * b, hi = lo + 8 < m ? lo + 8 : m;
    if (lo >= m) return 1;
    if (*n && ranges[2 * *n - 1] == lo) {
        ranges[2 * *n - 1] = hi;
        return 1;
    }
    if (*n == cap) return 0;
    ranges[2 * *n] = lo;
    ranges[2 * *n + 1] = hi;
    (*n)++;
    return 1;
}

/* The same test for a few candidates of one query, on rows: rows[j * row_bytes + q] is the code
 * of subspace dimension q of point j (0 past k; row_bytes a multiple of 16). The candidates
 * cand[0 .. n) that pass, in order, into out; returns their count. (The lists' refreshes and
 * their moved points' candidates: a few dozen per query, where a scan over all m would not pay.) */
typedef unsigned (*dpc_near_list_fn)(const uint8_t *rows, unsigned row_bytes, uint32_t query, const uint32_t *cand,
                                     unsigned n, uint32_t limit, uint32_t *out);
unsigned dpc_near_list_scalar(const uint8_t *rows, unsigned row_bytes, uint32_t query, const uint32_t *cand, unsigned n,
                              uint32_t limit, uint32_t *out);
#if defined(DPC_HAVE_AVX2)
unsigned dpc_near_list_avx2(const uint8_t *rows, unsigned row_bytes, uint32_t query, const uint32_t *cand, unsigned n,
                            uint32_t limit, uint32_t *out);
#endif

/* The limit for radius r (absolute, below 0.99: the limit stays below 65535): (256 r)^2 with a margin of 0.1% and 2 codes
 * for the float32 rounding of the kernel's squared distances. */
static inline uint32_t dpc_near_limit(float r) {
    const double u = 256.0 * (double)r;
    return (uint32_t)(u * u * (1.0 + 1.0 / 1024.0)) + 2u;
}

#endif
