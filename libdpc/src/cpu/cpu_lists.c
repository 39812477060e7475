/* Verlet neighbour lists in two tiers (cpu_lists.h). */
#include "cpu/cpu_lists.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define FAR_SHARE 16                     /* rebuild when more than m / FAR_SHARE points are far */
#define WARM_SHARE 8                     /* refresh the near lists when more than m / WARM_SHARE points are warm */
#define PAIRS_PER_POINT 256u             /* a worker holding more pairs than this per point gives up (crowded) */
#define ANCHOR_COLUMN(m) (2 * (m) + 160) /* bytes per anchor code column: readable 128 past 2m (cpu_near.h) */
#define MAX_LIST_RADIUS 0.98             /* the filter's 16-bit sums hold (256 r)^2 below this (cpu_near.h) */

void dpc_lists_init(dpc_lists *L, size_t m) {
    memset(L, 0, sizeof *L);
    L->m = m;
}

void dpc_lists_free(dpc_lists *L) {
    free(L->wide_off), free(L->wide), free(L->near_len), free(L->near), free(L->hot_off), free(L->hot);
    free(L->at_build), free(L->at_refresh), free(L->heat), free(L->hot_pts), free(L->far_pts), free(L->scratch);
    free(L->rows), free(L->extra_off), free(L->extra), free(L->extra_pair), free(L->anchor_code), free(L->near_off);
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
    const dpc_near_job *codes; /* its limit: the radius of this scan */
    dpc_near_points_fn points;
    dpc_near_list_fn list;
    size_t limit; /* pairs per worker */
    unsigned threads;
    const dpc_sub_job *job; /* heat_range, rows_range: the positions now, the move thresholds */
    double t1, t2;
} scan;

/* Pairs of point i with the points from `from` on (i itself left out), by the vector filter. */
static void scan_one(const scan *sc, unsigned slot, uint32_t i, uint32_t from) {
    dpc_lists *L = sc->L;
    dpc_pair_buffer *b = &L->buf[slot];
    uint32_t *out = L->scratch + (size_t)slot * L->m;
    const unsigned n = sc->points(sc->codes, i, from, out, (unsigned)L->m);
    for (unsigned c = 0; c < n && !b->failed; c++)
        if (out[c] != i) add_pair(b, i, out[c], sc->limit);
}

/* A build: each pair from its lower index, the queries in ascending order, cut into one
 * consecutive range per worker with about the same number of pairs (query u has m - 1 - u), so
 * that the workers' pairs in slot order are in query order and every list comes out ascending. */
static void build_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    const scan *sc = (const scan *)ctx;
    const double m = (double)sc->L->m, T = (double)sc->threads;
    const size_t a = (size_t)(m * (1.0 - sqrt(1.0 - (double)lo / T)));
    const size_t b = hi >= sc->threads ? sc->L->m : (size_t)(m * (1.0 - sqrt(1.0 - (double)hi / T)));
    for (size_t u = a; u < b && !sc->L->buf[slot].failed; u++) scan_one(sc, slot, (uint32_t)u, (uint32_t)u + 1);
}

/* A point's wide list and the pairs found for re-anchored points, merged ascending without
 * repeats and without i (into buf, or the wide list itself when there are none); *n of them. */
static const uint32_t *wide_and_extra(const dpc_lists *L, uint32_t i, uint32_t *buf, unsigned *n) {
    const uint32_t *a = L->wide + L->wide_off[i], *b = L->extra + L->extra_off[i];
    const uint32_t na = L->wide_off[i + 1] - L->wide_off[i], nb = L->extra_off[i + 1] - L->extra_off[i];
    if (nb == 0) {
        *n = na;
        return a;
    }
    uint32_t x = 0, y = 0;
    unsigned got = 0;
    while (x < na || y < nb) {
        const uint32_t j = (y >= nb || (x < na && a[x] <= b[y])) ? a[x++] : b[y++];
        if (j != i && (got == 0 || buf[got - 1] != j)) buf[got++] = j;
    }
    *n = got;
    return buf;
}

/* The pairs of this pass's warm points at radius r, from their wide and extra lists (far points
 * were re-anchored first, and are warm now). */
