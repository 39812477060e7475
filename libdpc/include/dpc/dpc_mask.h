/*
 * dpc_mask.h: threshold masks designed by annealing (dpc_mask_design).
 * dpc.h includes it (include dpc.h); on its own it includes dpc.h for the common types and
 * conventions. docs/masks.md states the design (the energy and its constants) and its
 * measurements.
 *
 * dpc_mask_design makes dpc's `annealed` blue-noise masks, the ones dpc.masks serves:
 * void-and-cluster per frame or channel, then simulated annealing of rank swaps on a spectral
 * energy of the mask and of its thresholded patterns (for a spatiotemporal mask also along time,
 * for a vector mask also of the joint patterns).
 * - Masks tile (toroidal) and are rank-exact: each frame (or channel) holds every rank
 *   0 ... N*N - 1 once. The threshold value of rank r is (r + 1/2) / (N*N).
 * - out_ranks[((f * N + y) * N + x) * C + c]: frame f, pixel (x, y), channel c (C = channels).
 * - Deterministic: the same ranks for the same options and seed on every machine and compiler.
 * - Cost: O(N^4) time on the calling thread; steps_per_pixel = 0 gives the void-and-cluster start
 *   alone. Memory: 16 * 64 * (T * C * F + N * N * (T / 2 + 1 if T > 1)) bytes, F about 0.22 N^2
 *   frequencies, at most DPC_MASK_MAX_STATE (else DPC_ERROR_LIMIT before any allocation).
 * - Threads: calls share no state; any number may run at once (on distinct output buffers).
 */
#ifndef DPC_DPC_MASK_H
#define DPC_DPC_MASK_H

#include "dpc.h"

#ifdef __cplusplus
extern "C" {
#endif

#define DPC_MASK_MAX_SIZE 1024u
#define DPC_MASK_MAX_FRAMES 1024u
#define DPC_MASK_MAX_STATE (8ull << 30)

typedef struct dpc_mask_options {
    uint32_t struct_size;     /* sizeof(dpc_mask_options), set by dpc_mask_options_init */
    uint32_t size;            /* N: N x N pixels, 8 .. DPC_MASK_MAX_SIZE (default 64) */
    uint32_t frames;          /* T: 1 (default), or 2 .. DPC_MASK_MAX_FRAMES for a spatiotemporal mask */
    uint32_t channels;        /* 1 (default), or 2 for a vector mask, blue per channel and jointly (frames 1) */
    uint32_t steps_per_pixel; /* annealing proposals per pixel and frame or channel (default 600) */
    /* NULL (default): none. Called with done / total = proposals made / steps_per_pixel * N*N * T*C,
     * every 65,536 proposals and at the end; before the first proposal (the void-and-cluster
     * start, the first spectra) with done = 0 every few million inner steps, as a poll (total
     * then at least 1, also when steps_per_pixel is 0). Nonzero stops with DPC_ERROR_CANCELLED. */
    dpc_progress_fn progress;
    void *user; /* passed to progress */
} dpc_mask_options;

/* Energies of the design, for diagnostics: at the void-and-cluster start, at the end, and the
 * number of swaps the annealer accepted. */
typedef struct dpc_mask_stats {
    double energy_start, energy_end;
    uint64_t accepted;
} dpc_mask_stats;

/* Fill *options with the defaults (a 64 x 64 scalar mask, 600 proposals per pixel). */
DPC_API void dpc_mask_options_init(dpc_mask_options *options);
/* *out_count = frames * size * size * channels, the uint32 values dpc_mask_design writes. */
DPC_API dpc_status dpc_mask_count(const dpc_mask_options *options, size_t *out_count);
/* Design a mask (see above) into out_ranks (dpc_mask_count values); out_stats may be NULL. On
 * failure out_ranks is left unspecified. */
DPC_API dpc_status dpc_mask_design(const dpc_mask_options *options, uint64_t seed, uint32_t *out_ranks,
                                   dpc_mask_stats *out_stats);

#ifdef __cplusplus
}
#endif

#endif /* DPC_DPC_MASK_H */
