/* Building a sampler's tables (docs/rendering.md, "Definition"). */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "common/error.h"
#include "common/threads.h"
#include "model/model_handle.h"
#include "sampler/sampler.h"

/* Seed of the s-th set a sampler generates. */
static uint64_t set_seed(uint64_t base, uint64_t s) { return dpc_stream_at(base, DPC_STREAM_SAMPLER_SET, s); }

typedef struct ranked {
    float v;
    uint32_t i;
} ranked;

static int by_value(const void *a, const void *b) {
    const ranked *x = (const ranked *)a, *y = (const ranked *)b;
    if (x->v != y->v) return x->v < y->v ? -1 : 1;
    return (x->i > y->i) - (x->i < y->i); /* ties by position: a total order, so the same on every libc */
}

/* Stratify both 1-D projections of an n-point table: each coordinate becomes the centre of its
 * rank's stratum, (rank + 1/2) / n. The 2-D arrangement (which x goes with which y) is the
 * model's; each axis gets one value per stratum, as a renderer's axis-aligned edges want. */
static void stratify_projections(float *table, uint32_t n, ranked *scratch) {
    for (int c = 0; c < 2; c++) {
        for (uint32_t i = 0; i < n; i++) scratch[i] = (ranked){table[(size_t)i * 2 + c], i};
        qsort(scratch, n, sizeof *scratch, by_value);
        for (uint32_t r = 0; r < n; r++) table[(size_t)scratch[r].i * 2 + c] = ((float)r + 0.5f) / (float)n;
    }
}

/* Frames: a set's points in the order of their cells' Morton codes bit-reversed (a quadtree
 * walked breadth-first, as van der Corput walks the bits of [0, 1)), cells of a 2^L x 2^L grid
 * with 4^L >= n, ties by position: the first 2^k points spread over the square like a
 * stratification, so that the first frames of a pixel are spread too. The code is scrambled
 * (nested, from the digit the sort reads first) by the table's own seed: with one order for every table,
 * point k of each lay in the same cells, and their pairs across dimensions integrated products
 * of half-planes worse than a random pairing (a development measurement). The cells come from
 * the stratified coordinates' ranks, so the order is integer arithmetic. */
