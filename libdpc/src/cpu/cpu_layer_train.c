/* Training kernels: one PointFilter layer (docs/model-format.md §3) in float64, forward and
 * backward (paper Appendix A, adapted to the scale-aware radius and the normalised subspace sum;
 * the contract: dpc/dpc_layer.h).
 *
 * Backward, per set, with G = dL/dy (m x n). The wrap y - floor(y) is treated as the identity.
 * For subspace t with dimension set D_t and an ordered pair (i, j) with e_t < d < r_t:
 *   delta = x_j (-) x_i over D_t (toroidal), d = |delta|, nh = delta / d,
 *   u = d (b-1) / r_t, q = min(floor(u), b-2), f = u - q, g = w[q] + f (w[q+1] - w[q]),
 *   g' = (w[q+1] - w[q]) (b-1) / r_t, and v_i[k] = h_t G_i[k] / c_k for moving k in D_t, 0 for
 *   fixed k. Then
 *   dL/dx_i   = G_i + sum_t sum_j J(delta_ij) (v_j - v_i),
 *               J(delta) = g' nh nh^T + (g / d) (I - nh nh^T)    (the Jacobian of g(d) delta/d)
 *   dL/dw_t[q]   += (1 - f) (nh . v_i),   dL/dw_t[q+1] += f (nh . v_i)
 * summed over every ordered pair of every set. J is even in delta, so each point only gathers
 * from its own neighbours.
 *
 * Work runs per set and per subspace: the set's points are counting-sorted into a toroidal cell
 * grid over the subspace's dims (or kept in order for all pairs), the subspace's coordinates
 * (and, backward, the scaled output gradients v) are packed in sorted order, and every point
 * GATHERS from its candidate neighbours. The pair Jacobian is even in δ, so the backward needs no
 * scatter: each point's sums are written by exactly one worker, in a fixed neighbour order.
 *
 * The one sum across points, the kernel gradient, is accumulated per chunk of consecutive sorted
 * points; chunk sums are added in chunk order and set sums in set order. Chunk boundaries depend
 * on m and b only, so every output is bit-identical for any thread count. Memory is O(m·n + cells)
 * per worker, never O(m²).
 *
 * The pair loop (filter candidates on d², then the pair math on the survivors) is per ISA:
 * cpu_layer_train_scalar.c, _avx2.c, _avx512.c, the ISA given by the caller (AUTO: resolved like
 * the inference engine's, DPC_ISA, else cpuid). Vector paths sum in lanes, so they differ from the scalar path by rounding; each path
 * on its own is deterministic and thread-count independent. Sets below SET_PARALLEL_BELOW points
 * always run whole on one worker, and there the vector paths take each unordered pair once and
 * scatter its (odd) term to the upper point (set_fn, cpu_layer_train_simd.h): still a fixed
 * order, since no other worker touches the set. */
#include "cpu/cpu_layer_train_impl.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/error.h"
#include "common/threads.h"
#include "cpu/cpu_cascade.h"
#include "cpu/cpu_grid.h"
#include "model/plan.h"

#define MAX_THREADS DPC_MAX_THREADS
#define SET_PARALLEL_BELOW 8192u /* smaller sets go to threads whole: no spawn per subspace */
#define MIN_CHUNK 256u

/* ---- plan: everything that depends on the layer and m only -------------------------------- */

typedef dpc_train_sub sub_plan;
typedef dpc_train_plan plan;
typedef dpc_train_ws wspace;
typedef dpc_train_pass pass;

/* The pair loop of isa (AUTO: the inference engine's choice, DPC_ISA, else the best of cpuid),
 * with the same errors for a bad DPC_ISA or a path this build or CPU lacks. */
static dpc_status pick_isa(plan *p, dpc_isa isa) {
    const dpc_status st = dpc_cpu_resolve_isa(isa, &isa);
    if (st != DPC_OK) return st;
    p->chunk_fn = dpc_train_chunk_scalar;
    p->set_fn = NULL;
    switch (isa) {
#if defined(DPC_HAVE_AVX2)
    case DPC_ISA_AVX2: p->chunk_fn = dpc_train_chunk_avx2, p->set_fn = dpc_train_set_avx2; break;
    case DPC_ISA_AVX512: p->chunk_fn = dpc_train_chunk_avx512, p->set_fn = dpc_train_set_avx512; break;
#endif
    default: break;
    }
    return DPC_OK;
}