static void hot_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    const scan *sc = (const scan *)ctx;
    dpc_lists *L = sc->L;
    dpc_pair_buffer *b = &L->buf[slot];
    uint32_t *out = L->scratch + (size_t)slot * L->m;
    for (size_t h = lo; h < hi && !b->failed; h++) {
        const uint32_t i = L->hot_pts[h];
        unsigned n;
        const uint32_t *cand = wide_and_extra(L, i, out, &n);
        n = sc->list(L->rows, L->row_bytes, i, cand, n, sc->codes->limit, out); /* in place: out never passes cand */
        for (unsigned c = 0; c < n; c++) add_pair(b, i, out[c], sc->limit);
    }
}

/* Re-anchoring: a far point's pairs within r2 of its new anchor, against every point's anchor. */
static void reanchor_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    const scan *sc = (const scan *)ctx;
    for (size_t f = lo; f < hi && !sc->L->buf[slot].failed; f++) scan_one(sc, slot, sc->L->far_pts[f], 0);
}

/* A refresh: of each wide and extra list, the points within r1 now (codes at limit(r1)). */
static void refresh_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    const scan *sc = (const scan *)ctx;
    dpc_lists *L = sc->L;
    uint32_t *buf = L->scratch + (size_t)slot * L->m;
    for (size_t i = lo; i < hi; i++) {
        unsigned n;
        const uint32_t *cand = wide_and_extra(L, (uint32_t)i, buf, &n);
        L->near_len[i] =
            sc->list(L->rows, L->row_bytes, (uint32_t)i, cand, n, sc->codes->limit, L->near + L->near_off[i]);
    }
}

