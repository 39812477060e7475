/* The prefix relaxation of docs/model-format.md §6.1: after a progressive model's levels, the
 * generator of a model with metadata "dpc.relax" = S moves every point at once, by S gradient
 * steps on a sum over the set's prefixes of Gaussian pair energies and low-frequency terms, so
 * that every prefix of base * 2^j points and the whole set are each as blue as a set made for
 * their size (docs/progressive.md, "Jointly relaxed prefixes"). Plain double arithmetic in a
 * fixed order (common/detmath.h), so the points are the same bits on every machine. */
#ifndef DPC_MODEL_RELAX_H
#define DPC_MODEL_RELAX_H

#include <stddef.h>
#include <stdint.h>

#include "dpc/dpc.h"

#define DPC_RELAX_MAX_STEPS 100000u
#define DPC_RELAX_REFRESH 10u /* steps between neighbour searches */

/* A hook asked before every step whether to go on (DPC_OK) or stop (any other status; the points
 * are then left as they were). NULL: never stopped. */
typedef dpc_status (*dpc_relax_hook)(void *ctx);

/* Relax m 2-D points (each coordinate in [0, 1)) in place: the prefixes are base * 2^j < m and
 * the whole set, steps gradient steps (§6.1), on up to `threads` threads (1 .. DPC_MAX_THREADS;
 * the same bits for any count). DPC_ERROR_OUT_OF_MEMORY or a hook's status leaves the points as
 * they were. */
dpc_status dpc_relax_points(float *x, size_t m, uint32_t base, uint32_t steps, unsigned threads, dpc_relax_hook hook,
                            void *ctx);

#endif
