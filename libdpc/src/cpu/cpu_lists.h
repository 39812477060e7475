/* Verlet neighbour lists for the prefilter of sparse high-dimensional subspaces (cpu_near.h).
 *
 * A build filters every pair once (each pair from its lower index, queries u and m - 1 - u
 * together so threads share the work evenly) at radius list_r = (1 + DPC_LISTS_SKIN) r and
 * keeps, per point, the points that passed, ascending. A later pass of the same subspace reuses them: a point that was
 * farther than list_r from a query at the build is farther than list_r - d_i - d_j now (d: how
 * far each moved since), so it is out of reach unless one of the two moved more than
 * (list_r - r) / 2 (less a margin for float32 distances). Those "hot" points are filtered
 * against all points at radius r, and each pair found is added to both its points' candidates;
 * when more than m / 8 points are hot the lists are rebuilt. Every candidate set is a superset
 * of the points in reach, so the kernel's sums are those of all pairs. */
#ifndef DPC_CPU_LISTS_H
#define DPC_CPU_LISTS_H

#include <stddef.h>
#include <stdint.h>

#include "common/threads.h"
#include "cpu/cpu_kernels.h"
#include "cpu/cpu_near.h"

/* list_r = (1 + DPC_LISTS_SKIN) r */
#define DPC_LISTS_SKIN 0.1

typedef struct dpc_pair_buffer {
    uint32_t *pair; /* 2 per pair */
    size_t n, cap;  /* pairs */
    int failed;     /* out of memory, or more pairs than a point set should have */
} dpc_pair_buffer;

typedef struct dpc_lists {
    size_t m;
    unsigned k;
    uint64_t mask; /* the subspace of the lists; 0: none */
    float list_r;
    uint32_t *near_off, *near; /* CSR: the points within list_r at the build */
    size_t near_cap;
    uint32_t *hot_off, *hot; /* CSR: this pass's pairs of hot points */
    size_t hot_cap;
    float *at;         /* m x k: positions at the build (working order) */
    uint32_t *hot_pts; /* the hot points of this pass */
    uint32_t *scratch; /* per worker: m indices */
    unsigned scratch_slots;
    dpc_pair_buffer buf[DPC_MAX_THREADS];
} dpc_lists;

/* An empty set of lists for m points (allocates on first use). */
void dpc_lists_init(dpc_lists *L, size_t m);
void dpc_lists_free(dpc_lists *L);

/* Make the lists exact for subspace `mask` at the current coordinates (job->coord, job->radius,
 * the codes of `codes`, whose limit is the radius's): reuse, add the hot pairs, or rebuild. 0
 * when they cannot be used (no memory, or a crowded set): the caller filters per query and the
 * lists are dropped. */
int dpc_lists_update(dpc_lists *L, uint64_t mask, const dpc_sub_job *job, const dpc_near_job *codes,
                     dpc_near_points_fn points, unsigned threads);

/* The candidate ranges of point s: the 8-aligned blocks of its listed and hot neighbours, merged
 * (cpu_near.h); their count, or cap + 1 if more than cap. */
unsigned dpc_lists_ranges(const dpc_lists *L, uint32_t s, uint32_t *ranges, unsigned cap);

#endif
