/*
 * dpc_layer.h: training support, one filter layer in float64 (dpc_layer_*).
 * dpc.h includes it (include dpc.h); on its own it includes dpc.h for the common types and
 * conventions. The backward pass's formulas: docs/training.md.
 *
 * The forward and backward passes of one PointFilter layer (docs/model-format.md §3) for a
 * training framework.
 * - Everything is float64 (h_t, distances, sums): results match the float64 reference of the
 *   format to rounding, not the float32 cascade of dpc_generate bit for bit.
 * - Work is O(m * neighbours) per set, memory O(m * n + cells); never O(m^2).
 * - Outputs are bit-identical for every thread count. The kernels run on the ISA path of
 *   dpc_layer_options.isa; DPC_ISA_AUTO (the default, and what dpc_layer_forward / _backward use)
 *   is the path the inference engine would pick: the environment variable DPC_ISA, else the best
 *   the CPU has; a bad DPC_ISA (DPC_ERROR_INVALID_ARGUMENT) or a path the CPU lacks
 *   (DPC_ERROR_UNSUPPORTED) fails the call as it fails a model's load.
 *   Paths differ by rounding only; each gives the same bits on every machine that has it.
 * - Backward is the derivative of forward for a scalar loss L, with the wrap y - floor(y) treated
 *   as the identity; gradients flow into fixed coordinates too (they shape distances). Pairs
 *   exactly at d = e_t or d = r_t, and distances exactly on a bin edge, are kinks where it is a
 *   one-sided derivative.
 * - Threads: any number of calls may run at once (on distinct output buffers).
 */
#ifndef DPC_DPC_LAYER_H
#define DPC_DPC_LAYER_H

#include "dpc.h"

#ifdef __cplusplus
extern "C" {
#endif

/* One PointFilter layer, as in a model file. */
typedef struct dpc_layer_desc {
    uint32_t dims;             /* n: 1 .. DPC_MAX_DIMS */
    uint32_t n_subspaces;      /* s: 1 .. 64 */
    uint32_t bins;             /* b: 2 .. 65536 */
    const uint64_t *subspaces; /* s bitmasks: nonzero, only bits < n, pairwise distinct */
    const double *radius;      /* s values rho_t in units of h_t: finite, 0 < rho_t <= 1e6 */
    double eps;                /* cutoff in units of h_t: finite, >= 0 */
    uint64_t fixed;            /* dimensions the layer never moves: only bits < n */
} dpc_layer_desc;

/* How a layer call runs. Initialise with dpc_layer_options_init(). */
typedef struct dpc_layer_options {
    uint32_t struct_size; /* sizeof(dpc_layer_options), set by dpc_layer_options_init */
    uint32_t threads;     /* worker threads: 1 (default), 0 = one per online CPU; bits do not depend on it */
    dpc_isa isa;          /* the pair loop's ISA path; default DPC_ISA_AUTO (see above) */
} dpc_layer_options;

/* Fill *options with the defaults. */
DPC_API void dpc_layer_options_init(dpc_layer_options *options);

/* y = layer(x) for count sets of n_points points each: x and y hold count * n_points * dims
 * doubles (set c at offset c * n_points * dims), x finite and in [0, 1). kernels: s * b finite
 * values, row t = subspace t (in units of h_t). y may be x (in place); otherwise the buffers must
 * not overlap. options may be NULL (defaults). */
DPC_API dpc_status dpc_layer_forward_ex(const dpc_layer_desc *layer, const double *kernels, size_t count,
                                        size_t n_points, const double *x, double *y, const dpc_layer_options *options);

/* Gradients of a scalar loss L given grad_y = dL/dy (same shape as x, finite): grad_x = dL/dx
 * (same shape; may be grad_y) and grad_kernels = dL/dkernels (s * b, overwritten, summed over the
 * count sets in set order). Other outputs must not overlap the inputs. options may be NULL. */
DPC_API dpc_status dpc_layer_backward_ex(const dpc_layer_desc *layer, const double *kernels, size_t count,
                                         size_t n_points, const double *x, const double *grad_y, double *grad_x,
                                         double *grad_kernels, const dpc_layer_options *options);

/* dpc_layer_forward_ex / _backward_ex with options {threads, DPC_ISA_AUTO}. */
DPC_API dpc_status dpc_layer_forward(const dpc_layer_desc *layer, const double *kernels, size_t count, size_t n_points,
                                     const double *x, double *y, uint32_t threads);
DPC_API dpc_status dpc_layer_backward(const dpc_layer_desc *layer, const double *kernels, size_t count, size_t n_points,
                                      const double *x, const double *grad_y, double *grad_x, double *grad_kernels,
                                      uint32_t threads);

#ifdef __cplusplus
}
#endif

#endif /* DPC_DPC_LAYER_H */
