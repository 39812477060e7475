/* Threshold masks designed by simulated annealing of their spectra (docs/masks.md, "Annealed
 * masks"): void-and-cluster starts, then rank swaps under a Metropolis rule. */
#ifndef DPC_MASK_MASK_DESIGN_H
#define DPC_MASK_MASK_DESIGN_H

#include <stdint.h>

#include "dpc/dpc.h"

/* Ulichney's void-and-cluster ranks (0 ... n*n - 1, pixel (x, y) at y * n + x) on the torus:
 * Gaussian filter sigma = 1.5 pixels, initial pattern of 10 % ones at random pixels (seed). */
dpc_status dpc_void_and_cluster_ranks(uint32_t n, uint64_t seed, int32_t *ranks);

/* The whole design for checked options: out as dpc_mask_design documents it. */
dpc_status dpc_mask_design_run(const dpc_mask_options *options, uint64_t seed, uint32_t *out, dpc_mask_stats *stats);

/* Bytes of spectra the annealer keeps for these options (checked against DPC_MASK_MAX_STATE). */
uint64_t dpc_mask_state_bytes(uint32_t size, uint32_t frames, uint32_t channels);

#endif
