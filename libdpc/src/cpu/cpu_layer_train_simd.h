/* The vector pair loop of the training kernels, written once for cpu_layer_train_avx2.c and
 * cpu_layer_train_avx512.c. The including file defines W (doubles per vector), the types vd
 * (W doubles), vx (W int32), vm (a lane mask), vf (WF floats), the primitives used below, and
 * TRAIN_CHUNK_FN / TRAIN_SET_FN (the exported names).
 *
 * Per point: (1) filter the candidates on d² against bounds that keep every pair of the window
 * (filter_range), compacting the survivors' sorted positions into a list; (2) the pair math on
 * the list, W pairs at a time (gathered coordinates), with the exact window test e < d < r in
 * double. The list order is the candidate order, so every sum has a fixed order that depends on
 * the data only, never on threads. Kernel-gradient terms are added to part in list order, lane
 * by lane. */
#if !defined(TRAIN_CHUNK_FN) || !defined(TRAIN_SET_FN)
#error "define the ISA primitives and TRAIN_CHUNK_FN before including cpu_layer_train_simd.h"
#endif

#include <string.h>

#include "cpu/cpu_grid.h"
#include "cpu/cpu_layer_train_impl.h"

#define ALWAYS_INLINE static inline __attribute__((always_inline))

#define LIST_CAP 256u                      /* survivors per flush */
#define LIST_SIZE (LIST_CAP + 2u * WF + W) /* room for full-vector compress stores and the padding */

/* Toroidal difference, t − rint(t) for t = x_j − x_i ∈ (−1, 1). */
ALWAYS_INLINE vd wrap(vd t) { return V_SUB(t, V_ROUND(t)); }
ALWAYS_INLINE vf wrapf(vf t) { return F_SUB(t, F_ROUND(t)); }

/* Appends the candidates of [j, je) that may lie in the window to list[*len ..], until the list
 * holds LIST_CAP or more; returns where it stopped. WF candidates a step, on float32 copies of
 * the coordinates against the widened float bounds r2_f / e2_f: a superset of the window (twice
 * the lanes of double); the pair math decides exactly. Columns are readable WF − 1 entries past
 * m; lanes past je are masked. */
ALWAYS_INLINE uint32_t filter_range(const dpc_train_pass *ps, size_t s, uint32_t j, uint32_t je, uint32_t *list,
                                    unsigned *len_io, const unsigned K) {
    const dpc_train_sub *sp = ps->sp;
    const size_t st = ps->p->stride;
    const float *Pf = ps->ws->Pf;
    const vf r2 = F_SET1(sp->r2_f), e2 = F_SET1(sp->e2_f);
    vf xf[DPC_MAX_DIMS];
    for (unsigned q = 0; q < K; q++) xf[q] = F_SET1(Pf[q * st + s]);
    unsigned len = *len_io;
    for (; j < je && len < LIST_CAP; j += WF) {
        vf d2 = F_ZERO();
        for (unsigned q = 0; q < K; q++) {
            const vf t = wrapf(F_SUB(F_LOADU(Pf + q * st + j), xf[q]));
            d2 = F_FMA(t, t, d2);
        }
        unsigned bits = F_BITS(d2, r2, e2);
        if (je - j < WF) bits &= (1u << (je - j)) - 1u;
        len = COMPRESS_APPEND_F(list, len, j, bits);
    }
    *len_io = len;
    return j < je ? j : je;
}

/* Pair math for list[0, len) of point s; acc[q] are the lane sums. SYM = 0: every candidate is
 * a neighbour of s only (the chunked pass, see the file comment). SYM = 1: the whole-set pass
 * over unordered pairs (below): each term is also subtracted from its partner in A. The two
 * differ only where SYM is tested; each keeps its own order of operations. */
