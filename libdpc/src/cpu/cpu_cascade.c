/* CPU backend: runs a cascade on one point set in place (docs/model-format.md §3).
 *
 * Per layer and subspace, candidates come from a toroidal cell grid over the subspace's dims
 * (points counting-sorted by cell, coordinates copied structure-of-arrays so each row of
 * neighbouring cells is one contiguous index range), or from all pairs where the grid does not
 * pay (few points, high-dimensional subspaces, radius near the domain size). All pairs in 5 or
 * more dimensions go through the neighbour prefilter (cpu_near.h), which drops the candidate
 * blocks with no point in reach and leaves the bits as they are. Each point's sum is computed
 * by exactly one thread in a fixed order, so the bits do not depend on the thread count. */
#include "cpu/cpu_cascade.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "common/error.h"
#include "common/rng.h"
#include "common/threads.h"
#include "cpu/cpu_grid.h"
#include "cpu/cpu_lists.h"
#include "model/balance.h"
#include "model/input.h"
#include "model/level_order.h"
#include "model/plan.h"
#include "model/relax.h"

#define MAX_RANGES DPC_PLAN_MAX_RANGES /* index ranges per point (2 per row of cells) */

#define PARALLEL_MIN_POINTS 2048 /* below this, the pool's hand-offs cost more than the threads save */

/* All pairs in subspaces of at least this many dimensions and sets of at least this many points
 * go through the prefilter, when the ball of radius r is expected to hold at most m / 16 points
 * (else most 8-candidate blocks pass anyway): in fewer dimensions the grid serves (or the radius
 * covers most of the torus), and small sets scan all pairs in no time. */
#define PREFILTER_MIN_DIMS 5
#define PREFILTER_MIN_POINTS 256
/* Neighbour lists kept across layers (cpu_lists.h) where the ball of the near lists' radius r1 is
 * expected to hold at most this many points, and that of the wide lists' r2 at most
 * WIDE_MAX_EXPECTED; denser subspaces filter every query every layer. */
#define LIST_MAX_EXPECTED 24.0
#define WIDE_MAX_EXPECTED 160.0
#define MAX_CANDIDATES 1024 /* a point's list candidates on the stack; more: all pairs (the same bits) */

/* The engine's loops over points: one range per worker (dpc_parallel_ranges), or the whole
 * range on the calling thread for small sets. */
static void parallel_for(unsigned threads, size_t n, dpc_range_fn fn, void *ctx) {
    dpc_parallel_ranges(n < PARALLEL_MIN_POINTS ? 1u : threads, n, fn, ctx);
}

typedef struct workspace {
    size_t m, n;
    float *delta;         /* m * n: summed subspace displacements */
    float *soa;           /* n columns of `stride` floats: coordinates of the current subspace, sorted */
    size_t stride;        /* column stride: m rounded up to 16, plus 16 floats that SIMD loads may read */
    uint32_t *perm;       /* m: sorted position -> point index */
    uint32_t *cell_of;    /* m: cell id of each point */
    uint32_t *cell_start; /* cells + 1 */
    size_t cell_cap;
    /* Points are kept physically sorted by cell between layers (they move little per layer, so
     * each layer's sort then reads memory almost sequentially): x is the working copy, order[i]
     * the caller's index of working point i; x_tmp / order_tmp are the reorder targets. */
    float *x, *x_tmp;
    uint32_t *order, *order_tmp, *cell_tmp;
    float *gather;   /* per worker: 4 columns of DPC_GATHER_STRIDE floats (kernel scratch) */
    uint8_t *code;   /* prefilter codes: DPC_MAX_DIMS / 2 columns of 2 * stride + 128 bytes (allocated on first use) */
    float *rows;     /* the list kernel's rows (dpc_sub_job.row), allocated on first use */
    size_t rows_cap; /* floats */
    dpc_lists lists; /* the prefilter's neighbour lists, kept across layers (dropped when the working order changes) */
    size_t frozen;   /* points whose caller index is below this never move (progressive levels) */
    dpc_cpu_hook hook; /* NULL: never stopped */
    void *hook_ctx;
    _Atomic int stop; /* the status a hook returned (DPC_OK: go on); read by every worker */
} workspace;

