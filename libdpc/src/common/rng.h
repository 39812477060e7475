/* The input-point generator of docs/model-format.md §5: a SplitMix64 stream, counter based, so
 * value c needs no state beyond (seed, c) and any slice can be produced in parallel. */
#ifndef DPC_COMMON_RNG_H
#define DPC_COMMON_RNG_H

#include <stdint.h>

static inline uint64_t dpc_mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Value c of the stream of seed, as a float in [0, 1) with 24 random bits (exact in float32). */
static inline float dpc_uniform_at(uint64_t state0, uint64_t c) {
    uint64_t z = dpc_mix64(state0 + (c + 1) * 0x9E3779B97F4A7C15ull);
    return (float)(z >> 40) * (1.0f / 16777216.0f);
}

#endif
