/* Portable pair loop of the training kernels (the reference the vector paths are tested
 * against): candidates are filtered on d² without branches, the survivors get the full pair
 * computation in candidate order. */
#include <math.h>
#include <string.h>

#include "cpu/cpu_grid.h"
#include "cpu/cpu_layer_train_impl.h"

#if defined(__GNUC__)
#define ALWAYS_INLINE static inline __attribute__((always_inline))
#else
#define ALWAYS_INLINE static inline
#endif

#define LIST_CAP 128u /* candidates that passed the squared-distance test, per flush */

/* Toroidal difference of two coordinates in [0, 1): t − rint(t) (half-even; t ∈ (−1, 1)). The
 * subtraction of 1 is exact there. */
ALWAYS_INLINE double wrap_diff(double t) { return t > 0.5 ? t - 1.0 : t < -0.5 ? t + 1.0 : t; }

/* Point s's interactions with the listed candidates (all with d² in (e2_keep, r2_keep)), in list
 * order. Forward: a += Σ g(d) δ/d. Backward: a += Σ J(δ)(v_j − v_i), and the kernel gradient of
 * each pair goes to part. K and BACKWARD are constants where inlined. */
ALWAYS_INLINE void pair_sums(const dpc_train_pass *ps, size_t s, const uint32_t *list, unsigned len, double *a,
                             double *part, const unsigned K, const int BACKWARD) {
    const dpc_train_sub *sp = ps->sp;
    const size_t st = ps->p->stride;
    const double *P = ps->ws->P, *V = ps->ws->V, *w = sp->w;
    const double r = sp->r, e = sp->e, scale = sp->scale;
    const double umax = (double)(ps->p->b - 1);
    const unsigned qmax = ps->p->b - 2;
    double xi[DPC_MAX_DIMS], vi[DPC_MAX_DIMS];
    for (unsigned q = 0; q < K; q++) {
        xi[q] = P[q * st + s];
        vi[q] = BACKWARD ? V[q * st + s] : 0.0;
    }
    for (unsigned z = 0; z < len; z++) {
        const size_t j = list[z];
        double dl[DPC_MAX_DIMS], d2 = 0.0;
        for (unsigned q = 0; q < K; q++) { /* the same operations as the test: the same bits */
            dl[q] = wrap_diff(P[q * st + j] - xi[q]);
            d2 += dl[q] * dl[q];
        }
        const double d = sqrt(d2);
        if (!(d > e && d < r)) continue; /* the exact window of §3 (differs only at the rounding edge) */
        double u = d * scale;
        u = u > umax ? umax : u;
        unsigned qb = (unsigned)u;
        qb = qb > qmax ? qmax : qb;
        const double f = u - (double)qb;
        const double w0 = w[qb], dw = w[qb + 1] - w0;
        const double g = w0 + f * dw;
        const double inv_d = 1.0 / d;
        if (!BACKWARD) {
            const double c = g * inv_d;
            for (unsigned q = 0; q < K; q++) a[q] += c * dl[q];
            continue;
        }
        /* J(δ)(v_j − v_i) = g'·(n̂·Δv) n̂ + (g/d)(Δv − (n̂·Δv) n̂), n̂ = δ/d. */
        double dv[DPC_MAX_DIMS], ndv = 0.0, nvi = 0.0;
        for (unsigned q = 0; q < K; q++) {
            dl[q] *= inv_d;
            dv[q] = V[q * st + j] - vi[q];
            ndv += dl[q] * dv[q];
            nvi += dl[q] * vi[q];
        }
        const double gd = g * inv_d;
        const double radial = (dw * scale - gd) * ndv;
        for (unsigned q = 0; q < K; q++) a[q] += radial * dl[q] + gd * dv[q];
        /* dg/dw[q] = 1 − f, dg/dw[q+1] = f; the pair's output sensitivity is n̂·v_i. */
        part[qb] += (1.0 - f) * nvi;
        part[qb + 1] += f * nvi;
    }
}

/* The points of sorted positions [lo, hi). Candidates are first filtered on d² without branches
 * (append always, advance by the test: the window test is a coin flip for a branch predictor),
 * then the survivors get the full computation in candidate order. */
ALWAYS_INLINE void chunk_body(const dpc_train_pass *ps, size_t lo, size_t hi, double *part, const unsigned K,
                              const int BACKWARD) {
    const dpc_train_plan *p = ps->p;
    const dpc_train_sub *sp = ps->sp;
    dpc_train_ws *ws = ps->ws;
    const size_t m = p->m, n = p->n, st = p->stride;
    const double *P = ws->P;
    const double r2_keep = sp->r2_keep, e2_keep = sp->e2_keep;
    uint32_t ranges[2 * DPC_TRAIN_MAX_RANGES];
    uint32_t list[LIST_CAP + 1];
    unsigned nr = 1;
    ranges[0] = 0;
    ranges[1] = (uint32_t)m;
    uint32_t cur = UINT32_MAX;
    for (size_t s = lo; s < hi; s++) {
        /* K <= 8: grids have k <= 4 (dpc_plan_search); the bound lets the compiler see dpc_grid_ranges in bounds. */
        if (K <= 8 && sp->grid && ws->cell[s] != cur) { /* a cell's consecutive points share ranges */
            cur = ws->cell[s];
            nr = dpc_grid_ranges(sp->k, sp->G, sp->R, ws->cell_start, cur, ranges, NULL);
        }
        double xi[DPC_MAX_DIMS], a[DPC_MAX_DIMS];
        for (unsigned q = 0; q < K; q++) {
            xi[q] = P[q * st + s];
            a[q] = 0.0;
        }
        unsigned len = 0;
        for (unsigned z = 0; z < nr; z++) {
            for (uint32_t j = ranges[2 * z], je = ranges[2 * z + 1]; j < je; j++) {
                double d2 = 0.0;
                for (unsigned q = 0; q < K; q++) {
                    const double t = wrap_diff(P[q * st + j] - xi[q]);
                    d2 += t * t;
                }
                list[len] = j;
                len += (d2 < r2_keep) & (d2 > e2_keep);
                if (len == LIST_CAP) {
                    pair_sums(ps, s, list, len, a, part, K, BACKWARD);
                    len = 0;
                }
            }
        }
        pair_sums(ps, s, list, len, a, part, K, BACKWARD);
        double *out = ws->acc + (size_t)ws->perm[s] * n;
        for (unsigned q = 0; q < K; q++) out[sp->dim[q]] += BACKWARD ? a[q] : sp->h * a[q];
    }
}

void dpc_train_chunk_scalar(const dpc_train_pass *ps, size_t lo, size_t hi, double *part) {
    const unsigned k = ps->sp->k;
    /* Constant K: the per-pair loops unroll and stay in registers. */
#define DPC_BODY(B)                                     \
    switch (k) {                                        \
    case 1: chunk_body(ps, lo, hi, part, 1, B); break;  \
    case 2: chunk_body(ps, lo, hi, part, 2, B); break;  \
    case 3: chunk_body(ps, lo, hi, part, 3, B); break;  \
    case 4: chunk_body(ps, lo, hi, part, 4, B); break;  \
    default: chunk_body(ps, lo, hi, part, k, B); break; \
    }
    if (part) {
        DPC_BODY(1)
    } else {
        DPC_BODY(0)
    }
#undef DPC_BODY
}