ALWAYS_INLINE void pair_pass(const dpc_train_pass *ps, size_t s, uint32_t *list, unsigned len, vd *acc, double *part,
                             const unsigned K, const int BACKWARD, const int SYM) {
    const dpc_train_sub *sp = ps->sp;
    const size_t st = ps->p->stride;
    const double *P = ps->ws->P, *V = ps->ws->V, *w = sp->w;
    double *A = ps->ws->A;
    const vd r = V_SET1(sp->r), e = V_SET1(sp->e), scale = V_SET1(sp->scale), one = V_SET1(1.0);
    const vd umax = V_SET1((double)(ps->p->b - 1)), qmax = V_SET1((double)(ps->p->b - 2));
    vd xi[DPC_MAX_DIMS], vi[DPC_MAX_DIMS];
    for (unsigned q = 0; q < K; q++) {
        xi[q] = V_SET1(P[q * st + s]);
        vi[q] = BACKWARD ? V_SET1(V[q * st + s]) : V_ZERO();
    }
    /* Padding lanes are the point itself: d = 0 fails d > e >= 0, never a pair. */
    for (unsigned z = 0; z < W; z++) list[len + z] = (uint32_t)s;
    for (unsigned z = 0; z < len; z += W) {
        const vx idx = I_LOADU(list + z);
        vd dl[DPC_MAX_DIMS];
        vd d2 = V_ZERO();
        for (unsigned q = 0; q < K; q++) {
            dl[q] = wrap(V_SUB(V_GATHER(P + q * st, idx), xi[q]));
            d2 = V_FMA(dl[q], dl[q], d2);
        }
        vd d = V_SQRT(d2);
        const vm in = M_AND(V_GT(d, e), V_LT(d, r));
        const unsigned bits = M_BITS(in);
        if (!bits) continue;
        d = V_SEL(in, d, one); /* finite 1/d and an in-range bin in the dead lanes */
        const vd u = V_MIN(V_MUL(d, scale), umax);
        const vd qf = V_MIN(V_TRUNC(u), qmax);
        const vd f = V_SUB(u, qf);
        const vx qb = V_CVTT(qf);
        /* SYM masks the terms instead of the kernel values: dead lanes hold 0 in tv */
        const vd w0 = SYM ? V_GATHER(w, qb) : V_SEL(in, V_GATHER(w, qb), V_ZERO());
        const vd dw = SYM ? V_SUB(V_GATHER(w + 1, qb), w0) : V_SEL(in, V_SUB(V_GATHER(w + 1, qb), w0), V_ZERO());
        const vd g = V_FMA(f, dw, w0);
        const vd inv_d = V_DIV(one, d);
        vd tv[DPC_MAX_DIMS];
        if (!BACKWARD) {
            if (!SYM) {
                const vd c = V_MUL(g, inv_d);
                for (unsigned q = 0; q < K; q++) acc[q] = V_FMA(c, dl[q], acc[q]);
                continue;
            }
            const vd c = V_SEL(in, V_MUL(g, inv_d), V_ZERO());
            for (unsigned q = 0; q < K; q++) tv[q] = V_MUL(c, dl[q]);
        } else {
            /* J(δ)(v_j − v_i) = g'·(n̂·Δv) n̂ + (g/d)(Δv − (n̂·Δv) n̂), n̂ = δ/d. */
            vd dv[DPC_MAX_DIMS];
            vd ndv = V_ZERO(), nvi = V_ZERO();
            for (unsigned q = 0; q < K; q++) {
                dl[q] = V_MUL(dl[q], inv_d);
                dv[q] = V_SUB(V_GATHER(V + q * st, idx), vi[q]);
                ndv = V_FMA(dl[q], dv[q], ndv);
                if (!SYM) nvi = V_FMA(dl[q], vi[q], nvi);
            }
            /* dg/dw[q] = 1 − f, dg/dw[q+1] = f; the pair's output sensitivity is n̂·v_i, and
             * with SYM the partner's too: n̂·(v_i − v_j) = −n̂·Δv. */
            vd lo, hi;
            if (!SYM) {
                const vd gd = V_MUL(g, inv_d);
                const vd radial = V_MUL(V_SUB(V_MUL(dw, scale), gd), ndv);
                for (unsigned q = 0; q < K; q++) acc[q] = V_FMA(radial, dl[q], V_FMA(gd, dv[q], acc[q]));
                lo = V_MUL(V_SUB(one, f), nvi);
                hi = V_MUL(f, nvi);
            } else {
                const vd gd = V_SEL(in, V_MUL(g, inv_d), V_ZERO());
                const vd radial = V_SEL(in, V_MUL(V_SUB(V_MUL(dw, scale), gd), ndv), V_ZERO());
                for (unsigned q = 0; q < K; q++) tv[q] = V_FMA(radial, dl[q], V_MUL(gd, dv[q]));
                lo = V_MUL(V_SUB(f, one), ndv);
                hi = V_MUL(f, V_SUB(V_ZERO(), ndv));
            }
            double lo_t[W], hi_t[W];
            int32_t qb_t[W];
            V_STORE(lo_t, lo);
            V_STORE(hi_t, hi);
            I_STORE(qb_t, qb);
            for (unsigned b = bits; b; b &= b - 1) {
                const unsigned l = (unsigned)__builtin_ctz(b);
                part[qb_t[l]] += lo_t[l];
                part[qb_t[l] + 1] += hi_t[l];
            }
            if (!SYM) continue;
        }
        for (unsigned q = 0; q < K; q++) acc[q] = V_ADD(acc[q], tv[q]);
        SCATTER_SUB(A, st, idx, in, bits, tv, K);
    }
}

