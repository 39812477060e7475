/* The input-point generator of docs/model-format.md §5: a SplitMix64 stream, counter based, so
 * value c needs no state beyond (seed, c) and any slice can be produced in parallel; and the
 * named streams every child seed comes from. */
#ifndef DPC_COMMON_RNG_H
#define DPC_COMMON_RNG_H

#include <stdint.h>

static inline uint64_t dpc_mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Child-seed streams: every seed libdpc derives from a caller's seed, named once. Each constant
 * keeps a stream apart from the others; the values are pinned (the generated bits depend on
 * them), and each comment states the derivation its users apply. */
#define DPC_GOLDEN 0x9E3779B97F4A7C15ull /* 2^64 / golden ratio: SplitMix64's increment */
/* Stratified input's cell shuffle: the stream of mix64(seed ^ K) (model/input.c). */
#define DPC_STREAM_STRATIFIED 0x5354524154494649ull
/* Progressive level j >= 1's input points: seed + j * K, unmixed (format §6; cpu/cpu_cascade.c). */
#define DPC_STREAM_LEVEL DPC_GOLDEN
/* The sampler, from base = mix64(seed) (sampler/): set s of its tables, dpc_stream_at(base, K, s); */
#define DPC_STREAM_SAMPLER_SET 0xD1B54A32D192ED03ull
/* the key of (dimension, pass), dpc_child_seed(base, K, pass << 32 | dimension); */
#define DPC_STREAM_SAMPLER_KEY DPC_GOLDEN
/* net slot t's seed, dpc_child_seed(base, K, t); */
#define DPC_STREAM_SAMPLER_NET 0x243F6A8885A308D3ull
/* the shuffle of net t's points, dpc_stream_at(net seed, K, i - 1) for point i >= 1; */
#define DPC_STREAM_NET_SHUFFLE 0xD1342543DE82EF95ull
/* the Owen-scrambling flips of a net, dpc_stream_at(net seed, K, f) for flip f; */
#define DPC_STREAM_NET_FLIP DPC_GOLDEN
/* the scramble of table t's frame order, dpc_child_seed(base, K, t). */
#define DPC_STREAM_SAMPLER_FRAME_ORDER 0x632BE59BD9B4E019ull
/* The mask designer's two SplitMix64 generators (mask/mask_design.c), started at seed * K + C:
 * the void-and-cluster start's and the annealer's. */
#define DPC_STREAM_MASK_START DPC_GOLDEN
#define DPC_STREAM_MASK_START_ADD 0x5EED0000ull
#define DPC_STREAM_MASK_ANNEAL 0x2545F4914F6CDD1Dull
#define DPC_STREAM_MASK_ANNEAL_ADD 0x1234567ull

/* Value c of the counter stream of (seed, K): mix64(seed + (c + 1) K). */
static inline uint64_t dpc_stream_at(uint64_t seed, uint64_t stream, uint64_t c) {
    return dpc_mix64(seed + (c + 1) * stream);
}

/* Child seed `index` of stream K: mix64(seed ^ mix64(index + K)). */
static inline uint64_t dpc_child_seed(uint64_t seed, uint64_t stream, uint64_t index) {
    return dpc_mix64(seed ^ dpc_mix64(index + stream));
}

/* Value c of the stream of seed, as a float in [0, 1) with 24 random bits (exact in float32). */
static inline float dpc_uniform_at(uint64_t state0, uint64_t c) {
    const uint64_t z = dpc_stream_at(state0, DPC_GOLDEN, c);
    return (float)(z >> 40) * (1.0f / 16777216.0f);
}

#endif
