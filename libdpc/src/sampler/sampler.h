/* The renderer-facing sampler (dpc_sampler_*): per dimension slot, a dpc point set of spp points
 * generated once on the CPU backend; per pixel, a toroidal shift from a screen-space mask (moved
 * per 32 x 32 tile) and a rotation of the sample index. A lookup is an integer hash, two table
 * reads and two float additions: no allocation, no lock, the same bits on every machine.
 * The definition is written out in docs/rendering.md ("Definition"); tests/python/
 * reference_sampler.py is an independent transcription of it. */
#ifndef DPC_SAMPLER_SAMPLER_H
#define DPC_SAMPLER_SAMPLER_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "common/rng.h"
#include "dpc/dpc.h"

#define DPC_SAMPLER_TILE 32u /* the mask repeats every 32 pixels in x and in y */

/* The screen-space mask: DPC_SAMPLER_TILE^2 pixels, row-major (y * 32 + x), three values each in
 * [0, 1): a 2-D shift (channels 0, 1) and a 1-D offset (channel 2) (sampler_mask.c, made by
 * lab/rendering/make_sampler_mask.py). */
#define DPC_SAMPLER_MASK_CHANNELS 3u
extern const float dpc_sampler_mask_data[DPC_SAMPLER_TILE * DPC_SAMPLER_TILE * DPC_SAMPLER_MASK_CHANNELS];

/* Dimensions whose pass-0 keys are kept inside the object, with their rotated masks (12 KiB
 * each). */
#define DPC_SAMPLER_FAST_SLOTS 64u

struct dpc_sampler {
    uint32_t spp;    /* n: points per table, options.samples_per_pixel times frames */
    uint32_t frames; /* F (options.frames, at least 1): frame f takes indices f * n / F .. */
    uint32_t slots;  /* D: tables; dimension d reads table d mod D */
    uint64_t seed;
    uint64_t base;            /* mix64 of the seed: the root of every key */
    float inv_spp;            /* 1 / n, for 1-D values */
    uint32_t quarter_from[3]; /* 1-D values: the strata from which the in-stratum offset turns by one,
                               * two, three quarters (dpc_sampler_in_stratum; n when it never does) */
    uint32_t fold_from;       /* dimensions >= fold_from are folded (dpc_sampler_fold) */
    /* The range of a pixel's rotation of the sample index: n for set models; 0 for progressive
     * models (format §6), whose tables are read in order so that the first 2^k samples of a
     * pixel are a progressive prefix. */
    uint32_t rotate;
    /* Net slots (docs/rendering.md, "Net dimensions"): tables t < net_slots are (0,m,2)-nets,
     * n = 2^m, randomised per pixel by a digital shift, not by the mask; 0 when n is not a
     * power of two >= 2. nets: net_slots * n cells, x << 16 | y, each coordinate m bits. */
    uint32_t net_slots;
    uint32_t net_shift; /* 24 - m: a cell's coordinate times 2^net_shift is its value on the 2^-24 grid */
    uint32_t *nets;
    uint32_t *net_index; /* per-pixel nets: the Sobol' index of each cell (nets after the first are shuffled) */
    float *tables;       /* D * n * 2 floats: table t, point j at (t * n + j) * 2 */
    uint64_t *keys;      /* D: key (d, pass 0), the common case */
    uint32_t fast_slots; /* min(D, DPC_SAMPLER_FAST_SLOTS) */
    /* The common case precomputed: for pass 0 of dimension d < fast_slots, every mask entry with
     * the key's rotation added, wrap(mask0, c0), wrap(mask1, c1), wrap(mask2, c0): the values
     * the general path computes, read instead of recomputed (the same bits). */
    float *shifted; /* fast_slots * 32 * 32 * 3 floats */
    /* Screen-ordered nets (net_layout DPC_SAMPLER_NETS_SCREEN): the Sobol' second coordinate of
     * an index, byte by byte (4 x 256 words). NULL for per-pixel nets. */
    uint32_t net_layout;
    uint32_t *sobol1;
    /* keys[d] for d < fast_slots, inside the object: one dependent load less on the lookups'
     * critical path (key -> hash -> point -> table read) */
    uint64_t fast_key[DPC_SAMPLER_FAST_SLOTS];
    /* The key whose tile offsets fast slot d's set lookups (pass 0) read the mask at: keys[d], or
     * with frames keys[0] for every dimension, so that one frame's values are the same mask entry
     * in every dimension, each rotated by its own key, and the error of an integrand over several
     * dimension pairs stays blue (4-D products of half-planes: E_low 0.35 against 0.50 with offsets
     * per dimension, lab/rendering/frames_study.py); over seeds the rotations alone keep each
     * pixel's values uniform and independent across dimensions. Precomputed, so that the common
     * path tests nothing for frames. */
    uint64_t tile_key[DPC_SAMPLER_FAST_SLOTS];
};

