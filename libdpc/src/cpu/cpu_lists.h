/* Verlet neighbour lists for the prefilter of sparse high-dimensional subspaces (cpu_near.h),
 * in two tiers, so that the all-pairs filter runs rarely.
 *
 * A build (positions P0) filters every pair once, each from its lower index, at radius
 * r2 = (1 + DPC_LISTS_WIDE) r: the wide lists. A refresh (positions P1) keeps, of each point's
 * wide list, the points within r1 = (1 + DPC_LISTS_SKIN) r: the near lists, the kernel's
 * candidates. A later pass of the same subspace at radius r uses them while they stay exact:
 * with D2 and D1 how far a point moved since P0 and since P1, a pair now within r was within
 * r + D2_i + D2_j at P0 and within r + D1_i + D1_j at P1. So a point is
 *   - cold when D1 <= (r1 - r) / 2 and D2 <= (r2 - r) / 2: its pairs with cold points are in
 *     its near list;
 *   - warm when D1 is larger but D2 is not: its pairs with points that are not far are in its
 *     wide list, which is filtered at r for it;
 *   - far when D2 > (r2 - r) / 2: filtered against all points (the vector filter).
 * (less a margin for float32 distances). The pairs found for warm and far points are added to
 * both points' candidates. When many points are warm the near lists are refreshed from the wide
 * ones (far points excepted, which are still filtered each pass); when many are far, the lists
 * are rebuilt. Every candidate set is a superset of the points in reach, so the kernel's sums
 * are those of all pairs. */
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
    uint32_t *near_len, *near; /* near[wide_off[i] ...], near_len[i] long: those within r1 at the refresh */
    uint32_t *hot_off, *hot;   /* CSR: this pass's pairs of warm and far points, ascending (repeats possible) */
    size_t hot_cap;
    float *at_build, *at_refresh; /* the rows (job->row) at the build (P0) and at the refresh (P1) */
    uint8_t *heat;                /* per point: 0 cold, 1 warm, 2 far */
    uint32_t *hot_pts;            /* this pass's warm and far points */
    uint32_t *far_pts;            /* this pass's far points */
    size_t n_far;
    double far_work, warm_work; /* far points' pairs scanned since the build, warm points since the refresh */
    uint8_t *rows;              /* m x row_bytes: the codes as rows (cpu_near.h) */
    unsigned row_bytes;
    uint32_t *scratch; /* per worker: m indices */
    unsigned scratch_slots;
    dpc_pair_buffer buf[DPC_MAX_THREADS];
    size_t builds, refreshes, hot_passes; /* how often each path ran (the tests and the bench read them) */
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
