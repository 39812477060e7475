/* Internals shared by the training kernels' driver (cpu_layer_train.c) and its per-ISA pair
 * loops (cpu_layer_train_scalar.c, _avx2.c, _avx512.c): the layer plan, the per-worker
 * workspace and one pass (one subspace of one set). */
#ifndef DPC_CPU_LAYER_TRAIN_IMPL_H
#define DPC_CPU_LAYER_TRAIN_IMPL_H

#include <stddef.h>
#include <stdint.h>

#include "cpu/cpu_layer_train.h"
#include "model/plan.h"

#define DPC_TRAIN_MAX_RANGES DPC_PLAN_MAX_RANGES /* candidate index ranges per cell (2 per row of cells) */
#define DPC_TRAIN_PAD 16u                        /* entries readable past the m-th of each packed column */

/* One subspace: the plan's values (model/plan.h, float64) and what the pair loops derive. */
typedef struct dpc_train_sub {
    unsigned k;                  /* |D_t| */
    unsigned dim[DPC_MAX_DIMS];  /* subspace axis q -> point dimension */
    double vscale[DPC_MAX_DIMS]; /* h_t / c_k for moving dims, 0 for fixed ones */
    int moves;                   /* some dimension of D_t moves (else the subspace is skipped) */
    double h, r, e;              /* spacing, radius, cutoff (absolute) */
    double r2_keep, e2_keep;     /* d² >= r2_keep implies d >= r, d² <= e2_keep implies d <= e */
    float r2_f, e2_f;            /* the same for d² from float32 coordinates (vector filters) */
    double scale;                /* (b - 1) / r */
    const double *w;             /* b kernel values */
    int grid;                    /* 0: all pairs */
    uint32_t G, R;               /* cells per axis, cells searched each side */
} dpc_train_sub;

typedef struct dpc_train_pass dpc_train_pass;

/* Sorted positions [lo, hi) of the current pass: per point the gathered sums go to ws->acc, and
 * (backward) the chunk's kernel gradient to part (b doubles, zeroed by the caller). */
typedef void (*dpc_train_chunk_fn)(const dpc_train_pass *ps, size_t lo, size_t hi, double *part);

/* The whole pass on one worker, each unordered pair once (vector paths; see cpu_layer_train_simd.h):
 * sums go to ws->acc, the kernel gradient to part (zeroed by the caller). */
typedef void (*dpc_train_set_fn)(const dpc_train_pass *ps, double *part);

typedef struct dpc_train_plan {
    size_t m, n;
    unsigned s, b;
    dpc_train_sub *sub;
    double count[DPC_MAX_DIMS]; /* c_k, 0 where dimension k does not move */
    size_t chunk, n_chunks;     /* kernel-gradient chunks over sorted positions */
    size_t max_cells;
    unsigned kmax;               /* largest k of a moving subspace */
    size_t stride;               /* entries per packed column: m + DPC_TRAIN_PAD, rounded up to 16 */
    dpc_train_chunk_fn chunk_fn; /* the ISA's pair loop */
    dpc_train_set_fn set_fn;     /* the ISA's unordered-pair pass; NULL: chunks only */
} dpc_train_plan;

typedef struct dpc_train_ws {
    double *P, *V;        /* kmax columns of `stride`: subspace coordinates / v, in sorted order */
    double *A;            /* kmax columns of `stride`: per-point sums of set_fn, in sorted order */
    float *Pf;            /* kmax columns of `stride`: P rounded to float32 (vector paths) */
    double *acc;          /* m · n: per-point sums over subspaces (caller's order) */
    uint32_t *perm;       /* sorted position -> point */
    uint32_t *cell;       /* sorted position -> cell id */
    uint32_t *cell_start; /* max_cells + 1 */
    double *gk;           /* s · b: this set's kernel gradient */
    double *part;         /* b per chunk in flight: chunk partial sums of the kernel gradient */
} dpc_train_ws;

struct dpc_train_pass {
    const dpc_train_plan *p;
    const dpc_train_sub *sp;
    dpc_train_ws *ws;
    const double *gy; /* this set's dL/dy, NULL forward */
};

void dpc_train_chunk_scalar(const dpc_train_pass *ps, size_t lo, size_t hi, double *part);
#if defined(DPC_HAVE_AVX2)
void dpc_train_chunk_avx2(const dpc_train_pass *ps, size_t lo, size_t hi, double *part);
void dpc_train_chunk_avx512(const dpc_train_pass *ps, size_t lo, size_t hi, double *part);
void dpc_train_set_avx2(const dpc_train_pass *ps, double *part);
void dpc_train_set_avx512(const dpc_train_pass *ps, double *part);
#endif

#endif