static dpc_status plan_init(plan *p, const dpc_train_layer *L, size_t m, dpc_isa isa) {
    memset(p, 0, sizeof *p);
    const dpc_status st = pick_isa(p, isa);
    if (st != DPC_OK) return st;
    /* Unordered pairs need a whole set per worker: only sets that always run in set mode use
     * them, whatever the thread count (run() picks set mode for every m below this). */
    if (m >= SET_PARALLEL_BELOW) p->set_fn = NULL;
    p->m = m;
    p->stride = (m + DPC_TRAIN_PAD + 15) & ~(size_t)15;
    p->n = L->n;
    p->s = L->s;
    p->b = L->b;
    p->sub = (sub_plan *)calloc(L->s, sizeof *p->sub);
    if (!p->sub) return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for a layer plan");
    unsigned count[DPC_MAX_DIMS];
    dpc_plan_counts(L->n, L->s, L->masks, L->fixed, count);
    for (unsigned d = 0; d < L->n; d++) p->count[d] = (double)count[d];
    p->max_cells = 1;
    for (unsigned t = 0; t < L->s; t++) {
        sub_plan *sp = &p->sub[t];
        dpc_sub_plan sub;
        dpc_plan_subspace(L->masks[t], L->fixed, L->radius[t], L->eps, L->b, m, DPC_PLAN_F64, &sub);
        sp->k = sub.k;
        memcpy(sp->dim, sub.dim, sizeof sp->dim);
        sp->moves = sub.moves;
        sp->h = sub.h;
        sp->r = sub.r;
        sp->e = sub.e;
        sp->scale = sub.scale;
        for (unsigned q = 0; q < sp->k; q++) {
            const double c = p->count[sp->dim[q]];
            sp->vscale[q] = c > 0.0 ? sp->h / c : 0.0;
        }
        /* Bounds on the exact r² and e² (rounded sqrt is monotone), so a test on d² drops only
         * pairs the exact test on d would drop too. */
        sp->r2_keep = sp->r * sp->r * (1.0 + 0x1p-50);
        sp->e2_keep = sp->e * sp->e * (1.0 - 0x1p-50);
        /* Float32 filter: coordinates rounded to float (error <= 2^-25 each) and their rounded
         * difference (<= 2^-25 more) put each component within 2^-23 of the exact one, so the
         * float distance is within sqrt(k) 2^-23 of d, plus a relative error below
         * (k + 2) 2^-24 from the float sum of squares. Twice both margins keep every pair with
         * e < d < r; the exact test in double follows. e_lo <= 0: keep d² = 0 too (points that
         * differ below float resolution). */
        {
            const double tol = sqrt((double)sp->k) * 0x1p-22, rel = (double)(sp->k + 2) * 0x1p-23;
            const double hi = (sp->r + tol) * (1.0 + rel), lo = (sp->e - tol) * (1.0 - rel);
            sp->r2_f = (float)(hi * hi);
            if ((double)sp->r2_f < hi * hi) sp->r2_f = nextafterf(sp->r2_f, INFINITY);
            sp->e2_f = -1.0f;
            if (lo > 0.0) {
                sp->e2_f = (float)(lo * lo);
                if ((double)sp->e2_f > lo * lo) sp->e2_f = nextafterf(sp->e2_f, 0.0f);
            }
        }
        sp->w = L->w + (size_t)t * L->b;
        if (!sp->moves) continue;
        if (sp->k > p->kmax) p->kmax = sp->k;
        sp->grid = sub.grid;
        if (sp->grid) {
            sp->G = sub.G;
            sp->R = sub.R;
            size_t cells = 1;
            for (unsigned q = 0; q < sp->k; q++) cells *= sp->G;
            if (cells > p->max_cells) p->max_cells = cells;
        }
    }
    /* Chunks: at least MIN_CHUNK points; few enough that n_chunks · b partial sums stay small. */
    size_t max_chunks = ((size_t)1 << 22) / L->b;
    if (max_chunks < 64) max_chunks = 64;
    if (max_chunks > 4096) max_chunks = 4096;
    p->chunk = (m + max_chunks - 1) / max_chunks;
    if (p->chunk < MIN_CHUNK) p->chunk = MIN_CHUNK;
    p->n_chunks = (m + p->chunk - 1) / p->chunk;
    return DPC_OK;
}