/* Ask the hook (inside a layer: layer_done = 0); whether to stop. */
static int poll_stop(workspace *ws, int layer_done) {
    if (!ws->hook) return 0;
    if (atomic_load_explicit(&ws->stop, memory_order_relaxed) != DPC_OK) return 1;
    const dpc_status st = ws->hook(ws->hook_ctx, layer_done);
    if (st != DPC_OK) {
        int expected = DPC_OK;
        atomic_compare_exchange_strong(&ws->stop, &expected, (int)st);
        return 1;
    }
    return 0;
}

static void workspace_free(workspace *w) {
    free(w->delta);
    free(w->soa);
    free(w->perm);
    free(w->cell_of);
    free(w->cell_start);
    free(w->x);
    free(w->x_tmp);
    free(w->order);
    free(w->order_tmp);
    free(w->cell_tmp);
    free(w->gather);
    free(w->code);
    free(w->rows);
    dpc_lists_free(&w->lists);
}

static dpc_status workspace_init(workspace *w, size_t m, size_t n, unsigned threads) {
    memset(w, 0, sizeof *w);
    w->m = m;
    w->n = n;
    w->cell_cap = 2 * m + DPC_PLAN_CELL_SLACK; /* the most cells a plan's grid has */
    dpc_lists_init(&w->lists, m);
    w->stride = (m + 15) / 16 * 16 + 16;
    w->delta = (float *)malloc(m * n * sizeof(float));
    w->soa = (float *)calloc(w->stride * n, sizeof(float));
    w->perm = (uint32_t *)malloc(m * sizeof(uint32_t));
    w->cell_of = (uint32_t *)malloc(m * sizeof(uint32_t));
    w->cell_start = (uint32_t *)malloc((w->cell_cap + 1) * sizeof(uint32_t));
    w->x = (float *)malloc(m * n * sizeof(float));
    w->x_tmp = (float *)malloc(m * n * sizeof(float));
    w->order = (uint32_t *)malloc(m * sizeof(uint32_t));
    w->order_tmp = (uint32_t *)malloc(m * sizeof(uint32_t));
    w->cell_tmp = (uint32_t *)malloc(m * sizeof(uint32_t));
    w->gather = (float *)malloc((size_t)threads * 4 * DPC_GATHER_STRIDE * sizeof(float));
    if (!w->gather || !w->cell_tmp || !w->delta || !w->soa || !w->perm || !w->cell_of || !w->cell_start || !w->x ||
        !w->x_tmp || !w->order || !w->order_tmp) {
        workspace_free(w);
        return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for a %zu x %zu point set", m, n);
    }
    return DPC_OK;
}

/* ---- one subspace of one layer ----------------------------------------------------------- */

typedef struct sub_pass {
    const dpc_cpu_engine *engine;
    workspace *ws;
    dpc_sub_job job;
    const unsigned *dim; /* subspace dimension q -> point dimension (the plan's) */
    float h;             /* mean spacing of the subspace */
    int grid;            /* 0: all pairs */
    uint32_t G, R;       /* cells per axis, cell offsets searched per axis */
    int local_cells;     /* 2R + 3 <= G: the cells searched around a cell that stay inside the grid
                          * lie less than (R + 1) / G <= 1/2 from it on every axis (plus the cell
                          * coordinates' rounding, a thousandth of a cell: plan.h), so its block
                          * is local (cpu_kernels.h) */
    int near;            /* all pairs through the prefilter */
    dpc_near_job near_job;
    int lists; /* near, through the workspace's lists */
} sub_pass;

/* The grid cell id of each point (k a constant where the caller specialises). */
static inline __attribute__((always_inline)) void cell_ids(sub_pass *p, const float *x, unsigned k) {
    workspace *ws = p->ws;
    const size_t m = ws->m, n = ws->n;
    const uint32_t G = p->G;
    for (size_t i = 0; i < m; i++) {
        uint32_t id = 0;
        for (unsigned q = k; q-- > 0;) {
            uint32_t c = (uint32_t)(x[i * n + p->dim[q]] * (float)G);
            id = id * G + (c < G ? c : G - 1);
        }
        ws->cell_of[i] = id;
    }
}