/* The walk over candidate partners: the grid's candidate ranges of the current cell (all of
 * [0, m) without a grid) and the filtered list handed to pair_pass. */
typedef struct pair_walk {
    uint32_t ranges[2 * DPC_TRAIN_MAX_RANGES];
    uint32_t list[LIST_SIZE];
    unsigned nr;
    uint32_t cur;
} pair_walk;

ALWAYS_INLINE void pair_walk_init(pair_walk *wk, size_t m) {
    wk->nr = 1;
    wk->ranges[0] = 0;
    wk->ranges[1] = (uint32_t)m;
    wk->cur = UINT32_MAX;
}

/* Every pair of sorted point s (SYM: with partners above s only, so each unordered pair once);
 * acc gets s's lane sums. */
ALWAYS_INLINE void point_pairs(const dpc_train_pass *ps, pair_walk *wk, size_t s, vd *acc, double *part,
                               const unsigned K, const int BACKWARD, const int SYM) {
    const dpc_train_sub *sp = ps->sp;
    dpc_train_ws *ws = ps->ws;
    /* K <= 8: grids have k <= 4 (dpc_plan_search); the bound lets the compiler see dpc_grid_ranges in bounds. */
    if (K <= 8 && sp->grid && ws->cell[s] != wk->cur) { /* a cell's consecutive points share ranges */
        wk->cur = ws->cell[s];
        wk->nr = dpc_grid_ranges(sp->k, sp->G, sp->R, ws->cell_start, wk->cur, wk->ranges, NULL);
    }
    for (unsigned q = 0; q < K; q++) acc[q] = V_ZERO();
    unsigned len = 0;
    for (unsigned z = 0; z < wk->nr; z++) {
        const uint32_t je = wk->ranges[2 * z + 1];
        uint32_t j = wk->ranges[2 * z];
        if (SYM && j <= s) j = (uint32_t)s + 1;
        while (j < je) {
            j = filter_range(ps, s, j, je, wk->list, &len, K);
            if (len >= LIST_CAP) {
                pair_pass(ps, s, wk->list, len, acc, part, K, BACKWARD, SYM);
                len = 0;
            }
        }
    }
    if (len) pair_pass(ps, s, wk->list, len, acc, part, K, BACKWARD, SYM);
}

ALWAYS_INLINE void chunk_body(const dpc_train_pass *ps, size_t lo, size_t hi, double *part, const unsigned K,
                              const int BACKWARD) {
    const dpc_train_sub *sp = ps->sp;
    dpc_train_ws *ws = ps->ws;
    const size_t n = ps->p->n;
    pair_walk wk;
    pair_walk_init(&wk, ps->p->m);
    for (size_t s = lo; s < hi; s++) {
        vd acc[DPC_MAX_DIMS];
        point_pairs(ps, &wk, s, acc, part, K, BACKWARD, 0);
        double *out = ws->acc + (size_t)ws->perm[s] * n;
        for (unsigned q = 0; q < K; q++) {
            const double a = V_HSUM(acc[q]);
            out[sp->dim[q]] += BACKWARD ? a : sp->h * a;
        }
    }
}