/* ---- per-worker workspace ------------------------------------------------------------------ */

static void wspace_free(wspace *w) {
    free(w->P);
    free(w->V);
    free(w->A);
    free(w->Pf);
    free(w->acc);
    free(w->perm);
    free(w->cell);
    free(w->cell_start);
    free(w->gk);
    free(w->part);
    memset(w, 0, sizeof *w);
}

static dpc_status wspace_init(wspace *w, const plan *p, int backward, size_t parts) {
    memset(w, 0, sizeof *w);
    const size_t m = p->m, kmax = p->kmax ? p->kmax : 1;
    /* calloc: the padding past m in each column is read (and masked) by the vector paths. */
    w->P = (double *)calloc(p->stride * kmax, sizeof(double));
    w->acc = (double *)malloc(m * p->n * sizeof(double));
    w->perm = (uint32_t *)malloc(m * sizeof(uint32_t));
    w->cell = (uint32_t *)malloc(m * sizeof(uint32_t));
    w->cell_start = (uint32_t *)malloc((p->max_cells + 1) * sizeof(uint32_t));
    int ok = w->P && w->acc && w->perm && w->cell && w->cell_start;
    if (p->set_fn) {
        w->A = (double *)malloc(p->stride * kmax * sizeof(double));
        ok = ok && w->A;
    }
    if (p->chunk_fn != dpc_train_chunk_scalar) { /* calloc: the padding is read (and masked) */
        w->Pf = (float *)calloc(p->stride * kmax, sizeof(float));
        ok = ok && w->Pf;
    }
    if (backward) {
        w->V = (double *)calloc(p->stride * kmax, sizeof(double));
        w->gk = (double *)malloc((size_t)p->s * p->b * sizeof(double));
        w->part = (double *)malloc(parts * p->b * sizeof(double));
        ok = ok && w->V && w->gk && w->part;
    }
    if (!ok) {
        wspace_free(w);
        return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for a %zu x %zu training workspace", m, p->n);
    }
    return DPC_OK;
}

/* ---- one subspace of one set ---------------------------------------------------------------- */

/* Sort the set's points by cell (stable counting sort) and pack the subspace's coordinates and,
 * backward, v = h_t · G / c_k, column by column in sorted order. */
static void prepare_pass(const pass *ps, const double *x) {
    const sub_plan *sp = ps->sp;
    wspace *ws = ps->ws;
    const size_t m = ps->p->m, n = ps->p->n, st = ps->p->stride;
    const unsigned k = sp->k;
    if (!sp->grid) {
        for (size_t i = 0; i < m; i++) ws->perm[i] = (uint32_t)i;
    } else {
        const uint32_t G = sp->G;
        size_t cells = 1;
        for (unsigned q = 0; q < k; q++) cells *= G;
        for (size_t i = 0; i < m; i++) {
            uint32_t id = 0;
            for (unsigned q = k; q-- > 0;) { /* axis 0 varies fastest */
                uint32_t c = (uint32_t)(x[i * n + sp->dim[q]] * (double)G);
                id = id * G + (c < G ? c : G - 1);
            }
            ws->cell[i] = id;
        }
        dpc_grid_sort(ws->cell, m, cells, ws->cell_start, ws->perm);
        const uint32_t *start = ws->cell_start;
        for (size_t c = 0; c < cells; c++) /* cell of each sorted position */
            for (uint32_t s = start[c]; s < start[c + 1]; s++) ws->cell[s] = (uint32_t)c;
    }
    for (size_t s = 0; s < m; s++) {
        const size_t i = ws->perm[s];
        for (unsigned q = 0; q < k; q++) ws->P[q * st + s] = x[i * n + sp->dim[q]];
        if (ws->Pf)
            for (unsigned q = 0; q < k; q++) ws->Pf[q * st + s] = (float)x[i * n + sp->dim[q]];
        if (ps->gy)
            for (unsigned q = 0; q < k; q++) ws->V[q * st + s] = sp->vscale[q] * ps->gy[i * n + sp->dim[q]];
    }
}

