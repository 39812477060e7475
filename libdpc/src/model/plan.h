/* The subspace plan: what every backend derives alike from one subspace of one layer at a
 * point count m (docs/model-format.md §3): its dimensions, whether it moves anything, the mean
 * spacing h_t, the radius r_t = min(rho_t h_t, 1/2), the cutoff e_t = eps h_t, the bin scale
 * (b - 1) / r_t, and the neighbour search (a toroidal cell grid of G cells per axis searched R
 * cells each side, or all pairs); and per layer the subspace counts c_k of the normalised sum.
 *
 * One function computes them for the CPU engine and the Vulkan host code (float32: every value
 * is the float32 result of the format's float arithmetic) and for the float64 training kernels
 * (float64), so the backends cannot drift apart. The search choice depends on r_t, so a float32
 * plan and a float64 plan of the same subspace decide from their own radius. */
#ifndef DPC_MODEL_PLAN_H
#define DPC_MODEL_PLAN_H

#include <stddef.h>
#include <stdint.h>

#include "model/model.h"

typedef enum dpc_plan_precision {
    DPC_PLAN_F32 = 0, /* inference (CPU engine, Vulkan): float32 arithmetic */
    DPC_PLAN_F64 = 1  /* training kernels: float64 arithmetic */
} dpc_plan_precision;

/* Index ranges a grid point's candidates may span (2 per row of cells): the CPU engine and the
 * training kernels size their range buffers by it. */
#define DPC_PLAN_MAX_RANGES 512u
/* Cells a grid may have at m points: 2m + DPC_PLAN_CELL_SLACK (the buffers are sized by it). */
#define DPC_PLAN_CELL_SLACK 64u

typedef struct dpc_sub_plan {
    unsigned k;                 /* |D_t| */
    unsigned dim[DPC_MAX_DIMS]; /* subspace axis q -> point dimension */
    int moves;                  /* some dimension of D_t is not fixed (else every backend skips it) */
    /* In the plan's precision; a float32 plan's values are float32 numbers (exact in double). */
    double h;      /* m^(-1/k) */
    double r;      /* min(rho h, 1/2) */
    double e;      /* eps h */
    double scale;  /* (b - 1) / r */
    double umax;   /* b - 1 */
    int32_t qmax;  /* b - 2 */
    int grid;      /* 1: cell grid, 0: all pairs */
    uint32_t G, R; /* grid: cells per axis, cells searched each side */
} dpc_sub_plan;

/* The plan of subspace `mask` (nonzero, bits < DPC_MAX_DIMS) of a layer that fixes `fixed`, with
 * radius rho and cutoff eps in spacings and b bins, at m >= 1 points. For DPC_PLAN_F32, rho and
 * eps are the file's float32 values (converted to double exactly). */
void dpc_plan_subspace(uint64_t mask, uint64_t fixed, double rho, double eps, uint32_t bins, size_t m,
                       dpc_plan_precision precision, dpc_sub_plan *out);

/* The neighbour search for a k-D subspace of radius r (absolute) at m points: 1 and *G_out,
 * *R_out for a cell grid, 0 for all pairs. About 2 cells per radius in 1-2-D and 1 in 3-4-D
 * (finer cells visit less area), at most ~2m cells and 16384 per axis, a margin of 1e-3 cells
 * for the rounding of cell coordinates; all pairs for k > 4, m < 64, fewer than 3 cells per axis,
 * a cell visited twice, or a search that would visit more than half the domain anyway. */
int dpc_plan_search(unsigned k, double r, size_t m, uint32_t *G_out, uint32_t *R_out);

/* c_k for each of the n dimensions of a layer: how many of its subspaces contain dimension k,
 * 0 for fixed dimensions (they never move). */
void dpc_plan_counts(unsigned n, unsigned n_sub, const uint64_t *masks, uint64_t fixed, unsigned *count);

/* The points expected within rho mean spacings of a point in k dimensions: V_k rho^k (V_k the
 * volume of the unit k-ball). */
double dpc_plan_in_reach(unsigned k, double rho);

/* The largest expected neighbour count per point of any moving subspace of the cascade, V_k rho^k
 * (V_k = pi^(k/2) / Gamma(k/2 + 1), the unit k-ball); dpc_load_options.max_neighbours bounds it. */
double dpc_plan_neighbours(const dpc_cascade *c);

#endif