static int cmp_u32(const void *a, const void *b) {
    const uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* Pairs (2 per pair, in `segments` arrays of n[g] pairs) as CSR lists, both directions, placed
 * in segment and pair order; each list is sorted afterwards unless `sorted` (a build's pairs come
 * in order, build_range). */
static int csr(size_t m, const uint32_t *const *seg, const size_t *n, unsigned segments, uint32_t **off,
               uint32_t **list, size_t *cap, int sorted) {
    size_t total = 0;
    for (unsigned g = 0; g < segments; g++) total += 2 * n[g];
    if (!*off && !(*off = (uint32_t *)malloc((m + 1) * sizeof(uint32_t)))) return 0;
    if (total > *cap || !*list) {
        uint32_t *p = (uint32_t *)realloc(*list, (total ? total : 1) * sizeof(uint32_t));
        if (!p) return 0;
        *list = p;
        *cap = total;
    }
    uint32_t *o = *off;
    memset(o, 0, (m + 1) * sizeof(uint32_t));
    for (unsigned g = 0; g < segments; g++)
        for (size_t c = 0; c < 2 * n[g]; c++) o[seg[g][c] + 1]++;
    for (size_t i = 0; i < m; i++) o[i + 1] += o[i];
    for (unsigned g = 0; g < segments; g++) /* place with cursors o[i], then restore the starts */
        for (size_t c = 0; c < n[g]; c++) {
            const uint32_t a = seg[g][2 * c], b = seg[g][2 * c + 1];
            (*list)[o[a]++] = b;
            (*list)[o[b]++] = a;
        }
    for (size_t i = m; i > 0; i--) o[i] = o[i - 1];
    o[0] = 0;
    if (!sorted)
        for (size_t i = 0; i < m; i++)
            if (o[i + 1] - o[i] > 1) qsort(*list + o[i], o[i + 1] - o[i], sizeof(uint32_t), cmp_u32);
    return 1;
}

/* The workers' pairs (csr, one segment per worker); 0 when a worker ran out of room. */
static int assemble(dpc_lists *L, unsigned threads, uint32_t **off, uint32_t **list, size_t *cap, int sorted) {
    const uint32_t *seg[DPC_MAX_THREADS];
    size_t n[DPC_MAX_THREADS];
    for (unsigned t = 0; t < threads; t++) {
        if (L->buf[t].failed) return 0;
        seg[t] = L->buf[t].pair;
        n[t] = L->buf[t].n;
    }
    return csr(L->m, seg, n, threads, off, list, cap, sorted);
}

static int ensure(dpc_lists *L, unsigned threads, unsigned k) {
    const size_t m = L->m;
    const unsigned row = (k + 15) / 16 * 16; /* bytes of a code row, floats of a snapshot row (job->row_stride) */
    if (row > L->row_bytes) {
        free(L->rows), free(L->at_build), free(L->at_refresh);
        L->rows = (uint8_t *)calloc(m, row);
        L->at_build = (float *)malloc(m * row * sizeof(float));
        L->at_refresh = (float *)malloc(m * row * sizeof(float));
        L->row_bytes = L->rows && L->at_build && L->at_refresh ? row : 0;
        L->mask = 0; /* the snapshots are gone */
    }
    if (!L->heat) L->heat = (uint8_t *)malloc(m);
    if (!L->hot_pts) L->hot_pts = (uint32_t *)malloc(m * sizeof(uint32_t));
    if (!L->far_pts) L->far_pts = (uint32_t *)malloc(m * sizeof(uint32_t));
    if (!L->near_len) L->near_len = (uint32_t *)malloc(m * sizeof(uint32_t));
    if (!L->hot_off) L->hot_off = (uint32_t *)calloc(m + 1, sizeof(uint32_t));
    if (!L->extra_off) L->extra_off = (uint32_t *)calloc(m + 1, sizeof(uint32_t));
    if (!L->near_off) L->near_off = (uint32_t *)calloc(m + 1, sizeof(uint32_t));
    if (!L->anchor_code) L->anchor_code = (uint8_t *)calloc(DPC_MAX_DIMS / 2 * ANCHOR_COLUMN(m), 1);
    if (L->scratch_slots < threads) {
        free(L->scratch);
        L->scratch = (uint32_t *)malloc((size_t)threads * m * sizeof(uint32_t));
        L->scratch_slots = L->scratch ? threads : 0;
    }
    return L->rows && L->at_build && L->at_refresh && L->heat && L->hot_pts && L->far_pts && L->near_len &&
           L->hot_off && L->extra_off && L->near_off && L->anchor_code && L->scratch;
}

static void reset_buffers(dpc_lists *L) {
    for (unsigned t = 0; t < DPC_MAX_THREADS; t++) L->buf[t].n = 0, L->buf[t].failed = 0;
}

typedef float v4 __attribute__((vector_size(16)));
typedef int32_t i4 __attribute__((vector_size(16)));

/* Squared torus distance of a point now from its position at a snapshot (rows of
 * job->row_stride floats), in float: the thresholds it is compared with carry a margin for its
 * rounding (a relative 1e-6, where the margin is 1e-4). */
static float moved2(const float *now, const float *at, unsigned stride) {
    v4 d2 = {0.0f, 0.0f, 0.0f, 0.0f};
    for (unsigned q = 0; q < stride; q += 4) { /* whole rows (zero past k), four dimensions at a time */
        v4 a, b;
        memcpy(&a, now + q, sizeof a);
        memcpy(&b, at + q, sizeof b);
        v4 t = a - b; /* in (-1, 1) */
        const v4 half = {0.5f, 0.5f, 0.5f, 0.5f}, one = {1.0f, 1.0f, 1.0f, 1.0f};
        t = t - (v4)((i4)one & (t > half)) + (v4)((i4)one & (t < -half)); /* the torus's nearest image */
        d2 += t * t;
    }
    return (d2[0] + d2[1]) + (d2[2] + d2[3]);
}

static void snapshot(const dpc_sub_job *job, float *at, size_t m) {
    memcpy(at, job->row, m * job->row_stride * sizeof(float));
}

/* The codes as rows (cpu_near.h: dpc_near_list_fn), zero past k: from the kernel's rows, the
 * same values as the columns' codes (floor(256 x), cpu_cascade.c). */
static void rows_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    (void)slot;
    const scan *sc = (const scan *)ctx;
    const unsigned k = sc->job->k, stride = sc->job->row_stride;
    for (size_t j = lo; j < hi; j++) {
        uint8_t *row = sc->L->rows + j * sc->L->row_bytes;
        const float *x = sc->job->row + j * stride;
        for (unsigned q = 0; q < k; q++) row[q] = (uint8_t)(x[q] * 256.0f);
    }
}

/* Each point's heat (cpu_lists.h): far, warm or cold. */
static void heat_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    (void)slot;
    const scan *sc = (const scan *)ctx;
    dpc_lists *L = sc->L;
    const size_t stride = sc->job->row_stride;
    const float far2 = (float)(sc->t2 * sc->t2 * (1.0 - 1e-4)), warm2 = (float)(sc->t1 * sc->t1 * (1.0 - 1e-4));
    for (size_t s = lo; s < hi; s++) {
        const float *now = sc->job->row + s * stride;
        L->heat[s] = moved2(now, L->at_build + s * stride, (unsigned)stride) > far2      ? 2
                     : moved2(now, L->at_refresh + s * stride, (unsigned)stride) > warm2 ? 1
                                                                                         : 0;
    }
}

