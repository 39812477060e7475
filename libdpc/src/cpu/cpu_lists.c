/* Verlet neighbour lists (cpu_lists.h). */
#include "cpu/cpu_lists.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define HOT_SHARE 8          /* rebuild when more than m / HOT_SHARE points are hot */
#define PAIRS_PER_POINT 256u /* a worker holding more pairs than this per point gives up (crowded) */

void dpc_lists_init(dpc_lists *L, size_t m) {
    memset(L, 0, sizeof *L);
    L->m = m;
}

void dpc_lists_free(dpc_lists *L) {
    free(L->near_off), free(L->near), free(L->hot_off), free(L->hot), free(L->at), free(L->hot_pts);
    free(L->scratch);
    for (unsigned t = 0; t < DPC_MAX_THREADS; t++) free(L->buf[t].pair);
    memset(L, 0, sizeof *L);
}

static int add_pair(dpc_pair_buffer *b, uint32_t i, uint32_t j, size_t limit) {
    if (b->n == b->cap) {
        const size_t cap = b->cap ? 2 * b->cap : 1024;
        uint32_t *p = cap <= limit ? (uint32_t *)realloc(b->pair, 2 * cap * sizeof(uint32_t)) : NULL;
        if (!p) return b->failed = 1, 0;
        b->pair = p;
        b->cap = cap;
    }
    b->pair[2 * b->n] = i;
    b->pair[2 * b->n + 1] = j;
    b->n++;
    return 1;
}

typedef struct scan {
    dpc_lists *L;
    const dpc_near_job *codes;
    dpc_near_points_fn points;
    size_t limit; /* pairs per worker */
} scan;

/* Pairs of query i with the points from `from` on (skipping i itself). */
static void scan_one(const scan *sc, unsigned slot, uint32_t i, uint32_t from) {
    dpc_lists *L = sc->L;
    dpc_pair_buffer *b = &L->buf[slot];
    uint32_t *out = L->scratch + (size_t)slot * L->m;
    const unsigned n = sc->points(sc->codes, i, from, out, (unsigned)L->m);
    for (unsigned c = 0; c < n && !b->failed; c++)
        if (out[c] != i) add_pair(b, i, out[c], sc->limit);
}

static void build_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    const scan *sc = (const scan *)ctx;
    const size_t m = sc->L->m;
    for (size_t u = lo; u < hi && !sc->L->buf[slot].failed; u++) {
        scan_one(sc, slot, (uint32_t)u, (uint32_t)u + 1);
        if (m - 1 - u != u) scan_one(sc, slot, (uint32_t)(m - 1 - u), (uint32_t)(m - u));
    }
}

static void hot_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    const scan *sc = (const scan *)ctx;
    for (size_t h = lo; h < hi && !sc->L->buf[slot].failed; h++) scan_one(sc, slot, sc->L->hot_pts[h], 0);
}