/* Chunk j of the current pass; part (b doubles, backward only) receives its kernel gradient. */
static void run_chunk(const pass *ps, size_t j, double *part) {
    const size_t lo = j * ps->p->chunk;
    const size_t hi = lo + ps->p->chunk < ps->p->m ? lo + ps->p->chunk : ps->p->m;
    if (part) memset(part, 0, ps->p->b * sizeof(double));
    ps->p->chunk_fn(ps, lo, hi, part);
}

/* ---- whole sets ----------------------------------------------------------------------------- */

typedef struct job {
    const plan *p;
    const double *x, *gy;
    double *y, *gx;
    size_t count;
    unsigned T;     /* workers */
    wspace *ws;     /* one per worker (set mode) or one (chunk mode) */
    size_t first;   /* set mode: first set of the current wave */
    const pass *ps; /* chunk mode: the current pass */
} job;

/* Per-point results of one set, from the sums in ws->acc. */
static void finish_set(const plan *p, const wspace *ws, const double *x, const double *gy, double *y, double *gx) {
    const size_t m = p->m, n = p->n;
    if (gy) {
        for (size_t i = 0; i < m * n; i++) gx[i] = gy[i] + ws->acc[i]; /* the residual path */
        return;
    }
    for (size_t i = 0; i < m; i++)
        for (size_t d = 0; d < n; d++) {
            const double xv = x[i * n + d];
            if (p->count[d] == 0.0) {
                y[i * n + d] = xv;
                continue;
            }
            double v = xv + ws->acc[i * n + d] / p->count[d];
            v -= floor(v);
            y[i * n + d] = (v >= 0.0 && v < 1.0) ? v : 0.0; /* -tiny + 1 rounds to 1; inf/NaN too */
        }
}

static void add_into(double *dst, const double *src, size_t len) {
    for (size_t i = 0; i < len; i++) dst[i] += src[i];
}

/* One set on one worker: subspaces in order, chunks in order. */
static void run_set_serial(const plan *p, wspace *ws, const double *x, const double *gy) {
    memset(ws->acc, 0, p->m * p->n * sizeof(double));
    if (gy) memset(ws->gk, 0, (size_t)p->s * p->b * sizeof(double));
    for (unsigned t = 0; t < p->s; t++) {
        if (!p->sub[t].moves) continue;
        pass ps = {p, &p->sub[t], ws, gy};
        prepare_pass(&ps, x);
        if (p->set_fn) {
            if (gy) memset(ws->part, 0, p->b * sizeof(double));
            p->set_fn(&ps, gy ? ws->part : NULL);
            if (gy) add_into(ws->gk + (size_t)t * p->b, ws->part, p->b);
            continue;
        }
        for (size_t j = 0; j < p->n_chunks; j++) {
            run_chunk(&ps, j, gy ? ws->part : NULL);
            if (gy) add_into(ws->gk + (size_t)t * p->b, ws->part, p->b);
        }
    }
}

static void set_worker(void *ctx, unsigned slot) {
    const job *jb = (const job *)ctx;
    const size_t c = jb->first + slot;
    if (c >= jb->count) return;
    const size_t mn = jb->p->m * jb->p->n;
    const double *gy = jb->gy ? jb->gy + c * mn : NULL;
    run_set_serial(jb->p, &jb->ws[slot], jb->x + c * mn, gy);
    finish_set(jb->p, &jb->ws[slot], jb->x + c * mn, gy, jb->y ? jb->y + c * mn : NULL,
               jb->gx ? jb->gx + c * mn : NULL);
}