/* ---- whole-set pass over unordered pairs ----------------------------------------------------
 * Every pair term is odd in δ (forward g(d) δ/d; backward J(δ)(v_j − v_i) with J even), and the
 * kernel-gradient terms of (i, j) and (j, i) share d: (1 − f)·n̂·(v_i − v_j) together. So each
 * unordered pair is found once, from its lower sorted position s (candidates j > s only), and
 * its term is added to s (lane sums, as in pair_pass) and subtracted from j (one term at a time,
 * in ascending s). A point's sum is its terms from partners below it, in ascending order, plus
 * the lane sums of those above: a fixed order, but one that needs the whole set on one worker. */

ALWAYS_INLINE void set_body(const dpc_train_pass *ps, double *part, const unsigned K, const int BACKWARD) {
    const dpc_train_plan *p = ps->p;
    const dpc_train_sub *sp = ps->sp;
    dpc_train_ws *ws = ps->ws;
    const size_t m = p->m, n = p->n, st = p->stride;
    double *A = ws->A;
    pair_walk wk;
    pair_walk_init(&wk, m);
    for (unsigned q = 0; q < K; q++) memset(A + q * st, 0, m * sizeof(double));
    for (size_t s = 0; s < m; s++) {
        vd acc[DPC_MAX_DIMS];
        point_pairs(ps, &wk, s, acc, part, K, BACKWARD, 1);
        /* The terms of partners below s, in ascending order, then the lane sums of those above. */
        for (unsigned q = 0; q < K; q++) A[q * st + s] += V_HSUM(acc[q]);
    }
    for (size_t s = 0; s < m; s++) {
        double *out = ws->acc + (size_t)ws->perm[s] * n;
        for (unsigned q = 0; q < K; q++) out[sp->dim[q]] += BACKWARD ? A[q * st + s] : sp->h * A[q * st + s];
    }
}

void TRAIN_SET_FN(const dpc_train_pass *ps, double *part) {
    const unsigned k = ps->sp->k;
#define DPC_BODY(B)                            \
    switch (k) {                               \
    case 1: set_body(ps, part, 1, B); break;   \
    case 2: set_body(ps, part, 2, B); break;   \
    case 3: set_body(ps, part, 3, B); break;   \
    case 4: set_body(ps, part, 4, B); break;   \
    case 5: set_body(ps, part, 5, B); break;   \
    case 6: set_body(ps, part, 6, B); break;   \
    case 10: set_body(ps, part, 10, B); break; \
    default: set_body(ps, part, k, B); break;  \
    }
    if (part) {
        DPC_BODY(1)
    } else {
        DPC_BODY(0)
    }
#undef DPC_BODY
}

void TRAIN_CHUNK_FN(const dpc_train_pass *ps, size_t lo, size_t hi, double *part) {
    const unsigned k = ps->sp->k;
    /* Constant K for the common subspace sizes: per-dimension vectors stay in registers. */
#define DPC_BODY(B)                                      \
    switch (k) {                                         \
    case 1: chunk_body(ps, lo, hi, part, 1, B); break;   \
    case 2: chunk_body(ps, lo, hi, part, 2, B); break;   \
    case 3: chunk_body(ps, lo, hi, part, 3, B); break;   \
    case 4: chunk_body(ps, lo, hi, part, 4, B); break;   \
    case 5: chunk_body(ps, lo, hi, part, 5, B); break;   \
    case 6: chunk_body(ps, lo, hi, part, 6, B); break;   \
    case 10: chunk_body(ps, lo, hi, part, 10, B); break; \
    default: chunk_body(ps, lo, hi, part, k, B); break;  \
    }
    if (part) {
        DPC_BODY(1)
    } else {
        DPC_BODY(0)
    }
#undef DPC_BODY
}