static int by_key(const void *a, const void *b) {
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static dpc_status order_for_frames(float *table, uint32_t n, uint32_t scramble) {
    uint32_t L = 0;
    while ((1ull << (2 * L)) < n) L++;
    uint64_t *key = (uint64_t *)malloc((size_t)n * sizeof *key); /* reversed code << 32 | position */
    float *copy = (float *)malloc((size_t)n * 2 * sizeof *copy);
    if (!key || !copy) {
        free(key);
        free(copy);
        return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory ordering a sampler table of %u points", n);
    }
    for (uint32_t i = 0; i < n; i++) {
        uint32_t code = 0;
        for (int a = 0; a < 2; a++) {
            const uint64_t rank = (uint64_t)(table[(size_t)i * 2 + a] * (float)n); /* (rank + 1/2) / n, exact */
            const uint32_t cell = (uint32_t)((rank << L) / n);
            for (uint32_t b = 0; b < L; b++) code |= ((cell >> b) & 1u) << (2 * b + a);
        }
        /* nested from bit 0 up: the code's coarsest digit is the reversed code's lowest */
        const uint32_t reversed = L ? dpc_sampler_reverse32(dpc_sampler_nested(code, scramble)) >> (32 - 2 * L) : 0;
        key[i] = (uint64_t)reversed << 32 | i;
    }
    qsort(key, n, sizeof *key, by_key);
    memcpy(copy, table, (size_t)n * 2 * sizeof *copy);
    for (uint32_t r = 0; r < n; r++) {
        const uint32_t i = (uint32_t)key[r];
        table[(size_t)r * 2] = copy[(size_t)i * 2];
        table[(size_t)r * 2 + 1] = copy[(size_t)i * 2 + 1];
    }
    free(key);
    free(copy);
    return DPC_OK;
}

#define SAMPLER_MAX_WORKERS 16u

/* options.progress: one unit per set made, polled inside each set's generation (between the
 * cascade's chunks and layers, before every relaxation step); calls serialised, from any worker. */
typedef dpc_progress_state build_progress;

static dpc_status set_hook(void *ctx, int layer_done) {
    (void)layer_done;
    return dpc_progress_add((build_progress *)ctx, 0);
}

/* Sets made at once for a sampler's tables: set j (the k[j]-th set, seed set_seed(base, k[j]))
 * into sets[j], on worker j. */
typedef struct set_job {
    const dpc_sampler_options *o;
    uint64_t base;
    uint32_t n, widest, count;
    uint64_t k[SAMPLER_MAX_WORKERS];
    uint32_t first_slot[SAMPLER_MAX_WORKERS];
    float *sets;
    build_progress *progress; /* NULL: none */
    dpc_status status[SAMPLER_MAX_WORKERS];
} set_job;

static void make_set(void *ctx, unsigned j) {
    set_job *job = (set_job *)ctx;
    const dpc_model *m = job->o->models[job->k[j] % job->o->n_models];
    job->status[j] =
        dpc_model_generate_cpu(m, set_seed(job->base, job->k[j]), job->n, job->sets + (size_t)j * job->n * job->widest,
                               job->progress ? set_hook : NULL, job->progress);
}

/* Sets dpc_sampler_build makes: one per model turn whose slots are not all nets. */
static uint64_t sets_to_make(const dpc_sampler_options *o, uint32_t net_slots) {
    uint64_t sets = 0;
    for (uint64_t k = 0, t = 0; t < o->dimensions; k++) {
        const uint32_t dims = o->models[k % o->n_models]->cascade.dims;
        if (t + dims / 2 > net_slots) sets++;
        t += dims / 2;
    }
    return sets;
}

static dpc_status build(dpc_sampler *s, const dpc_sampler_options *o, build_progress *progress) {
    const uint32_t frames = o->frames, n = o->samples_per_pixel * frames, D = o->dimensions;
    uint32_t widest = 0;
    for (uint32_t j = 0; j < o->n_models; j++)
        if (o->models[j]->cascade.dims > widest) widest = o->models[j]->cascade.dims;
    s->spp = n;
    s->frames = frames;
    s->slots = D;
    s->seed = o->seed;
    s->base = dpc_mix64(o->seed);
    s->inv_spp = 1.0f / (float)n;
    /* k = floor(s g / n), g = gcd(n, 4), reaches j at the least s with s g >= j n */
    const uint32_t g = (n & 3u) == 0 ? 4u : (n & 1u) ? 1u : 2u;
    for (uint32_t j = 1; j <= 3; j++) s->quarter_from[j - 1] = j < g ? (uint32_t)(((uint64_t)j * n + g - 1) / g) : n;
    s->fold_from = o->fold_from;
    /* progressive tables and frames are read in order (all progressive or none: api_sampler.c) */
    const int progressive = o->models[0]->cascade.progressive_base != 0;
    s->rotate = progressive || frames > 1 ? 0 : n;
    uint32_t log_n = 0;
    while ((1u << log_n) < n) log_n++;
    /* The default: nets in every slot from DPC_SAMPLER_AUTO_NETS_SPP on, where they beat the
     * sets, folded or not, on a renderer's per-pixel error in Mitsuba and pbrt
     * (docs/rendering.md, "Nets in every slot"); progressive samplers keep one (more were not
     * measured in a renderer). */
    uint32_t net_dims = o->net_dims;
    if (net_dims == DPC_SAMPLER_NET_DIMS_AUTO)
        net_dims = frames > 1 ? 0 : !progressive && n >= DPC_SAMPLER_AUTO_NETS_SPP ? D : 1;
    s->net_slots = n >= 2 && (1u << log_n) == n ? (net_dims < D ? net_dims : D) : 0;
    s->net_shift = 24 - log_n;
    /* The default: screen-ordered below DPC_SAMPLER_SCREEN_NETS_BELOW, where their errors are blue
     * across pixels at the per-pixel nets' MSE; per pixel from there on, where the optimised
     * scrambling had the lower MSE in pbrt-v4 (docs/rendering.md, "Screen-ordered nets"). */
    uint32_t layout = o->net_layout;
    if (layout == DPC_SAMPLER_NETS_AUTO)
        layout = n < DPC_SAMPLER_SCREEN_NETS_BELOW ? DPC_SAMPLER_NETS_SCREEN : DPC_SAMPLER_NETS_PER_PIXEL;
    s->net_layout = s->net_slots ? layout : DPC_SAMPLER_NETS_PER_PIXEL;
    s->tables = (float *)malloc((size_t)D * n * 2 * sizeof(float));
    s->keys = (uint64_t *)malloc((size_t)D * sizeof *s->keys);
    s->fast_slots = D < DPC_SAMPLER_FAST_SLOTS ? D : DPC_SAMPLER_FAST_SLOTS;
    s->shifted = (float *)malloc((size_t)s->fast_slots * DPC_SAMPLER_TILE * DPC_SAMPLER_TILE *
                                 DPC_SAMPLER_MASK_CHANNELS * sizeof(float));
    /* sets made at once: the first model's threads (a progressive model's relaxation takes
     * seconds for large tables), at most one per set slot */
    unsigned workers = o->models[0]->engine.threads;
    if (workers > SAMPLER_MAX_WORKERS) workers = SAMPLER_MAX_WORKERS;
    if (workers > D) workers = D;
    if (workers < 1) workers = 1;
    float *set = (float *)malloc((size_t)workers * n * widest * sizeof(float)); /* sets of the widest model */
    ranked *scratch = (ranked *)malloc((size_t)n * sizeof *scratch);
    s->nets = s->net_slots ? (uint32_t *)malloc((size_t)s->net_slots * n * sizeof *s->nets) : NULL;
    s->net_index = s->net_slots ? (uint32_t *)malloc((size_t)s->net_slots * n * sizeof *s->net_index) : NULL;
    if (s->net_layout) s->sobol1 = (uint32_t *)malloc(4 * 256 * sizeof *s->sobol1);
    dpc_status st = DPC_OK;
    if (!s->tables || !s->keys || !s->shifted || !set || !scratch || (s->net_slots && (!s->nets || !s->net_index)) ||
        (s->net_layout && !s->sobol1)) {
        st = dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for a sampler of %u x %u points", D, n);
        goto done;
    }
    for (uint32_t d = 0; d < D; d++) s->keys[d] = dpc_sampler_key(s->base, d, 0);
    for (uint32_t d = 0; d < s->fast_slots; d++) {
        s->fast_key[d] = s->keys[d];
        s->tile_key[d] = s->keys[frames > 1 ? 0 : d]; /* frames: dimension 0's offsets for all */
    }
    if (s->net_layout) {
        uint32_t v[32];
        v[0] = 1u << 31;
        for (uint32_t b = 1; b < 32; b++) v[b] = v[b - 1] ^ (v[b - 1] >> 1);
        for (uint32_t byte = 0; byte < 4; byte++)
            for (uint32_t e = 0; e < 256; e++) {
                uint32_t acc = 0;
                for (uint32_t b = 0; b < 8; b++)
                    if (e >> b & 1u) acc ^= v[byte * 8 + b];
                s->sobol1[byte * 256 + e] = acc;
            }
    }
    for (uint32_t d = 0; d < s->fast_slots; d++) /* what dpc_sampler_locate and the lookups compute */
        for (uint32_t at = 0; at < DPC_SAMPLER_TILE * DPC_SAMPLER_TILE; at++) {
            const float *m = dpc_sampler_mask_data + (size_t)at * DPC_SAMPLER_MASK_CHANNELS;
            float *e = s->shifted + ((size_t)d * DPC_SAMPLER_TILE * DPC_SAMPLER_TILE + at) * DPC_SAMPLER_MASK_CHANNELS;
            const float c0 = dpc_sampler_c0(s->keys[d]), c1 = dpc_sampler_c1(s->keys[d]);
            e[0] = dpc_sampler_wrap(m[0], c0);
            e[1] = dpc_sampler_wrap(m[1], c1);
            e[2] = dpc_sampler_wrap(m[2], c0);
        }
    /* Fill the slots in order: the next model in turn gives a set, its dimension pairs fill slots.
     * A set whose slots are all nets is not made (they are overwritten below); set k keeps its
     * seed either way, so every other slot's table is the same whatever net_dims is. The sets
     * are made `workers` at a time, one per thread (each the same bits on any thread). */
    uint32_t t = 0;
    set_job job = {.o = o, .base = s->base, .n = n, .widest = widest, .sets = set, .progress = progress};
    if (progress) progress->total = sets_to_make(o, s->net_slots);
    if (progress && dpc_progress_add(progress, 0) != DPC_OK) goto cancelled;
    for (uint64_t k = 0; t < D || job.count; k++) {
        if (t < D) {
            const uint32_t dims = o->models[k % o->n_models]->cascade.dims;
            if (t + dims / 2 <= s->net_slots) {
                t += dims / 2;
                continue;
            }
            job.k[job.count] = k;
            job.first_slot[job.count++] = t;
            t += dims / 2;
            if (t < D && job.count < workers) continue;
        }
        dpc_run_workers(job.count, make_set, &job);
        for (uint32_t j = 0; j < job.count; j++)
            if (job.status[j] == DPC_ERROR_CANCELLED) goto cancelled;
        for (uint32_t j = 0; j < job.count; j++) {
            const dpc_model *m = o->models[job.k[j] % o->n_models];
            const uint32_t dims = m->cascade.dims;
            const float *made = set + (size_t)j * n * widest;
            if (job.status[j] != DPC_OK) { /* again on this thread, for its message */
                st = dpc_model_generate_cpu(m, set_seed(s->base, job.k[j]), n, set, NULL, NULL);
                if (st == DPC_OK) st = dpc_fail(job.status[j], "making a sampler table failed");
                goto done;
            }
            for (uint32_t a = 0, u = job.first_slot[j]; a + 1 < dims && u < D; a += 2, u++) {
                float *table = s->tables + (size_t)u * n * 2;
                for (uint32_t i = 0; i < n; i++) {
                    table[(size_t)i * 2] = made[(size_t)i * dims + a];
                    table[(size_t)i * 2 + 1] = made[(size_t)i * dims + a + 1];
                }
                stratify_projections(table, n, scratch);
                if (frames > 1 && !progressive &&
                    (st = order_for_frames(
                         table, n, (uint32_t)dpc_child_seed(s->base, DPC_STREAM_SAMPLER_FRAME_ORDER, u))) != DPC_OK)
                    goto done;
            }
        }
        if (progress && dpc_progress_add(progress, job.count) != DPC_OK) goto cancelled;
        job.count = 0;
    }
    /* Net slots: the net's cells, as cell centres (what dpc_sampler_table shows; the lookups
     * read the cells). */
    for (t = 0; t < s->net_slots; t++) {
        uint32_t *cells = s->nets + (size_t)t * n, *sobol_index = s->net_index + (size_t)t * n;
        for (uint32_t i = 0; i < n; i++) sobol_index[i] = i;
        if (progress && dpc_progress_add(progress, 0) != DPC_OK) goto cancelled;
        const uint64_t net_seed = dpc_child_seed(s->base, DPC_STREAM_SAMPLER_NET, t);
        if ((st = dpc_sampler_make_net(log_n, net_seed, cells)) != DPC_OK) goto done;
        /* Every net after the first in a seeded random order (Fisher-Yates): two nets in Sobol'
         * order, rotated against each other, pair their points in a lattice-like pattern (a
         * cross-slot 2-D projection had 16 times the error of a random pairing at 256 spp). The
         * first keeps Sobol' order, and with it the values of net_dims = 1. Progressive samplers
         * shuffle each octave [2^(k-1), 2^k) within itself: every power-of-two prefix keeps its
         * points (a (0,k,2)-net); read in Sobol' order, index by index, the nets had paired
         * 4-40 times worse than at random from 64 samples on (a development measurement). */
        if (t > 0)
            for (uint32_t i = n - 1; i > 0; i--) {
                uint32_t low = 0; /* the first index of i's octave, or 0 for the whole net */
                if (!s->rotate)
                    for (low = 1; low <= i >> 1;) low <<= 1;
                const uint64_t r = dpc_stream_at(net_seed, DPC_STREAM_NET_SHUFFLE, (uint64_t)i - 1);
                const uint32_t j = low + (uint32_t)(((r >> 32) * (i - low + 1)) >> 32), c = cells[i];
                cells[i] = cells[j];
                cells[j] = c;
                const uint32_t k = sobol_index[i];
                sobol_index[i] = sobol_index[j];
                sobol_index[j] = k;
            }
        float *table = s->tables + (size_t)t * n * 2;
        for (uint32_t i = 0; i < n; i++) {
            table[(size_t)i * 2] = ((float)(cells[i] >> 16) + 0.5f) / (float)n;
            table[(size_t)i * 2 + 1] = ((float)(cells[i] & 0xFFFFu) + 0.5f) / (float)n;
        }
    }
done:
    free(set);
    free(scratch);
    return st;
cancelled:
    st = dpc_fail(DPC_ERROR_CANCELLED, "sampler creation cancelled by the progress callback (%llu of %llu sets made)",
                  (unsigned long long)progress->done, (unsigned long long)progress->total);
    goto done;
}

dpc_status dpc_sampler_build(dpc_sampler *s, const dpc_sampler_options *o) {
    if (!o->progress) return build(s, o, NULL);
    build_progress p;
    const dpc_status begun = dpc_progress_begin(&p, o->progress, o->user);
    if (begun != DPC_OK) return begun;
    const dpc_status st = build(s, o, &p);
    dpc_progress_end(&p);
    return st;
}

const uint8_t dpc_sampler_perm4[24] = {0xE4, 0xB4, 0xD8, 0x78, 0x9C, 0x6C, 0xE1, 0xB1, 0xC9, 0x39, 0x8D, 0x2D,
                                       0xD2, 0x72, 0xC6, 0x36, 0x4E, 0x1E, 0x93, 0x63, 0x87, 0x27, 0x4B, 0x1B};

dpc_status dpc_sampler_lookup_2d_general(const dpc_sampler *s, uint32_t x, uint32_t y, uint32_t index, uint32_t dim,
                                         float out[2]) {
    const dpc_sampler_point p = dpc_sampler_locate(s, x, y, index, dim);
    if (p.table < s->net_slots && s->net_layout) {
        dpc_sampler_screen_values(s, p.h, p.code, p.j, out); /* never folded */
        return DPC_OK;
    }
    if (p.table < s->net_slots) {
        dpc_sampler_net_values(s, p.table, p.j, p.h, out); /* never folded */
        return DPC_OK;
    }
    const float *t = s->tables + ((size_t)p.table * s->spp + p.j) * 2;
    out[0] = dpc_sampler_out(s, dim, dpc_sampler_wrap(t[0], dpc_sampler_wrap(p.mask[0], p.c[0])));
    out[1] = dpc_sampler_out(s, dim, dpc_sampler_wrap(t[1], dpc_sampler_wrap(p.mask[1], p.c[1])));
    return DPC_OK;
}

/* Sobol's third coordinate (primitive polynomial x^2 + x + 1, initial direction numbers 1, 3):
 * direction number b of index bit b, the fraction's first bit at bit 31. */
static const uint32_t SOBOL2_DIRECTIONS[32] = {
    0x80000000u, 0xC0000000u, 0x60000000u, 0x90000000u, 0xE8000000u, 0x5C000000u, 0x8E000000u, 0xC5000000u,
    0x68800000u, 0x9CC00000u, 0xEE600000u, 0x55900000u, 0x80680000u, 0xC09C0000u, 0x60EE0000u, 0x90550000u,
    0xE8808000u, 0x5CC0C000u, 0x8E606000u, 0xC5909000u, 0x6868E800u, 0x9C9C5C00u, 0xEEEE8E00u, 0x5555C500u,
    0x8000E880u, 0xC0005CC0u, 0x60008E60u, 0x9000C590u, 0xE8006868u, 0x5C009C9Cu, 0x8E00EEEEu, 0xC5005555u};

static uint32_t sobol2(uint32_t i) {
    uint32_t z = 0;
    for (uint32_t b = 0; i; b++, i >>= 1) z ^= SOBOL2_DIRECTIONS[b] & (0u - (i & 1u));
    return z;
}

dpc_status dpc_sampler_lookup_1d_general(const dpc_sampler *s, uint32_t x, uint32_t y, uint32_t index, uint32_t dim,
                                         float *out) {
    const dpc_sampler_point p = dpc_sampler_locate(s, x, y, index, dim);
    if (p.table < s->net_slots) { /* never folded */
        /* A stratum, at the in-stratum place of one offset u per pixel (dpc_sampler_in_stratum).
         * Screen-ordered, u's quarter is the lowest digit of the pixel's permuted code and the
         * rest its code bit-reversed (what an unscrambled Sobol' sequence has below the stratum):
         * the 4 pixels of an aligned 2 x 2 block take distinct quarters of every stratum and
         * distinct quarters of frac(4u). Per pixel, u comes from the pixel's hash. */
        float u;
        const uint64_t r = dpc_mix64(p.h ^ 0x632BE59BD9B4E019ull); /* its own stream of the hash */
        if (s->net_layout) {
            /* the code's bits reversed and digitally shifted by the tile (so that u's quarter and its
             * fraction are independent over seeds), then random bits: 22 bits */
            const uint32_t below = ((dpc_sampler_reverse32(p.code) >> 10) ^ (uint32_t)r) & 0x3FFFFFu;
            u = (float)((p.code & 3u) << 22 | below) * 0x1p-24f;
        } else {
            u = dpc_sampler_unit(r);
        }
        /* The stratum: after a net slot (a 2-D value, renderers' film position before the
         * wavelength), the third Sobol' coordinate of that slot's point, Owen-scrambled per
         * pixel, so that the previous slot's 2-D values and these are one 3-D net per pixel
         * (the first three Sobol' coordinates: t = 1); else the stratum of this slot's own net
         * point's x (one point per stratum, as the lattice). */
        uint32_t stratum;
        if (dim > 0 && (dim - 1) % s->slots < s->net_slots) { /* only then the previous point is needed */
            const dpc_sampler_point q = dpc_sampler_locate(s, x, y, index, dim - 1);
            const uint32_t i = s->net_layout ? dpc_sampler_screen_index(s, q.h, q.code, q.j)
                                             : s->net_index[(size_t)q.table * s->spp + q.j];
            const uint32_t z = dpc_sampler_nested(dpc_sampler_reverse32(sobol2(i)), (uint32_t)(r >> 32));
            stratum = dpc_sampler_reverse32(z) >> (8 + s->net_shift);
        } else {
            float v[2];
            if (s->net_layout) dpc_sampler_screen_values(s, p.h, p.code, p.j, v);
            else dpc_sampler_net_values(s, p.table, p.j, p.h, v);
            stratum = (uint32_t)(v[0] * (float)s->spp); /* exact: n is a power of two */
        }
        const float value = ((float)stratum + dpc_sampler_in_stratum(s, stratum, u)) * s->inv_spp;
        *out = value < 1.0f ? value : 0.0f; /* 1 only by rounding */
        return DPC_OK;
    }
    *out = dpc_sampler_out(s, dim, dpc_sampler_lattice(s, p.table, p.j, dpc_sampler_wrap(p.mask[2], p.c[0]), p.c[1]));
    return DPC_OK;
}
