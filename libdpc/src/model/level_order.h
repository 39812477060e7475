/* The order within a progressive model's levels (docs/model-format.md §6): a level's new points
 * are put in the order that fills the largest gaps first, so that a prefix ending inside a level
 * (a sampler stopped at a sample count that is not a level size) holds well-spread points. It
 * changes no level's set of points, only their order. Plain double arithmetic (+, -, *, /) on
 * the float32 points, in a fixed order: the same order on every machine. */
#ifndef DPC_MODEL_LEVEL_ORDER_H
#define DPC_MODEL_LEVEL_ORDER_H

#include <stddef.h>
#include <stdint.h>

#include "dpc/dpc.h"

/* Reorder the level x[n .. n + a) (dims floats per point, each in [0, 1)) after the held points
 * x[0 .. n). DPC_ERROR_OUT_OF_MEMORY leaves the points as they were. */
dpc_status dpc_order_level(float *x, size_t n, size_t a, uint32_t dims);

/* The levels of a progressive set of m points: the first holds min(m, base) points, each next
 * one adds min(n, m - n) to the n so far (§6). */
static inline size_t dpc_first_level(size_t m, size_t base) { return m < base ? m : base; }
static inline size_t dpc_level_size(size_t n, size_t m) { return n < m - n ? n : m - n; }

/* Every level of the m points x in order (what dpc_order_levels does). */
dpc_status dpc_order_level_points(float *x, size_t m, uint32_t dims, size_t base);

#endif
