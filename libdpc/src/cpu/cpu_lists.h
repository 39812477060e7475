/* Verlet neighbour lists for the prefilter of sparse high-dimensional subspaces (cpu_near.h),
 * in two tiers, so that the all-pairs filter runs rarely.
 *
 * Every point has an anchor A (its position at the build, or at its last re-anchoring), and the
 * lists keep this invariant: two points whose anchors are within r2 = (1 + DPC_LISTS_WIDE) r of
 * each other are in each other's wide-or-extra list (W). A build sets every anchor and filters
 * every pair once, each from its lower index, at r2: the wide lists. A refresh (positions P1)
 * keeps, of each point's W, the points within r1 = (1 + DPC_LISTS_SKIN) r: the near lists, the
 * kernel's candidates. A later pass of the same subspace at radius r uses them while they stay
 * exact: with D2 and D1 how far a point moved since its anchor and since P1, a pair now within r
 * was within r + D2_i + D2_j at the anchors and within r + D1_i + D1_j at P1. So a point is
 *   - cold when D1 <= (r1 - r) / 2 and D2 <= (r2 - r) / 2: its pairs with cold points are in
 *     its near list;
 *   - warm when D1 is larger but D2 is not: its pairs with points that are not far are in its W,
 *     which is filtered at r for it;
 *   - far when D2 > (r2 - r) / 2: it is re-anchored where it is now and filtered at r2 against
 *     every point's anchor (the vector filter, on the anchors' codes); the pairs found join the
 *     extra lists of both points, and it is warm from then on.
 * (less a margin for float32 distances). The pairs found for warm points are added to both
 * points' candidates. When many points are warm the near lists are refreshed; when many are far
 * at once, or the extra lists outgrow the wide ones, the lists are rebuilt. Every candidate set
 * is a superset of the points in reach, so the kernel's sums are those of all pairs. */
#ifndef DPC_CPU_LISTS_H
#define DPC_CPU_LISTS_H

#include <stddef.h>
#include <stdint.h>

#include "common/threads.h"
#include "cpu/cpu_kernels.h"
#include "cpu/cpu_near.h"

/* r1 = (1 + DPC_LISTS_SKIN) r: the near lists, which the kernel visits every pass */
#define DPC_LISTS_SKIN 0.1
/* r2 = (1 + DPC_LISTS_WIDE) r: the wide lists, which only refreshes and warm points visit */
#define DPC_LISTS_WIDE 0.25

typedef struct dpc_pair_buffer {
    uint32_t *pair; /* 2 per pair */
    size_t n, cap;  /* pairs */
    int failed;     /* out of memory, or more pairs than a point set should have */
} dpc_pair_buffer;

typedef struct dpc_lists {
    size_t m;
    unsigned k;
    uint64_t mask; /* the subspace of the lists; 0: none */
    float r1, r2;
    uint32_t *wide_off, *wide; /* CSR: the points within r2 at the build, ascending */
    size_t wide_cap;
    uint32_t *extra_off, *extra; /* CSR: the pairs found for re-anchored points since the build, ascending */
    size_t extra_cap;
    uint32_t *extra_pair; /* those pairs, 2 per pair */
    size_t n_extra_pair, extra_pair_cap;
    uint8_t *anchor_code;                 /* code columns (cpu_near.h) of every point's anchor (its row in at_build) */
    uint32_t *near_off, *near_len, *near; /* near[near_off[i] ...], near_len[i] long: those within r1 at the refresh */
    size_t near_cap;
    uint32_t *hot_off, *hot; /* CSR: this pass's pairs of warm and far points, ascending (repeats possible) */
    size_t hot_cap;
    float *at_build,
        *at_refresh; /* each point's anchor (its row at the build, or at its re-anchoring) and its row at the refresh */
    uint8_t *heat;   /* per point: 0 cold, 1 warm, 2 far */
    uint32_t *hot_pts; /* this pass's warm and far points */
    uint32_t *far_pts; /* this pass's far points */
    size_t n_far;
    double warm_work; /* warm points handled since the refresh */
    uint8_t *rows;    /* m x row_bytes: the codes as rows (cpu_near.h); row_bytes = job->row_stride */
    unsigned row_bytes;
    uint32_t *scratch; /* per worker: m indices */
    unsigned scratch_slots;
    dpc_pair_buffer buf[DPC_MAX_THREADS];
    size_t builds, refreshes, hot_passes, reanchors; /* how often each path ran (the tests read them) */
} dpc_lists;

/* An empty set of lists for m points (allocates on first use). */
void dpc_lists_init(dpc_lists *L, size_t m);
void dpc_lists_free(dpc_lists *L);

/* Make the lists exact for subspace `mask` at the current coordinates (job->row, job->radius,
 * the codes of `codes`, whose limit is the radius's; the filters `points` and `list`): reuse, add the hot pairs, refresh or
 * rebuild. 0 when they cannot be used (no memory, or a crowded set): the caller filters per
 * query and the lists are dropped. */
int dpc_lists_update(dpc_lists *L, uint64_t mask, const dpc_sub_job *job, const dpc_near_job *codes,
                     dpc_near_points_fn points, dpc_near_list_fn list, unsigned threads);

/* The candidates of point s: its near list and hot pairs merged, ascending, without repeats and
 * without s (a dpc_list_fn's input), *n of them: the near list itself when s has no hot pairs,
 * else merged into buf; NULL if more than cap would be needed. */
const uint32_t *dpc_lists_candidates(const dpc_lists *L, uint32_t s, uint32_t *buf, unsigned cap, unsigned *n);

#endif