static int refresh(dpc_lists *L, const dpc_sub_job *job, const dpc_near_job *codes, dpc_near_list_fn list,
                   unsigned threads) {
    dpc_near_job at_r1 = *codes;
    at_r1.limit = dpc_near_limit(L->r1);
    scan sc = {L, &at_r1, NULL, list, 0, threads, job, 0.0, 0.0};
    for (size_t i = 0; i <= L->m; i++) L->near_off[i] = L->wide_off[i] + L->extra_off[i];
    if (L->near_off[L->m] > L->near_cap || !L->near) {
        uint32_t *p = (uint32_t *)realloc(L->near, (L->near_off[L->m] ? L->near_off[L->m] : 1) * sizeof(uint32_t));
        if (!p) return 0;
        L->near = p;
        L->near_cap = L->near_off[L->m];
    }
    dpc_parallel_ranges(threads, L->m, refresh_range, &sc);
    snapshot(job, L->at_refresh, L->m);
    L->refreshes++;
    return 1;
}

/* Re-anchor this pass's far points: their anchors (rows and codes) become their positions now,
 * and each is filtered at r2 against every point's anchor; the pairs found join the extra lists.
 * Afterwards they count as warm (heat 1). 0: no memory. */
static int reanchor(dpc_lists *L, const dpc_sub_job *job, const dpc_near_job *codes, const scan *now) {
    const size_t m = L->m, stride = job->row_stride;
    dpc_near_job anchors = *codes;
    anchors.limit = dpc_near_limit(L->r2);
    for (unsigned p = 0; p < codes->pairs; p++) anchors.code[p] = L->anchor_code + p * ANCHOR_COLUMN(m);
    for (size_t h = 0; h < L->n_far; h++) {
        const uint32_t f = L->far_pts[h];
        memcpy(L->at_build + f * stride, job->row + f * stride, stride * sizeof(float));
        for (unsigned p = 0; p < codes->pairs; p++)
            memcpy((uint8_t *)anchors.code[p] + 2 * (size_t)f, codes->code[p] + 2 * (size_t)f, 2);
        L->heat[f] = 1;
    }
    scan sc = *now;
    sc.codes = &anchors;
    reset_buffers(L);
    dpc_parallel_ranges(sc.threads, L->n_far, reanchor_range, &sc);
    size_t added = 0;
    for (unsigned t = 0; t < sc.threads; t++) {
        if (L->buf[t].failed) return 0;
        added += L->buf[t].n;
    }
    if (L->n_extra_pair + added > L->extra_pair_cap) {
        const size_t cap = 2 * (L->n_extra_pair + added);
        uint32_t *p = (uint32_t *)realloc(L->extra_pair, 2 * cap * sizeof(uint32_t));
        if (!p) return 0;
        L->extra_pair = p;
        L->extra_pair_cap = cap;
    }
    for (unsigned t = 0; t < sc.threads; t++) {
        memcpy(L->extra_pair + 2 * L->n_extra_pair, L->buf[t].pair, 2 * L->buf[t].n * sizeof(uint32_t));
        L->n_extra_pair += L->buf[t].n;
    }
    L->reanchors++;
    const uint32_t *all = L->extra_pair;
    return csr(m, &all, &L->n_extra_pair, 1, &L->extra_off, &L->extra, &L->extra_cap, 0);
}