/* Sort points by cell (stable counting sort): cell_of, cell_start and perm. */
static void sort_cells(sub_pass *p, const float *x) {
    workspace *ws = p->ws;
    const size_t m = ws->m;
    const unsigned k = p->job.k;
    if (!p->grid) {
        for (size_t i = 0; i < m; i++) ws->perm[i] = (uint32_t)i;
    } else {
        size_t cells = 1;
        for (unsigned q = 0; q < k; q++) cells *= p->G;
        if (k == 2) cell_ids(p, x, 2); /* the common case, unrolled */
        else cell_ids(p, x, k);
        dpc_grid_sort(ws->cell_of, m, cells, ws->cell_start, ws->perm);
    }
}

/* Copy the subspace's coordinates, in sorted order, structure-of-arrays. */
static void soa_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    (void)slot;
    const sub_pass *p = (const sub_pass *)ctx;
    const workspace *ws = p->ws;
    for (unsigned q = 0; q < p->job.k; q++) {
        float *col = ws->soa + q * ws->stride;
        for (size_t s = lo; s < hi; s++) col[s] = ws->x[(size_t)ws->perm[s] * ws->n + p->dim[q]];
    }
}

static void fill_soa(sub_pass *p) {
    workspace *ws = p->ws;
    for (unsigned q = 0; q < p->job.k; q++) p->job.coord[q] = ws->soa + q * ws->stride;
    parallel_for(p->engine->threads, ws->m, soa_range, p);
}

/* The prefilter's codes of the subspace's coordinates (sorted order), two dimensions per pair;
 * 0 when there is no memory for them. */
static void codes_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    (void)slot;
    const sub_pass *p = (const sub_pass *)ctx;
    const dpc_near_job *nj = &p->near_job;
    for (unsigned pr = 0; pr < nj->pairs; pr++) {
        uint8_t *c = (uint8_t *)nj->code[pr];
        for (unsigned e = 0; e < 2; e++) {
            const unsigned q = 2 * pr + e;
            if (q >= p->job.k) {
                for (size_t s = lo; s < hi; s++) c[2 * s + e] = 0;
                continue;
            }
            const float *col = p->job.coord[q];
            for (size_t s = lo; s < hi; s++) c[2 * s + e] = (uint8_t)(col[s] * 256.0f); /* exact: x in [0, 1) */
        }
    }
}

static int fill_codes(sub_pass *p) {
    workspace *ws = p->ws;
    const size_t m = ws->m, column = 2 * ws->stride + 128;
    if (!ws->code && !(ws->code = (uint8_t *)calloc(DPC_MAX_DIMS / 2 * column, 1))) return 0;
    dpc_near_job *nj = &p->near_job;
    nj->pairs = (p->job.k + 1) / 2;
    nj->m = (uint32_t)m;
    nj->limit = dpc_near_limit(p->job.radius);
    for (unsigned pr = 0; pr < nj->pairs; pr++) nj->code[pr] = ws->code + pr * column;
    parallel_for(p->engine->threads, m, codes_range, p);
    return 1;
}

/* The subspace's coordinates as rows for the list kernel (dpc_sub_job.row); 0 when there is no
 * memory for them. */
static void rows_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    (void)slot;
    const sub_pass *p = (const sub_pass *)ctx;
    const unsigned k = p->job.k, stride = p->job.row_stride;
    for (size_t s = lo; s < hi; s++) {
        float *row = p->ws->rows + s * stride;
        for (unsigned q = 0; q < k; q++) row[q] = p->job.coord[q][s];
        for (unsigned q = k; q < stride; q++) row[q] = 0.0f;
    }
}

static int fill_rows(sub_pass *p) {
    workspace *ws = p->ws;
    const unsigned stride = (p->job.k + 15) / 16 * 16;
    const size_t need = ws->m * stride;
    if (need > ws->rows_cap) {
        free(ws->rows);
        ws->rows = (float *)calloc(need, sizeof(float));
        ws->rows_cap = ws->rows ? need : 0;
        if (!ws->rows) return 0;
    }
    p->job.row = ws->rows;
    p->job.row_stride = stride;
    parallel_for(p->engine->threads, ws->m, rows_range, p);
    return 1;
}