static int cmp_u32(const void *a, const void *b) {
    const uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* The workers' pairs as CSR lists (both directions, each list ascending). */
static int assemble(dpc_lists *L, unsigned threads, uint32_t **off, uint32_t **list, size_t *cap) {
    const size_t m = L->m;
    size_t total = 0;
    for (unsigned t = 0; t < threads; t++) {
        if (L->buf[t].failed) return 0;
        total += 2 * L->buf[t].n;
    }
    if (!*off && !(*off = (uint32_t *)malloc((m + 1) * sizeof(uint32_t)))) return 0;
    if (total > *cap) {
        uint32_t *p = (uint32_t *)realloc(*list, (total ? total : 1) * sizeof(uint32_t));
        if (!p) return 0;
        *list = p;
        *cap = total;
    }
    uint32_t *o = *off;
    memset(o, 0, (m + 1) * sizeof(uint32_t));
    for (unsigned t = 0; t < threads; t++)
        for (size_t c = 0; c < 2 * L->buf[t].n; c++) o[L->buf[t].pair[c] + 1]++;
    for (size_t i = 0; i < m; i++) o[i + 1] += o[i];
    for (unsigned t = 0; t < threads; t++) /* place with cursors o[i], then restore the starts */
        for (size_t c = 0; c < L->buf[t].n; c++) {
            const uint32_t a = L->buf[t].pair[2 * c], b = L->buf[t].pair[2 * c + 1];
            (*list)[o[a]++] = b;
            (*list)[o[b]++] = a;
        }
    for (size_t i = m; i > 0; i--) o[i] = o[i - 1];
    o[0] = 0;
    for (size_t i = 0; i < m; i++)
        if (o[i + 1] - o[i] > 1) qsort(*list + o[i], o[i + 1] - o[i], sizeof(uint32_t), cmp_u32);
    return 1;
}

static int ensure(dpc_lists *L, unsigned threads) {
    const size_t m = L->m;
    if (!L->at) L->at = (float *)malloc(m * DPC_MAX_DIMS * sizeof(float));
    if (!L->hot_pts) L->hot_pts = (uint32_t *)malloc(m * sizeof(uint32_t));
    if (!L->hot_off) L->hot_off = (uint32_t *)calloc(m + 1, sizeof(uint32_t));
    if (L->scratch_slots < threads) {
        free(L->scratch);
        L->scratch = (uint32_t *)malloc((size_t)threads * m * sizeof(uint32_t));
        L->scratch_slots = L->scratch ? threads : 0;
    }
    return L->at && L->hot_pts && L->scratch && L->hot_off;
}

static void reset_buffers(dpc_lists *L) {
    for (unsigned t = 0; t < DPC_MAX_THREADS; t++) L->buf[t].n = 0, L->buf[t].failed = 0;
}

int dpc_lists_update(dpc_lists *L, uint64_t mask, const dpc_sub_job *job, const dpc_near_job *codes,
                     dpc_near_points_fn points, unsigned threads) {
    const size_t m = L->m;
    const unsigned k = job->k;
    const double r = job->radius;
    if (threads < 1) threads = 1;
    if (!ensure(L, threads)) return L->mask = 0, 0;
    scan sc = {L, codes, points, PAIRS_PER_POINT * m / threads + 1024};
    if (L->mask == mask && L->k == k && r < L->list_r) {
        const double reach = 0.5 * ((double)L->list_r - r * (1.0 + 1e-4)); /* the move that keeps a pair out */
        size_t n_hot = 0;
        for (size_t s = 0; s < m; s++) {
            double d2 = 0.0;
            for (unsigned q = 0; q < k; q++) {
                double t = (double)job->coord[q][s] - (double)L->at[s * k + q];
                t -= nearbyint(t);
                d2 += t * t;
            }
            if (d2 > reach * reach) L->hot_pts[n_hot++] = (uint32_t)s;
        }
        if (n_hot == 0) {
            memset(L->hot_off, 0, (m + 1) * sizeof(uint32_t));
            return 1;
        }
        if (n_hot <= m / HOT_SHARE) {
            reset_buffers(L);
            dpc_parallel_ranges(threads, n_hot, hot_range, &sc);
            if (assemble(L, threads, &L->hot_off, &L->hot, &L->hot_cap)) return 1;
            return L->mask = 0, 0;
        }
    }
    /* build at list_r */
    double list_r = (1.0 + DPC_LISTS_SKIN) * r;
    if (list_r > 0.5) list_r = 0.5;
    dpc_near_job wide = *codes;
    wide.limit = dpc_near_limit((float)list_r);
    sc.codes = &wide;
    reset_buffers(L);
    dpc_parallel_ranges(threads, (m + 1) / 2, build_range, &sc);
    if (!assemble(L, threads, &L->near_off, &L->near, &L->near_cap)) return L->mask = 0, 0;
    memset(L->hot_off, 0, (m + 1) * sizeof(uint32_t));
    for (size_t s = 0; s < m; s++)
        for (unsigned q = 0; q < k; q++) L->at[s * k + q] = job->coord[q][s];
    L->mask = mask;
    L->k = k;
    L->list_r = (float)list_r;
    return 1;
}

static int add(uint32_t *ranges, unsigned *n, unsigned cap, uint32_t j, uint32_t m) {
    if (*n && ranges[2 * *n - 1] > j) return 1; /* its block is in already */
    return dpc_near_add_block(ranges, n, cap, j / 8, m);
}

unsigned dpc_lists_ranges(const dpc_lists *L, uint32_t s, uint32_t *ranges, unsigned cap) {
    const uint32_t m = (uint32_t)L->m;
    uint32_t a = L->near_off[s], b = L->hot_off[s];
    const uint32_t ae = L->near_off[s + 1], be = L->hot_off[s + 1];
    unsigned n = 0;
    while (a < ae || b < be) { /* the two ascending lists merged */
        const uint32_t j = (b >= be || (a < ae && L->near[a] <= L->hot[b])) ? L->near[a++] : L->hot[b++];
        if (!add(ranges, &n, cap, j, m)) return cap + 1;
    }
    return n;
}