int dpc_lists_update(dpc_lists *L, uint64_t mask, const dpc_sub_job *job, const dpc_near_job *codes,
                     dpc_near_points_fn points, dpc_near_list_fn list, unsigned threads) {
    const size_t m = L->m;
    const unsigned k = job->k;
    const double r = job->radius * (1.0 + 1e-4); /* a margin for the kernel's float32 distances */
    if (threads < 1) threads = 1;
    if (!ensure(L, threads, k)) return L->mask = 0, 0;
    scan sc = {L, codes, points, list, PAIRS_PER_POINT * m / threads + 1024, threads, job, 0.0, 0.0};
    dpc_parallel_ranges(threads, m, rows_range, &sc);
    if (L->mask == mask && L->k == k && r < L->r1) {
        sc.t1 = 0.5 * ((double)L->r1 - r);
        sc.t2 = 0.5 * ((double)L->r2 - r);
        dpc_parallel_ranges(threads, m, heat_range, &sc);
        size_t n_warm = 0;
        L->n_far = 0;
        for (size_t s = 0; s < m; s++) {
            if (L->heat[s] == 2) L->far_pts[L->n_far++] = (uint32_t)s;
            n_warm += L->heat[s] == 1;
        }
        /* Far points are re-anchored (each filtered once against every anchor), unless so many
         * are far at once, or the pairs so found outgrow the wide lists, that a build pays. */
        const size_t wide_pairs = L->wide_off[m] / 2;
        if (L->n_far <= m / FAR_SHARE && L->n_extra_pair <= wide_pairs + m) {
            if (L->n_far && !reanchor(L, job, codes, &sc)) return L->mask = 0, 0;
            n_warm += L->n_far; /* re-anchored: warm (moved since the refresh) */
            /* Rent or buy: warm points cost their lists each pass, which a refresh (m lists) ends. */
            L->warm_work += (double)n_warm;
            if (n_warm > m / WARM_SHARE || L->warm_work > (double)m) {
                L->warm_work = 0.0; /* the warm points' pairs with the others now come from the near lists */
                if (!refresh(L, job, codes, list, threads)) return L->mask = 0, 0;
                memset(L->heat, 0, m);
                n_warm = 0;
            }
            size_t n_hot = 0;
            for (size_t s = 0; s < m; s++)
                if (L->heat[s]) L->hot_pts[n_hot++] = (uint32_t)s;
            if (n_hot == 0) {
                memset(L->hot_off, 0, (m + 1) * sizeof(uint32_t));
                return 1;
            }
            reset_buffers(L);
            dpc_parallel_ranges(threads, n_hot, hot_range, &sc);
            L->hot_passes++;
            if (assemble(L, threads, &L->hot_off, &L->hot, &L->hot_cap, 0)) return 1;
            return L->mask = 0, 0;
        }
    }
    /* build at r2, then the near lists at r1 */
    double r2 = (1.0 + DPC_LISTS_WIDE) * job->radius, r1 = (1.0 + DPC_LISTS_SKIN) * job->radius;
    if (r2 > MAX_LIST_RADIUS) r2 = MAX_LIST_RADIUS;
    if (r1 > r2) r1 = r2;
    dpc_near_job wide = *codes;
    wide.limit = dpc_near_limit((float)r2);
    sc.codes = &wide;
    reset_buffers(L);
    dpc_parallel_ranges(threads, threads, build_range, &sc);
    if (!assemble(L, threads, &L->wide_off, &L->wide, &L->wide_cap, 1)) return L->mask = 0, 0;
    memset(L->extra_off, 0, (m + 1) * sizeof(uint32_t));
    L->n_extra_pair = 0;
    for (unsigned p = 0; p < codes->pairs; p++) memcpy(L->anchor_code + p * ANCHOR_COLUMN(m), codes->code[p], 2 * m);
    L->k = k;
    L->r1 = (float)r1;
    L->r2 = (float)r2;
    if (!refresh(L, job, codes, list, threads)) return L->mask = 0, 0;
    snapshot(job, L->at_build, m);
    memset(L->hot_off, 0, (m + 1) * sizeof(uint32_t));
    L->warm_work = 0.0;
    L->mask = mask;
    L->builds++;
    return 1;
}

const uint32_t *dpc_lists_candidates(const dpc_lists *L, uint32_t s, uint32_t *buf, unsigned cap, unsigned *n) {
    const uint32_t *near = L->near + L->near_off[s];
    const uint32_t ae = L->near_len[s], be = L->hot_off[s + 1] - L->hot_off[s];
    if (be == 0) { /* the near list as it is (it never holds s: builds leave each point out of its own) */
        *n = ae;
        return near;
    }
    const uint32_t *hot = L->hot + L->hot_off[s];
    uint32_t a = 0, b = 0;
    unsigned got = 0;
    while (a < ae || b < be) { /* the two ascending lists merged */
        const uint32_t j = (b >= be || (a < ae && near[a] <= hot[b])) ? near[a++] : hot[b++];
        if (got && buf[got - 1] == j) continue; /* neither list holds s (wide_and_extra leaves it out) */
        if (got == cap) return NULL;
        buf[got++] = j;
    }
    *n = got;
    return buf;
}