static void chunk_worker(void *ctx, unsigned slot) {
    const job *jb = (const job *)ctx;
    const pass *ps = jb->ps;
    for (size_t j = slot; j < jb->p->n_chunks; j += jb->T)
        run_chunk(ps, j, ps->gy ? ps->ws->part + j * jb->p->b : NULL);
}

static dpc_status run(const dpc_train_layer *L, size_t count, size_t m, const double *x, const double *gy, double *y,
                      double *gx, double *gw, unsigned threads, dpc_isa isa) {
    plan p;
    dpc_status st = plan_init(&p, L, m, isa);
    if (st != DPC_OK) return st;
    const int backward = gy != NULL;
    const size_t mn = m * p.n, sb = (size_t)p.s * p.b;
    unsigned T = dpc_threads_resolve(threads);
    /* Set mode: whole sets per worker (small sets, or enough of them). Chunk mode: the chunks of
     * one set across workers. Both compute every value by the same operations in the same order. */
    const int set_mode = T <= 1 || count >= T || m < SET_PARALLEL_BELOW;
    unsigned n_ws = 1;
    if (set_mode) {
        if (T > count) T = (unsigned)count;
        n_ws = T;
    } else if ((size_t)T > p.n_chunks) {
        T = (unsigned)p.n_chunks;
    }
    double *total = NULL;
    wspace ws[MAX_THREADS];
    memset(ws, 0, sizeof ws);
    if (backward) {
        total = (double *)calloc(sb, sizeof(double));
        if (!total) st = dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for the kernel gradient");
    }
    for (unsigned t = 0; t < n_ws && st == DPC_OK; t++)
        st = wspace_init(&ws[t], &p, backward, set_mode ? 1 : p.n_chunks);
    if (st == DPC_OK) {
        job jb = {&p, x, gy, y, gx, count, T, ws, 0, NULL};
        if (set_mode) {
            for (size_t c0 = 0; c0 < count; c0 += T) { /* waves of T sets; sums in set order */
                jb.first = c0;
                dpc_run_workers(T, set_worker, &jb);
                if (backward)
                    for (size_t c = c0; c < count && c < c0 + T; c++) add_into(total, ws[c - c0].gk, sb);
            }
        } else {
            for (size_t c = 0; c < count; c++) {
                const double *xc = x + c * mn, *gyc = backward ? gy + c * mn : NULL;
                memset(ws[0].acc, 0, mn * sizeof(double));
                if (backward) memset(ws[0].gk, 0, sb * sizeof(double));
                for (unsigned t = 0; t < p.s; t++) {
                    if (!p.sub[t].moves) continue;
                    pass ps = {&p, &p.sub[t], &ws[0], gyc};
                    prepare_pass(&ps, xc);
                    jb.ps = &ps;
                    dpc_run_workers(T, chunk_worker, &jb);
                    if (backward)
                        for (size_t j = 0; j < p.n_chunks; j++)
                            add_into(ws[0].gk + (size_t)t * p.b, ws[0].part + j * p.b, p.b);
                }
                finish_set(&p, &ws[0], xc, gyc, backward ? NULL : y + c * mn, backward ? gx + c * mn : NULL);
                if (backward) add_into(total, ws[0].gk, sb);
            }
        }
        if (backward) memcpy(gw, total, sb * sizeof(double)); /* last: gw may not alias, but be safe */
    }
    for (unsigned t = 0; t < n_ws; t++) wspace_free(&ws[t]);
    free(total);
    free(p.sub);
    return st;
}

dpc_status dpc_train_forward(const dpc_train_layer *L, size_t count, size_t m, const double *x, double *y,
                             unsigned threads, dpc_isa isa) {
    return run(L, count, m, x, NULL, y, NULL, NULL, threads, isa);
}

dpc_status dpc_train_backward(const dpc_train_layer *L, size_t count, size_t m, const double *x, const double *gy,
                              double *grad_x, double *grad_w, unsigned threads, dpc_isa isa) {
    return run(L, count, m, x, gy, NULL, grad_x, grad_w, threads, isa);
}