/* Key of (dimension d, pass r): everything a lookup derives for that dimension and block of
 * spp sample indices comes from it. */
static inline uint64_t dpc_sampler_key(uint64_t base, uint32_t dim, uint32_t pass) {
    return dpc_child_seed(base, DPC_STREAM_SAMPLER_KEY, (uint64_t)pass << 32 | dim);
}

/* 24 bits of a key as a float in [0, 1), exact. */
static inline float dpc_sampler_unit(uint64_t bits) { return (float)(bits & 0xFFFFFFu) * (1.0f / 16777216.0f); }

/* The rotation (c0, c1) of every value of a key's set-slot lookups. */
static inline float dpc_sampler_c0(uint64_t key) { return dpc_sampler_unit(key >> 10); }
static inline float dpc_sampler_c1(uint64_t key) { return dpc_sampler_unit(key >> 34); }

/* A pixel's rotation of the sample index, in [0, rotate): the high half of its hash scaled. */
static inline uint32_t dpc_sampler_rotation(uint64_t hash, uint32_t rotate) {
    return (uint32_t)(((hash >> 32) * rotate) >> 32);
}

/* Point k of n rotated by rot < n. */
static inline uint32_t dpc_sampler_rotated(uint32_t n, uint32_t k, uint32_t rot) {
    const uint32_t j = k + rot;
    return j - (j >= n ? n : 0);
}

/* What a key gives pixel (x, y) of a set slot through the pixel's 32 x 32 tile: its entry of
 * the mask moved by the tile's own (ox, oy), and its rotation of the sample index. Each tile
 * its own offset, so no two tiles (and, in Mitsuba, no two blocks or render seeds) repeat each
 * other's sets, while inside a tile the mask's relative shifts, its blue noise, are kept. One
 * hash per lookup: the index rotation is the tile's hash and the pixel's place in the tile
 * through one multiply. */
typedef struct dpc_sampler_tiled {
    uint32_t at;  /* the mask entry: ((y + oy) mod 32) * 32 + (x + ox) mod 32 */
    uint32_t rot; /* the pixel's rotation of the sample index, in [0, rotate) */
} dpc_sampler_tiled;

static inline dpc_sampler_tiled dpc_sampler_tile(uint64_t key, uint32_t rotate, uint32_t x, uint32_t y) {
    const uint64_t tile = (uint64_t)(y / DPC_SAMPLER_TILE) << 32 | (x / DPC_SAMPLER_TILE);
    const uint64_t kt = dpc_mix64(key ^ tile); /* a key serves set or net slots, never both */
    const uint32_t ox = (uint32_t)kt, oy = (uint32_t)(kt >> 5), last = DPC_SAMPLER_TILE - 1;
    const uint64_t place = (uint64_t)((y & last) * DPC_SAMPLER_TILE + (x & last));
    /* a bijection of kt for each place (uniform over seeds), its high bits spread over places */
    const uint64_t spin = (kt ^ (place + 1) * 0x9E3779B97F4A7C15ull) * 0xBF58476D1CE4E5B9ull;
    dpc_sampler_tiled t;
    t.at = ((y + oy) & last) * DPC_SAMPLER_TILE + ((x + ox) & last);
    t.rot = dpc_sampler_rotation(spin, rotate);
    return t;
}

/* a + b - floor(a + b) for a, b in [0, 1): the result of the float addition minus 1 when it
 * reaches 1 (exact, so a sum that rounds up to 1 gives 0). */
