/* The input points of docs/model-format.md §5: what a cascade filters for a seed. Counter-based
 * (SplitMix64), so any slice can be made in parallel and Python reproduces them bit for bit;
 * shared by the CPU and the Vulkan backends (the Vulkan backend uploads them). */
#ifndef DPC_MODEL_INPUT_H
#define DPC_MODEL_INPUT_H

#include <stddef.h>
#include <stdint.h>

#include "model/model.h"

/* out[c] for c < count: value c of the uniform stream of seed (dpc_uniform). */
void dpc_input_uniform(uint64_t seed, size_t count, float *out);

/* m stratified points in n dimensions (dpc_stratified; m <= DPC_MAX_POINTS). Needs no memory
 * beyond out (m * n floats): the cell lists live in out itself. */
void dpc_input_stratified(uint64_t seed, size_t m, size_t n, float *out);

/* The input of one set of the cascade: m points of kind `input` (UNIFORM or STRATIFIED) from
 * seed, then the grid's cell centres in the gridded dimensions. */
void dpc_input_fill(const dpc_cascade *c, dpc_input input, uint64_t seed, size_t m, float *x);

#endif