/* The blocks of points lo..hi: a grid cell's points (which share candidate ranges), or runs of
 * points over all pairs. k is the subspace's size: a constant where the caller specialises. */
static inline __attribute__((always_inline)) void block_range(const sub_pass *p, unsigned slot, size_t lo, size_t hi,
                                                              unsigned k) {
    workspace *ws = p->ws;
    const size_t m = ws->m, n = ws->n;
    uint32_t ranges[2 * MAX_RANGES];
    float xs[DPC_BLOCK_MAX * 4], acc[DPC_BLOCK_MAX * 4]; /* blocks hold DPC_BLOCK_MAX * 4 floats */
    const unsigned block_cap = k <= 4 ? DPC_BLOCK_MAX : (DPC_BLOCK_MAX * 4) / k;
    float *scratch = p->grid ? ws->gather + (size_t)slot * 4 * DPC_GATHER_STRIDE : NULL; /* grid: k <= 4 */
    unsigned n_ranges = 1;
    ranges[0] = 0;
    ranges[1] = (uint32_t)m; /* all pairs */
    size_t next_poll = lo + DPC_CPU_POLL_POINTS;
    for (size_t s = lo; s < hi;) {
        if (s >= next_poll) {
            if (poll_stop(ws, 0)) return;
            next_poll = s + DPC_CPU_POLL_POINTS;
        }
        /* A block: consecutive sorted points of one cell (they share candidate ranges). */
        size_t e = s + 1;
        int local = 0;
        if (p->grid) {
            const uint32_t cell = ws->cell_of[ws->perm[s]];
            while (e < hi && e - s < block_cap && ws->cell_of[ws->perm[e]] == cell) e++;
            n_ranges = dpc_grid_ranges(k, p->G, p->R, ws->cell_start, cell, ranges, &local);
            local &= p->local_cells;
        } else {
            e = s + block_cap < hi ? s + block_cap : hi;
        }
        /* the block's points that move (held points of a progressive level are skipped: each
         * point's sum is its own, so the others' bits do not change; set models hold none, and
         * skip the two index loads) */
        uint32_t which[DPC_BLOCK_MAX];
        unsigned count = 0;
        for (size_t t = s; t < e; t++) {
            if (ws->frozen && ws->order[ws->perm[t]] < ws->frozen) continue;
            which[count] = (uint32_t)t;
            for (unsigned q = 0; q < k; q++) xs[count * k + q] = p->job.coord[q][t];
            count++;
        }
        if (count) p->engine->block(&p->job, xs, count, ranges, n_ranges, local, acc, scratch);
        for (unsigned b = 0; b < count; b++) {
            float *d = ws->delta + (size_t)ws->perm[which[b]] * n;
            for (unsigned q = 0; q < k; q++) d[p->dim[q]] += p->h * acc[b * k + q];
        }
        s = e;
    }
}

static void sub_pass_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    const sub_pass *p = (const sub_pass *)ctx;
    workspace *ws = p->ws;
    const unsigned k = p->job.k;
    const size_t m = ws->m, n = ws->n;
    uint32_t ranges[2 * MAX_RANGES];
    if (p->near) { /* one point at a time, each with its own ranges */
        float xs[DPC_MAX_DIMS], acc[DPC_MAX_DIMS];
        uint32_t cand[MAX_CANDIDATES];
        for (size_t s = lo; s < hi; s++) {
            if (((s - lo) & (DPC_CPU_POLL_POINTS - 1)) == DPC_CPU_POLL_POINTS - 1 && poll_stop(ws, 0)) return;
            if (ws->frozen && ws->order[ws->perm[s]] < ws->frozen) continue;
            for (unsigned q = 0; q < k; q++) xs[q] = p->job.coord[q][s];
            unsigned n_cand = 0;
            const uint32_t *cands =
                p->lists ? dpc_lists_candidates(&ws->lists, (uint32_t)s, cand, MAX_CANDIDATES, &n_cand) : NULL;
            if (cands) {
                p->engine->list(&p->job, xs, cands, n_cand, acc);
            } else {
                unsigned n_ranges =
                    p->lists ? MAX_RANGES + 1 : p->engine->near(&p->near_job, (uint32_t)s, ranges, MAX_RANGES);
                if (n_ranges > MAX_RANGES) { /* too many blocks pass: all of them */
                    ranges[0] = 0;
                    ranges[1] = (uint32_t)m;
                    n_ranges = 1;
                }
                p->engine->block(&p->job, xs, 1, ranges, n_ranges, 0, acc, NULL);
            }
            float *d = ws->delta + (size_t)ws->perm[s] * n;
            for (unsigned q = 0; q < k; q++) d[p->dim[q]] += p->h * acc[q];
        }
        return;
    }
    if (k == 2) block_range(p, slot, lo, hi, 2); /* the common case, unrolled */
    else block_range(p, slot, lo, hi, k);
}