static inline float dpc_sampler_wrap(float a, float b) {
    /* t - (t >= 1 ? 1 : 0) without a branch (the outcome is a coin flip, so a branch would
     * mispredict half the time): 1.0f masked by the comparison. */
#if defined(__SSE2__)
    /* in SSE registers: compare, and, subtract (the integer form below moves through a general
     * register and back: twice the instructions on the lookups' critical path) */
    const __m128 t = _mm_add_ss(_mm_set_ss(a), _mm_set_ss(b));
    const __m128 one = _mm_and_ps(_mm_cmpge_ss(t, _mm_set_ss(1.0f)), _mm_set_ss(1.0f));
    return _mm_cvtss_f32(_mm_sub_ss(t, one));
#else
    const float t = a + b;
    const uint32_t one_bits = (0u - (uint32_t)(t >= 1.0f)) & 0x3F800000u;
    float one;
    memcpy(&one, &one_bits, sizeof one);
    return t - one;
#endif
}

/* The baker's (tent) transform 1 - |2v - 1| as a bijection of the 2^-24 grid of [0, 1): 2v below
 * 1/2, 2(1 - v) - 2^-24 from 1/2 on. Every step is exact (1 - v by Sterbenz, the doubling, and
 * the result, a multiple of 2^-24 in [2^-24, 1 - 2^-24]), so contraction cannot change it. */
static inline float dpc_sampler_fold(float v) {
    /* both sides, then a select: which side is a coin flip, so a branch would mispredict half
     * the time (21 against 10 ns per 2-D lookup on bench_sampler) */
#if defined(__SSE2__)
    const __m128 x = _mm_set_ss(v);
    const __m128 t = _mm_sub_ss(_mm_set_ss(1.0f), x);
    const __m128 hi = _mm_sub_ss(_mm_add_ss(t, t), _mm_set_ss(0x1p-24f));
    const __m128 below = _mm_cmplt_ss(x, _mm_set_ss(0.5f));
    return _mm_cvtss_f32(_mm_or_ps(_mm_and_ps(below, _mm_add_ss(x, x)), _mm_andnot_ps(below, hi)));
#else
    const float lo = 2.0f * v, hi = 2.0f * (1.0f - v) - 0x1p-24f;
    uint32_t a, b;
    memcpy(&a, &lo, sizeof a);
    memcpy(&b, &hi, sizeof b);
    const uint32_t below = 0u - (uint32_t)(v < 0.5f), bits = (a & below) | (b & ~below);
    float r;
    memcpy(&r, &bits, sizeof r);
    return r;
#endif
}

/* The value a set slot's dimension dim returns for v: v folded from fold_from on
 * (docs/rendering.md). Net slots are never folded: the tent map halves the net's strata and
 * maps pairs of its points onto each other (a folded net had 1.5 to 10 times the unfolded
 * one's error in bench/sampler_fold_study.py). */
static inline float dpc_sampler_out(const struct dpc_sampler *s, uint32_t dim, float v) {
    return dim >= s->fold_from ? dpc_sampler_fold(v) : v;
}

/* Nets are optimised up to this many points; larger ones keep their random scrambling, which
 * integrated the Cornell box's light rim better at 256 spp (docs/rendering.md, "Net dimensions"). */
#define DPC_SAMPLER_NET_OPTIMISED 64u
#define DPC_SAMPLER_NET_SWEEPS 4u

/* The n = 2^m cells (x << 16 | y) of the net of seed (sampler_net.c). */
dpc_status dpc_sampler_make_net(uint32_t m, uint64_t seed, uint32_t *cells);

/* Net slot t, point j, as randomised by the pixel's hash h: the cell's coordinates exchanged
 * when bit 32 of h is set, then XORed with h's bits 0.. and 16.. (a digital shift: every
 * elementary interval of the net keeps one point), then a uniform offset inside the cell from
 * g = (h XOR (j + 1) * golden) * 0xD6E8FEB86659FD93, bits 40.. for x and 16.. for y. */
