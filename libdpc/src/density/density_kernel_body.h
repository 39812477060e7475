/* The density kernel (density_kernel.h) on VW-lane vectors, written once for every ISA path:
 * per query, (1) the window test on VW candidates at a time, the candidates in the window packed
 * in order into dense streams (tx, ty, a); (2) the terms of VW packed candidates at a time, each
 * lane doing the float operations density_kernel.h lists, added to the 8 lane sums: packed
 * candidate r to lane r mod 8, in order (with 16 lanes, the low 8 products first, then the high
 * 8). The packing changes which register lane computes a term, not the term, nor the order of
 * the sums. The including file defines VW (8 or 16), vf, vi, VLOAD(p), VSQRT(x), optionally
 * VMIN(a, b), VIMIN(a, b) and VLIVE(iota, n), then table_regs, LOAD_TABLE(T, w, n), LOOKUP(T, b),
 * mask_t, WINDOW(v, lo, hi) (the lanes with lo < v < hi) and PACK3(m, tx, ty, a, px, py, pa)
 * (the lanes of m of the three vectors stored in order at px, py, pa, each with room for VW
 * floats; returns their count). */
#ifndef KERNEL
#error "define KERNEL and the primitives before including density_kernel_body.h"
#endif

#include <string.h>

#include "density/density_kernel.h"

typedef float vf8 __attribute__((vector_size(32)));

static inline vf vsplat(float a) { return (vf){0} + a; }
static inline vi visplat(int32_t a) { return (vi){0} + a; }
static inline vf vselect(vi mask, vf a, vf b) { return (vf)(((vi)a & mask) | ((vi)b & ~mask)); }
#ifndef VMIN /* lane-wise minimum of non-NaN floats / of ints; an ISA may give one instruction */
#define VMIN(a, b) vselect((a) < (b), (a), (b))
#define VIMIN(a, b) ((vi)vselect((a) < (b), (vf)(a), (vf)(b)))
#endif
#ifndef VLIVE /* the lanes whose index (iota) is below n */
#define VLIVE(iota, n) ((iota) < visplat(n))
#endif

/* s + (the products of lanes 0-7), then + (those of lanes 8-15). */
static inline vf8 add_lanes(vf8 s, vf v) {
#if VW == 16
    s = s + __builtin_shufflevector(v, v, 0, 1, 2, 3, 4, 5, 6, 7);
    return s + __builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15);
#else
    return s + v;
#endif
}

void KERNEL(const dpc_density_job *job, const float *cx, const float *cy, const float *ca, uint32_t n, const float *q,
            unsigned nq, float *acc, float *scratch) {
    const vf c2 = vsplat(job->c2), cut2 = vsplat(job->cut2), umax = vsplat(job->umax), umax2 = vsplat(job->umax2);
    const vf smin2 = vsplat(job->smin2);
    const vf two = vsplat(2.0f), zero = vsplat(0.0f), one = vsplat(1.0f);
#if VW == 16
    const vi iota = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
#else
    const vi iota = {0, 1, 2, 3, 4, 5, 6, 7};
#endif
    const vi qmax = visplat(job->qmax);
    float *dtx = scratch, *dty = scratch + DPC_DENSITY_DENSE, *da = scratch + 2 * DPC_DENSITY_DENSE;
    table_regs w_t, dw_t;
    LOAD_TABLE(&w_t, job->w, job->qmax + 2);
    LOAD_TABLE(&dw_t, job->dw, job->qmax + 2);
    for (unsigned p = 0; p < nq; p++) {
        const vf X = vsplat(q[4 * p]), Y = vsplat(q[4 * p + 1]), A = vsplat(q[4 * p + 2]);
        /* (1) the window, packed */
        uint32_t m = 0;
        for (uint32_t o = 0; o < n; o += VW) {
            const vf tx = VLOAD(cx + o) - X, ty = VLOAD(cy + o) - Y;
            const vf d2 = tx * tx + ty * ty;
            const vf a = VLOAD(ca + o) + A, s = a * c2, s2 = s * s;
            const mask_t in = WINDOW(d2 * vselect(s2 < smin2, smin2, s2), cut2, umax2);
            m += PACK3(in, tx, ty, a, dtx + m, dty + m, da + m);
        }
        /* (2) the terms. Lanes of the last vector beyond m compute a finite k from d = a = 1 and
         * add k * 0 (+0 or -0), which changes no sum. */
        vf8 sx, sy;
        memcpy(&sx, acc + 16 * p, sizeof sx);
        memcpy(&sy, acc + 16 * p + 8, sizeof sy);
        for (uint32_t r = 0; r < m; r += VW) {
            const vi live = VLIVE(iota, (int32_t)(m - r));
            const vf tx = vselect(live, VLOAD(dtx + r), zero), ty = vselect(live, VLOAD(dty + r), zero);
            const vf a = vselect(live, VLOAD(da + r), one);
            const vf d = VSQRT(vselect(live, tx * tx + ty * ty, one)); /* d2 again: the same operations */
            const vf u = (d * c2) * a;
            const vf uc = VMIN(u, umax);
            const vi b = VIMIN(__builtin_convertvector(uc, vi), qmax);
            const vf f = uc - __builtin_convertvector(b, vf);
            const vf g = LOOKUP(&w_t, b) + f * LOOKUP(&dw_t, b);
            const vf k = (two * g) / (a * d);
            sx = add_lanes(sx, k * tx);
            sy = add_lanes(sy, k * ty);
        }
        memcpy(acc + 16 * p, &sx, sizeof sx);
        memcpy(acc + 16 * p + 8, &sy, sizeof sy);
    }
}
