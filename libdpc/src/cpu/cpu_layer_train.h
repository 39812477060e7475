/* Training kernels: forward and backward of one PointFilter layer in float64 (see the
 * "Training support" section of dpc.h for the formulas). The caller (api.c) has validated every
 * argument; these functions fail only for lack of memory. */
#ifndef DPC_CPU_LAYER_TRAIN_H
#define DPC_CPU_LAYER_TRAIN_H

#include <stddef.h>
#include <stdint.h>

#include "dpc/dpc.h"

typedef struct dpc_train_layer {
    unsigned n, s, b;      /* dims, subspaces, bins */
    const uint64_t *masks; /* s subspace bitmasks */
    const double *radius;  /* s values rho_t */
    double eps;
    uint64_t fixed;
    const double *w; /* s * b kernel values */
} dpc_train_layer;

/* y = layer(x) for `count` sets of m points (count * m * n doubles each; y may equal x), on
 * `threads` workers (0: one per online CPU) and the pair loop of `isa` (AUTO: as the inference
 * engine resolves it; a path this build or CPU lacks, or a bad DPC_ISA, fails as there). */
dpc_status dpc_train_forward(const dpc_train_layer *L, size_t count, size_t m, const double *x, double *y,
                             unsigned threads, dpc_isa isa);

/* grad_x (may equal gy) and grad_w (s * b, overwritten, summed over the sets) from gy = dL/dy. */
dpc_status dpc_train_backward(const dpc_train_layer *L, size_t count, size_t m, const double *x, const double *gy,
                              double *grad_x, double *grad_w, unsigned threads, dpc_isa isa);

#endif