static inline void dpc_sampler_net_values(const struct dpc_sampler *s, uint32_t t, uint32_t j, uint64_t h,
                                          float out[2]) {
    const uint32_t cell = s->nets[(size_t)t * s->spp + j], cells = s->spp - 1;
    uint32_t a = cell >> 16, b = cell & 0xFFFFu;
    const uint32_t swap = (a ^ b) & (0u - (uint32_t)((h >> 32) & 1u)); /* a select: the swap is a coin flip */
    a ^= swap ^ ((uint32_t)h & cells);
    b ^= swap ^ ((uint32_t)(h >> 16) & cells);
    /* one multiply, not a full mix: the offsets need only be uniform (h is) and differ per point */
    const uint64_t g = (h ^ (uint64_t)(j + 1) * 0x9E3779B97F4A7C15ull) * 0xD6E8FEB86659FD93ull;
    const uint32_t low = (1u << s->net_shift) - 1u;
    out[0] = (float)(a << s->net_shift | ((uint32_t)(g >> 40) & low)) * 0x1p-24f;
    out[1] = (float)(b << s->net_shift | ((uint32_t)(g >> 16) & low)) * 0x1p-24f;
}

/* Screen-ordered net slots (docs/rendering.md, "Screen-ordered nets"): a 32 x 32 tile of pixels
 * shares one 2-D Sobol' sequence of 1024 n points; pixel (x, y) takes the block of n points at its
 * Morton code in the tile, the code's base-4 digits permuted (nested, per dimension, pass and
 * tile), its sample index shuffled (nested, per pixel), and both coordinates Owen-scrambled per
 * tile, so a pixel's samples are a (0,m,2)-net and each aligned group of 4^k pixels' samples a
 * finer one. The permutation is the tile's own: with one per dimension, tiles shared which pixel
 * took which block, and their error images correlated (|r| 0.2-0.4 on smooth and step integrands;
 * 0.03 with the tile's own). */
static inline uint32_t dpc_sampler_reverse32(uint32_t v) {
    v = (v >> 16) | (v << 16);
    v = ((v & 0xFF00FF00u) >> 8) | ((v & 0x00FF00FFu) << 8);
    v = ((v & 0xF0F0F0F0u) >> 4) | ((v & 0x0F0F0F0Fu) << 4);
    v = ((v & 0xCCCCCCCCu) >> 2) | ((v & 0x33333333u) << 2);
    return ((v & 0xAAAAAAAAu) >> 1) | ((v & 0x55555555u) << 1);
}

/* A nested scramble of v's bits from bit 0 up (each output bit is its input bit XOR a function
 * of the bits below it and the seed): the hash of Laine and Karras 2011 with the constants of
 * Burley 2020 ("Practical Hash-based Owen Scrambling"). Applied to bit-reversed values it is an
 * Owen scrambling: every elementary interval keeps its points. */
static inline uint32_t dpc_sampler_nested(uint32_t v, uint32_t seed) {
    v ^= v * 0x3d20adeau;
    v += seed;
    v *= (seed >> 16) | 1u;
    v ^= v * 0x05526c56u;
    v ^= v * 0x53a22864u;
    return v;
}

/* The 24 permutations of {0, 1, 2, 3} in lexicographic order, each packed 2 bits per image. */
extern const uint8_t dpc_sampler_perm4[24];

/* The Morton code (x bit b at 2b, y bit b at 2b + 1) of a tile place, its five base-4 digits
 * permuted from the top, each by permutation mix(kt + ((prefix << 3 | level) + 1) golden) of 24,
 * prefix the original digits above it, kt the tile's hash. */
static inline uint32_t dpc_sampler_screen_code(uint64_t kt, uint32_t x, uint32_t y) {
    uint32_t code = 0, out = 0;
    for (uint32_t b = 0; b < 5; b++) code |= ((x >> b) & 1u) << (2 * b) | ((y >> b) & 1u) << (2 * b + 1);
    for (uint32_t l = 0; l < 5; l++) {
        const uint32_t shift = 8 - 2 * l, digit = (code >> shift) & 3u;
        const uint64_t prefix = code >> (shift + 2);
        const uint64_t h = dpc_mix64(kt + ((prefix << 3 | l) + 1) * 0x9E3779B97F4A7C15ull);
        const uint32_t perm = dpc_sampler_perm4[((h >> 32) * 24) >> 32];
        out |= ((perm >> (2 * digit)) & 3u) << shift;
    }
    return out;
}

