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

/* The levels of a progressive set of m points: the first holds min(m, base) points, each next
 * one adds min(n, m - n) to the n so far (§6). */
static inline size_t dpc_first_level(size_t m, size_t base) { return m < base ? m : base; }
static inline size_t dpc_level_size(size_t n, size_t m) { return n < m - n ? n : m - n; }

/* Reorder each level of the m points x (dims floats per point, each in [0, 1)), the first level
 * first: a level's order depends on the levels before it as ordered. What dpc_order_levels and
 * the generator of a progressive model (last) do. DPC_ERROR_OUT_OF_MEMORY leaves the level it
 * happens in as it was. */
dpc_status dpc_order_level_points(float *x, size_t m, uint32_t dims, size_t base);

#endif