/* ---- applying a layer -------------------------------------------------------------------- */

typedef struct apply_pass {
    float *x;
    const float *delta;
    const uint32_t *order; /* working point -> caller index */
    size_t n, frozen;
    float count[DPC_MAX_DIMS]; /* c_k, 0 for dimensions that do not move */
    int all_ones;              /* no held points and every c_k = 1 (apply_all) */
} apply_pass;

/* y (a coordinate plus its step) wrapped into [0, 1): y - floor(y), with the usual cases first
 * (the same operations, so the same bits). -tiny + 1 rounds to 1: mapped to 0. Overflow (inf or
 * NaN, only from absurd kernels) also maps to 0, so every output and every cell index stays in
 * range. */
static inline float wrapped(float y) {
    if (y >= 1.0f && y < 2.0f) y -= 1.0f;
    else if (y < 0.0f && y >= -1.0f) y += 1.0f;
    else if (!(y >= 0.0f && y < 1.0f)) y -= floorf(y);
    return (y >= 0.0f && y < 1.0f) ? y : 0.0f;
}

/* wrapped(x + step) for every coordinate of points lo..hi (no held points, every dimension in
 * one subspace), 4 at a time in GCC vectors (SSE2 everywhere): the two usual cases as selects,
 * which give wrapped()'s value wherever they land in [0, 1); a vector with a lane elsewhere (a
 * step past a period, inf, NaN, or -tiny + 1 = 1) and the tail go through wrapped() itself. */
static void apply_all(const apply_pass *a, size_t lo, size_t hi) {
    typedef float v4 __attribute__((vector_size(16)));
    typedef int32_t i4 __attribute__((vector_size(16)));
    float *x = a->x + lo * a->n;
    const float *step = a->delta + lo * a->n;
    const size_t count = (hi - lo) * a->n;
    size_t j = 0;
    for (; j + 4 <= count; j += 4) {
        v4 y, s;
        memcpy(&y, x + j, sizeof y);
        memcpy(&s, step + j, sizeof s);
        y = y + s;
        const i4 down = (y >= 1.0f) & (y < 2.0f);
        y = (v4)((down & (i4)(y - 1.0f)) | (~down & (i4)y));
        const i4 up = (y < 0.0f) & (y >= -1.0f);
        y = (v4)((up & (i4)(y + 1.0f)) | (~up & (i4)y));
        const i4 out = ~((y >= 0.0f) & (y < 1.0f));
        if (out[0] | out[1] | out[2] | out[3])
            for (size_t l = j; l < j + 4; l++) x[l] = wrapped(x[l] + step[l]);
        else memcpy(x + j, &y, sizeof y);
    }
    for (; j < count; j++) x[j] = wrapped(x[j] + step[j]);
}

static void apply_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    (void)slot;
    const apply_pass *a = (const apply_pass *)ctx;
    if (a->all_ones) {
        apply_all(a, lo, hi);
        return;
    }
    for (size_t i = lo; i < hi; i++) {
        if (a->frozen && a->order[i] < a->frozen) continue;
        for (size_t d = 0; d < a->n; d++) {
            if (a->count[d] == 0.0f) continue;
            const float step = a->delta[i * a->n + d];
            a->x[i * a->n + d] = wrapped(a->x[i * a->n + d] + (a->count[d] == 1.0f ? step : step / a->count[d]));
        }
    }
}