/* Sobol's second coordinate of index i (32-bit, generator v_0 = 2^31, v_b = v_{b-1} XOR
 * v_{b-1} >> 1) from the sampler's byte tables. */
static inline uint32_t dpc_sampler_sobol1(const struct dpc_sampler *s, uint32_t i) {
    return s->sobol1[i & 0xFFu] ^ s->sobol1[256 + ((i >> 8) & 0xFFu)] ^ s->sobol1[512 + ((i >> 16) & 0xFFu)] ^
           s->sobol1[768 + (i >> 24)];
}

/* The index in the tile's sequence of screen-ordered net sample k (< n = 2^m, m = 24 - net_shift)
 * for tile hash kt and permuted code c: the block at c, k shuffled in it, nested from its top bit,
 * so that every power-of-two prefix of the pixel's samples stays an aligned block. */
static inline uint32_t dpc_sampler_screen_index(const struct dpc_sampler *s, uint64_t kt, uint32_t c, uint32_t k) {
    const uint32_t m = 24 - s->net_shift;
    const uint64_t hp = dpc_mix64(kt ^ ((uint64_t)c << 1 | 1u));
    return c << m |
           dpc_sampler_reverse32(dpc_sampler_nested(dpc_sampler_reverse32(k) >> (32 - m), (uint32_t)hp)) >> (32 - m);
}

/* The values of screen-ordered net sample k (< n = 2^m) for tile hash kt and permuted code c. */
static inline void dpc_sampler_screen_values(const struct dpc_sampler *s, uint64_t kt, uint32_t c, uint32_t k,
                                             float out[2]) {
    const uint32_t i = dpc_sampler_screen_index(s, kt, c, k);
    const uint64_t hs = dpc_mix64(kt + 0x9E3779B97F4A7C15ull);
    /* x is i bit-reversed: scrambling i from bit 0 up is x's Owen scrambling from the top */
    const uint32_t xs = dpc_sampler_reverse32(dpc_sampler_nested(i, (uint32_t)hs));
    const uint32_t ys = dpc_sampler_reverse32(
        dpc_sampler_nested(dpc_sampler_reverse32(dpc_sampler_sobol1(s, i)), (uint32_t)(hs >> 32)));
    out[0] = (float)(xs >> 8) * 0x1p-24f;
    out[1] = (float)(ys >> 8) * 0x1p-24f;
}

typedef struct dpc_sampler_point {
    uint32_t table; /* t = dim mod D */
    uint32_t j;     /* point of table t: k rotated by the pixel's offset */
    float mask[3];  /* set slots: the pixel's mask values, the mask moved by its tile's (ox, oy) */
    float c[2];     /* set slots: the key's rotation of every value */
    uint64_t h;     /* net slots: the pixel's hash, its index rotation and digital shift (screen-ordered:
                     * the tile's hash) */
    uint32_t code;  /* screen-ordered net slots: the pixel's permuted Morton code */
} dpc_sampler_point;

/* Fill a zeroed sampler from checked options: keys, then D tables from the models' sets, each
 * with its 1-D projections stratified. On failure the caller frees it. */
dpc_status dpc_sampler_build(struct dpc_sampler *s, const dpc_sampler_options *o);

/* The pieces every lookup shares (docs/rendering.md, "Definition"). */
static inline dpc_sampler_point dpc_sampler_locate(const struct dpc_sampler *s, uint32_t x, uint32_t y, uint32_t index,
                                                   uint32_t dim) {
    const uint32_t n = s->spp;
    uint32_t pass = 0, k = index, table = dim;
    if (index >= n) { /* later passes: rare, so the divisions stay off the common path */
        pass = index / n;
        k = index - pass * n;
    }
    if (dim >= s->slots) table = dim % s->slots;
    const uint64_t key = pass == 0 && dim < s->slots ? s->keys[dim] : dpc_sampler_key(s->base, dim, pass);
    /* the pixel's rotation of the sample index decorrelates how dimensions pair up (none for
     * progressive tables, whose order is their point); a net slot takes it, and its digital
     * shift, from the pixel's own hash */
    dpc_sampler_point p;
    uint32_t rot;
    p.table = table;
    p.code = 0;
    if (table < s->net_slots && s->net_layout) { /* h: the tile's hash; j: the permuted code, k the index */
        p.h = dpc_mix64(key ^ ((uint64_t)(y / DPC_SAMPLER_TILE) << 32 | (x / DPC_SAMPLER_TILE)));
        p.code = dpc_sampler_screen_code(p.h, x & (DPC_SAMPLER_TILE - 1), y & (DPC_SAMPLER_TILE - 1));
        rot = 0;
        p.mask[0] = p.mask[1] = p.mask[2] = p.c[0] = p.c[1] = 0.0f;
    } else if (table < s->net_slots) {
        p.h = dpc_mix64(key ^ ((uint64_t)y << 32 | x));
        rot = dpc_sampler_rotation(p.h, s->rotate);
        p.mask[0] = p.mask[1] = p.mask[2] = p.c[0] = p.c[1] = 0.0f;
    } else {
        /* frames: every dimension's mask at the offsets of dimension 0's key (see tile_key) */
        const uint64_t tile_key = s->frames > 1 ? dpc_sampler_key(s->base, 0, pass) : key;
        const dpc_sampler_tiled tiled = dpc_sampler_tile(tile_key, s->rotate, x, y);
        const float *m = dpc_sampler_mask_data + (size_t)tiled.at * DPC_SAMPLER_MASK_CHANNELS;
        p.h = 0;
        rot = tiled.rot;
        p.mask[0] = m[0];
        p.mask[1] = m[1];
        p.mask[2] = m[2];
        p.c[0] = dpc_sampler_c0(key);
        p.c[1] = dpc_sampler_c1(key);
    }
    p.j = dpc_sampler_rotated(n, k, rot);
    return p;
}

/* Entry at of the rotated mask of fast slot dim (pass 0). */
static inline const float *dpc_sampler_shifted_at(const struct dpc_sampler *s, uint32_t dim, uint32_t at) {
    return s->shifted + ((size_t)dim * DPC_SAMPLER_TILE * DPC_SAMPLER_TILE + at) * DPC_SAMPLER_MASK_CHANNELS;
}

/* Later passes and dimensions past fast_slots (sampler.c): out of line, so that the common case
 * below compiles to a leaf function that tail-calls these (no register saves, no frame). They
 * return DPC_OK. */
dpc_status dpc_sampler_lookup_2d_general(const struct dpc_sampler *s, uint32_t x, uint32_t y, uint32_t index,
                                         uint32_t dim, float out[2]);
dpc_status dpc_sampler_lookup_1d_general(const struct dpc_sampler *s, uint32_t x, uint32_t y, uint32_t index,
                                         uint32_t dim, float *out);

/* The value pair for (x, y, index, dim) into out; returns DPC_OK. */
static inline dpc_status dpc_sampler_lookup_2d(const struct dpc_sampler *s, uint32_t x, uint32_t y, uint32_t index,
                                               uint32_t dim, float out[2]) {
    if (index >= s->spp || dim >= s->fast_slots) return dpc_sampler_lookup_2d_general(s, x, y, index, dim, out);
    if (dim < s->net_slots && s->net_layout) {
        const uint32_t last = DPC_SAMPLER_TILE - 1;
        const uint64_t kt =
            dpc_mix64(s->fast_key[dim] ^ ((uint64_t)(y / DPC_SAMPLER_TILE) << 32 | (x / DPC_SAMPLER_TILE)));
        dpc_sampler_screen_values(s, kt, dpc_sampler_screen_code(kt, x & last, y & last), index, out);
        return DPC_OK;
    }
    if (dim < s->net_slots) { /* a net slot's pass 0: one hash, one read, one multiply */
        const uint64_t h = dpc_mix64(s->fast_key[dim] ^ ((uint64_t)y << 32 | x));
        const uint32_t j = dpc_sampler_rotated(s->spp, index, dpc_sampler_rotation(h, s->rotate));
        dpc_sampler_net_values(s, dim, j, h, out);
        return DPC_OK;
    }
    /* the common case: one hash, two reads */
    const dpc_sampler_tiled tiled = dpc_sampler_tile(s->tile_key[dim], s->rotate, x, y);
    const float *m = dpc_sampler_shifted_at(s, dim, tiled.at);
    const float *t = s->tables + ((size_t)dim * s->spp + dpc_sampler_rotated(s->spp, index, tiled.rot)) * 2;
    out[0] = dpc_sampler_out(s, dim, dpc_sampler_wrap(t[0], m[0]));
    out[1] = dpc_sampler_out(s, dim, dpc_sampler_wrap(t[1], m[1]));
    return DPC_OK;
}