/* The rows, caller indices and cell ids in sorted order, into the _tmp arrays (n a constant where
 * the caller specialises). */
static inline __attribute__((always_inline)) void reorder_rows(workspace *ws, size_t n) {
    for (size_t s = 0; s < ws->m; s++) {
        const uint32_t i = ws->perm[s];
        for (size_t d = 0; d < n; d++) ws->x_tmp[s * n + d] = ws->x[(size_t)i * n + d]; /* n is small: no memcpy call */
        ws->order_tmp[s] = ws->order[i];
        ws->cell_tmp[s] = ws->cell_of[i];
    }
}

/* Physically reorder the working points by the cell order sort_cells just computed; afterwards
 * the sorted order is the identity and the cell starts are unchanged. */
static void reorder_points(workspace *ws) {
    const size_t m = ws->m;
    if (ws->n == 2) reorder_rows(ws, 2); /* the common case, unrolled */
    else reorder_rows(ws, ws->n);
    for (size_t s = 0; s < m; s++) ws->perm[s] = (uint32_t)s;
    ws->lists.mask = 0; /* the lists hold working indices */
    float *xt = ws->x;
    ws->x = ws->x_tmp;
    ws->x_tmp = xt;
    uint32_t *t = ws->order;
    ws->order = ws->order_tmp;
    ws->order_tmp = t;
    t = ws->cell_of;
    ws->cell_of = ws->cell_tmp;
    ws->cell_tmp = t;
}

static void run_layer(const dpc_layer *L, const dpc_cpu_engine *e, workspace *ws) {
    const size_t m = ws->m, n = ws->n;
    int accumulated = 0; /* the reorder must come before any displacement is summed */
    memset(ws->delta, 0, m * n * sizeof(float));
    apply_pass a;
    memset(&a, 0, sizeof a);
    unsigned count[DPC_MAX_DIMS];
    dpc_plan_counts((unsigned)n, L->n_sub, L->masks, L->fixed, count);
    for (size_t d = 0; d < n; d++) a.count[d] = (float)count[d];
    for (unsigned t = 0; t < L->n_sub; t++) {
        dpc_sub_plan plan;
        dpc_plan_subspace(L->masks[t], L->fixed, L->radius[t], L->eps, L->bins, m, DPC_PLAN_F32, &plan);
        if (!plan.moves) continue; /* moves nothing (e.g. the grid's own axes) */
        sub_pass p;
        memset(&p, 0, sizeof p);
        p.engine = e;
        p.ws = ws;
        p.dim = plan.dim;
        p.job.k = plan.k;
        p.h = (float)plan.h;
        p.job.radius = (float)plan.r;
        p.job.cutoff = (float)plan.e;
        p.job.scale = (float)plan.scale;
        p.job.umax = (float)plan.umax;
        p.job.qmax = plan.qmax;
        p.job.w = L->kernels + (size_t)t * L->bins;
        p.job.dw = L->slopes + (size_t)t * L->bins;
        p.grid = plan.grid;
        p.G = plan.G;
        p.R = plan.R;
        p.local_cells = plan.grid && 2 * plan.R + 3 <= plan.G;
        p.near = e->prefilter && !plan.grid && plan.k >= PREFILTER_MIN_DIMS && m >= PREFILTER_MIN_POINTS &&
                 dpc_plan_in_reach(plan.k, L->radius[t]) <= (double)m / 16.0;
        sort_cells(&p, ws->x);
        if (p.grid && !accumulated) reorder_points(ws);
        fill_soa(&p);
        if (p.near && !fill_codes(&p)) p.near = 0; /* no memory for it: all pairs, the same bits */
        if (p.near && dpc_plan_in_reach(plan.k, (1.0 + DPC_LISTS_SKIN) * L->radius[t]) <= LIST_MAX_EXPECTED &&
            dpc_plan_in_reach(plan.k, (1.0 + DPC_LISTS_WIDE) * L->radius[t]) <= WIDE_MAX_EXPECTED &&
            fill_rows(&p)) /* no memory for the rows: the ranges, the same bits */
            p.lists = dpc_lists_update(&ws->lists, L->masks[t], &p.job, &p.near_job, e->near_points, e->near_list,
                                       m < PARALLEL_MIN_POINTS ? 1u : e->threads);
        parallel_for(e->threads, m, sub_pass_range, &p);
        accumulated = 1;
        if (ws->hook && atomic_load(&ws->stop) != DPC_OK) return;
    }
    a.x = ws->x;
    a.delta = ws->delta;
    a.order = ws->order;
    a.n = n;
    a.frozen = ws->frozen;
    a.all_ones = !ws->frozen;
    for (size_t d = 0; d < n; d++) a.all_ones &= a.count[d] == 1.0f;
    parallel_for(e->threads, m, apply_range, &a);
}

dpc_status dpc_cpu_filter(const dpc_cascade *c, const dpc_cpu_engine *e, size_t m, float *x) {
    return dpc_cpu_filter_hooked(c, e, m, x, NULL, NULL);
}

dpc_status dpc_cpu_filter_hooked(const dpc_cascade *c, const dpc_cpu_engine *e, size_t m, float *x, dpc_cpu_hook hook,
                                 void *ctx) {
    return dpc_cpu_filter_frozen(c, e, m, 0, x, hook, ctx);
}

dpc_status dpc_cpu_filter_frozen(const dpc_cascade *c, const dpc_cpu_engine *e, size_t m, size_t frozen, float *x,
                                 dpc_cpu_hook hook, void *ctx) {
    workspace ws;
    dpc_status st = workspace_init(&ws, m, c->dims, e->threads);
    if (st != DPC_OK) return st;
    ws.frozen = frozen;
    ws.hook = hook;
    ws.hook_ctx = ctx;
    atomic_init(&ws.stop, DPC_OK);
    const size_t n = c->dims;
    memcpy(ws.x, x, m * n * sizeof(float));
    for (size_t i = 0; i < m; i++) ws.order[i] = (uint32_t)i;
    for (uint32_t l = 0; l < c->n_layers; l++) {
        run_layer(&c->layers[l], e, &ws);
        if (hook && (atomic_load(&ws.stop) != DPC_OK || poll_stop(&ws, 1))) {
            st = (dpc_status)atomic_load(&ws.stop);
            workspace_free(&ws);
            return st;
        }
    }
    for (size_t i = 0; i < m; i++) memcpy(x + (size_t)ws.order[i] * n, ws.x + i * n, n * sizeof(float));
    workspace_free(&ws);
    return DPC_OK;
}

/* ---- whole sets: input points, then the cascade; batches fanned out over threads ------------ */

/* The output balance of a set's first m points (format §5.1), the points from first on moving
 * (0: all; a progressive level: its own points, §6); nothing when the model has no dpc.balance. */
static dpc_status balance_prefix(const dpc_cascade *c, float *x, size_t m, size_t first) {
    return dpc_balance_points(x, m, c->dims, dpc_balance_radius(c->balance, m, c->dims), first);
}

/* The progress hook asked between the relaxation's neighbour searches (inside a step: 0). */
typedef struct relax_hook_ctx {
    dpc_cpu_hook hook;
    void *ctx;
} relax_hook_ctx;

static dpc_status relax_hook(void *ctx) {
    const relax_hook_ctx *h = (const relax_hook_ctx *)ctx;
    return h->hook(h->ctx, 0) == DPC_OK ? DPC_OK : DPC_ERROR_CANCELLED;
}