/* Where a 1-D value of stratum s (of n) sits inside it, for a pixel offset u in [0, 1):
 * frac(u + k / 4), k = floor(s g / n), g = gcd(n, 4). Hero-wavelength spectral sampling (Wilkie
 * et al. 2014; pbrt-v4 and Mitsuba 3's spectral modes) draws 4 wavelengths from one value v, at
 * v + i / 4: with k = 0 (a plain lattice) the n values' shifts repeat n strata of [0, 1) four
 * times where 4 divides n, and at n = 2 and 4 every sample of a pixel draws the same four
 * wavelengths; with k they fill the 4n strata once each, at the offset frac(4u). Odd n have
 * k = 0: their lattice already does. */
static inline float dpc_sampler_in_stratum(const struct dpc_sampler *sp, uint32_t s, float u) {
    /* k by comparisons with precomputed strata (quarter_from), not a division per value */
    const uint32_t k = (uint32_t)(s >= sp->quarter_from[0]) + (uint32_t)(s >= sp->quarter_from[1]) +
                       (uint32_t)(s >= sp->quarter_from[2]);
    return dpc_sampler_wrap(u, 0.25f * (float)k);
}

/* (i + in_stratum(i, u)) / n rotated by c1: the 1-D value of point j of table t with pixel
 * offset u, where i = j, or for progressive tables the rank of point j's x (its table value
 * (i + 1/2) / n times n, exact for n < 2^22), so that a prefix's strata are spread like its
 * points. */
static inline float dpc_sampler_lattice(const struct dpc_sampler *s, uint32_t t, uint32_t j, float u, float c1) {
    const uint32_t i = s->rotate ? j : (uint32_t)(s->tables[((size_t)t * s->spp + j) * 2] * (float)s->spp);
    /* frames: i / n shifted by u as a whole, so that one frame's values spread over [0, 1)
     * across pixels (the same lattice per pixel, u / n's place taken by frac(u n) / n) */
    if (s->frames > 1) return dpc_sampler_wrap(dpc_sampler_wrap((float)i * s->inv_spp, u), c1);
    const float lattice = ((float)i + dpc_sampler_in_stratum(s, i, u)) * s->inv_spp; /* 1 only by rounding */
    return dpc_sampler_wrap(lattice < 1.0f ? lattice : 0.0f, c1);
}

/* 1-D: the stratified lattice, u the pixel's 1-D mask value rotated by c0, then the whole
 * lattice rotated by c1: one value per stratum, and the offset inside the stratum is blue noise
 * across pixels (a quarter turn of it per quarter of the strata), so neighbouring pixels fill
 * each other's strata. */
static inline dpc_status dpc_sampler_lookup_1d(const struct dpc_sampler *s, uint32_t x, uint32_t y, uint32_t index,
                                               uint32_t dim, float *out) {
    if (index >= s->spp || dim >= s->fast_slots || dim < s->net_slots)
        return dpc_sampler_lookup_1d_general(s, x, y, index, dim, out);
    const dpc_sampler_tiled tiled = dpc_sampler_tile(s->tile_key[dim], s->rotate, x, y);
    const uint32_t j = dpc_sampler_rotated(s->spp, index, tiled.rot);
    *out = dpc_sampler_out(
        s, dim,
        dpc_sampler_lattice(s, dim, j, dpc_sampler_shifted_at(s, dim, tiled.at)[2], dpc_sampler_c1(s->fast_key[dim])));
    return DPC_OK;
}

#endif