static dpc_status generate_one(const dpc_cascade *c, dpc_input input, const dpc_cpu_engine *e, uint64_t seed, size_t m,
                               float *out, dpc_cpu_hook hook, void *ctx) {
    if (hook && hook(ctx, 0) != DPC_OK) return DPC_ERROR_CANCELLED;
    if (!c->progressive_base) {
        dpc_input_fill(c, input, seed, m, out);
        const dpc_status st = dpc_cpu_filter_hooked(c, e, m, out, hook, ctx);
        return st == DPC_OK ? balance_prefix(c, out, m, 0) : st;
    }
    /* Progressive: level j >= 1 adds its input points, of seed + j * DPC_STREAM_LEVEL, to the
     * n points so far and filters them past those, which stay where they are. */
    size_t n = dpc_first_level(m, c->progressive_base);
    dpc_input_fill(c, input, seed, n, out);
    dpc_status st = dpc_cpu_filter_hooked(c, e, n, out, hook, ctx);
    if (st == DPC_OK) st = balance_prefix(c, out, n, 0);
    for (uint64_t level = 1; st == DPC_OK && n < m; level++) {
        const size_t add = dpc_level_size(n, m);
        dpc_input_fill(c, input, seed + level * DPC_STREAM_LEVEL, add, out + n * c->dims);
        st = dpc_cpu_filter_frozen(c, e, n + add, n, out, hook, ctx);
        if (st == DPC_OK) /* the level's new points balance the whole prefix; the held ones stay */
            st = balance_prefix(c, out, n + add, n);
        n += add;
    }
    if (st == DPC_OK && c->relax) { /* every prefix relaxed at once (§6.1): the held points move too */
        relax_hook_ctx h = {hook, ctx};
        st = dpc_relax_points(out, m, c->progressive_base, c->relax, e->threads, hook ? relax_hook : NULL, &h);
    }
    /* last, each level's points in the order that fills the emptiest place first (§6): the
     * levels and the relaxation never see it */
    return st == DPC_OK ? dpc_order_level_points(out, m, c->dims, c->progressive_base) : st;
}

size_t dpc_cpu_filter_runs(const dpc_cascade *c, size_t m) {
    size_t runs = 1;
    if (c->progressive_base)
        for (size_t n = dpc_first_level(m, c->progressive_base); n < m; n += dpc_level_size(n, m)) runs++;
    return runs;
}

/* Batches with several threads: whole sets go to workers, set c always from seed + c, so the
 * bits are those of the serial loop. */
typedef struct batch_job {
    const dpc_cascade *cascade;
    dpc_input input;
    dpc_cpu_engine engine; /* single-threaded copy */
    uint64_t seed;
    size_t count, m, stride;
    unsigned workers;
    float *out;
    dpc_cpu_hook hook;
    void *ctx;
    dpc_status status[DPC_MAX_THREADS];
} batch_job;

static void batch_worker(void *arg, unsigned slot) {
    batch_job *j = (batch_job *)arg;
    dpc_status st = DPC_OK;
    for (size_t c = slot; c < j->count && st == DPC_OK; c += j->workers)
        st = generate_one(j->cascade, j->input, &j->engine, j->seed + c, j->m, j->out + c * j->stride, j->hook, j->ctx);
    j->status[slot] = st;
}

dpc_status dpc_cpu_generate(const dpc_cascade *c, dpc_input input, const dpc_cpu_engine *e, uint64_t seed, size_t count,
                            size_t m, float *out, dpc_cpu_hook hook, void *ctx) {
    const size_t stride = m * c->dims;
    unsigned threads = e->threads;
    if (threads > count) threads = (unsigned)count;
    if (threads <= 1 || m >= 65536) { /* big sets parallelise inside each set instead */
        for (size_t s = 0; s < count; s++) {
            const dpc_status st = generate_one(c, input, e, seed + s, m, out + s * stride, hook, ctx);
            if (st != DPC_OK)
                return st == DPC_ERROR_CANCELLED
                           ? dpc_fail(st, "cancelled by the progress callback (%zu of %zu sets done)", s, count)
                           : st;
        }
        return DPC_OK;
    }
    batch_job j = {c, input, *e, seed, count, m, stride, threads, out, hook, ctx, {DPC_OK}};
    j.engine.threads = 1;
    dpc_run_workers(threads, batch_worker, &j);
    for (unsigned t = 0; t < threads; t++)
        if (j.status[t] == DPC_ERROR_CANCELLED)
            return dpc_fail(DPC_ERROR_CANCELLED, "cancelled by the progress callback");
    for (unsigned t = 0; t < threads; t++)
        if (j.status[t] != DPC_OK)
            return dpc_fail(j.status[t], "generating a set of the batch failed (%s)", dpc_status_string(j.status[t]));
    return DPC_OK;
}
