/* The density kernel (density_kernel.h) on VW-lane vectors, written once for every ISA path:
 * per query, (1) the window test on VW candidates at a time, the candidates in the window packed
 * in order into dense streams (tx, ty, 1/h_j); (2) the terms of VW packed candidates at a time, each
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
#include "density/walls.h"

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

/* The window's value d2 max(s s, smin2), s = a c2 (density_kernel.h): in the window when in
 * (cut2, umax2). */
static inline vf window_value(vf d2, vf a, vf c2, vf smin2) {
    const vf s = a * c2, s2 = s * s;
    return d2 * vselect(s2 < smin2, smin2, s2);
}

/* The window of query (X, Y, A) over the chunk, at the pair spacing 2 / (cj + A): the candidates
 * in it packed in order into (dtx, dty, dc) (dc: their 1/h, cj), their count returned. */
static inline __attribute__((always_inline)) uint32_t window(const float *cx, const float *cy, const float *ca,
                                                             uint32_t n, vf X, vf Y, vf A, vf c2, vf smin2, vf cut2,
                                                             vf umax2, float *dtx, float *dty, float *dc) {
    uint32_t m = 0;
    for (uint32_t o = 0; o < n; o += VW) {
        const vf tx = VLOAD(cx + o) - X, ty = VLOAD(cy + o) - Y;
        const vf d2 = tx * tx + ty * ty;
        const vf cj = VLOAD(ca + o);
        m += PACK3(WINDOW(window_value(d2, cj + A, c2, smin2), cut2, umax2), tx, ty, cj, dtx + m, dty + m, dc + m);
    }
    return m;
}

/* The pair's a = 1/h_i + 1/h_j, or, where the spacings differ more than WR times (walls), at the
 * smaller spacing: 2 max(cj, A); *own: the lanes that are not so. */
static inline __attribute__((always_inline)) vf pair_a(const int walls, vf cj, vf A, vf WR, vi *own) {
    const vf a = cj + A;
    if (!walls) {
        *own = visplat(-1);
        return a;
    }
    const vi up = cj > A;
    const vf big = vselect(up, cj, A), small = vselect(up, A, cj);
    *own = big <= small * WR;
    return vselect(*own, a, big + big);
}

/* The mirror images, across the line t . n + D = 0 (n = (NX, NY), D >= 0 the query's distance to
 * it), of the live lanes of one vector of candidates (tx, ty relative to the query, cj) of its own
 * spacing on its side (e = t . n + D > 0): t' = t - 2 e n, less the glide (GX, GY) along the line
 * when glide; those in the window packed in order at (itx, ity, ic), their count returned. */
static inline __attribute__((always_inline)) uint32_t mirror_vector(vf tx, vf ty, vf cj, vi live, const int glide, vf A,
                                                                    vf WR, vf NX, vf NY, vf D, vf GX, vf GY, vf c2,
                                                                    vf smin2, vf cut2, vf umax2, float *itx, float *ity,
                                                                    float *ic) {
    vi own;
    const vf a = pair_a(1, cj, A, WR, &own);
    const vf e = tx * NX + ty * NY + D, f = e + e;
    vf jx = tx - f * NX, jy = ty - f * NY;
    if (glide) jx = jx - GX, jy = jy - GY;
    const vf v = vselect(live & own & (e > vsplat(0.0f)), window_value(jx * jx + jy * jy, a, c2, smin2), umax2);
    return PACK3(WINDOW(v, cut2, umax2), jx, jy, cj, itx, ity, ic);
}

/* A plain mirror: the images of the packed candidates (tx, ty, cj)[0 .. m). An image is never
 * nearer than its candidate, so the packed candidates hold every image in reach but the query's
 * own (t = 0: density.c adds it). A glide mirror: the images of the chunk's candidates (cx, cy,
 * ca)[0 .. n), shifted by (GX, GY) along the line; the query itself is one of them. */
static inline __attribute__((always_inline)) uint32_t images(const int glide, const float *px, const float *py,
                                                             const float *pc, uint32_t n, vi iota, vf X, vf Y, vf A,
                                                             vf WR, vf NX, vf NY, vf D, vf GX, vf GY, vf c2, vf smin2,
                                                             vf cut2, vf umax2, float *itx, float *ity, float *ic) {
    uint32_t k = 0;
    for (uint32_t r = 0; r < n; r += VW) {
        /* the packed streams are relative to the query and end at n; the chunk is absolute and padded */
        const vf tx = glide ? VLOAD(px + r) - X : VLOAD(px + r), ty = glide ? VLOAD(py + r) - Y : VLOAD(py + r);
        const vi live = glide ? visplat(-1) : VLIVE(iota, (int32_t)(n - r));
        k += mirror_vector(tx, ty, VLOAD(pc + r), live, glide, A, WR, NX, NY, D, GX, GY, c2, smin2, cut2, umax2,
                           itx + k, ity + k, ic + k);
    }
    return k;
}

/* Add the terms of the packed candidates (tx, ty, cj)[0 .. m) to the lane sums (sx, sy). With
 * walls, a pair of spacings more than WR apart (pair_a) is tested again against the window at its
 * smaller spacing, and its term is 0 outside. Lanes of the last vector beyond m compute a finite k
 * from d = 1, cj = 1 and add k * 0 (+0 or -0), which changes no sum; so do pairs out of the window. */
static inline __attribute__((always_inline)) void
terms(const int walls, const float *dtx, const float *dty, const float *dc, uint32_t m, vi iota, vf A, vf WR, vf c2,
      vf smin2, vf cut2, vf umax, vf umax2, vi qmax, const table_regs *w_t, const table_regs *dw_t, vf8 *sx, vf8 *sy) {
    const vf two = vsplat(2.0f), zero = vsplat(0.0f), one = vsplat(1.0f);
    for (uint32_t r = 0; r < m; r += VW) {
        const vi live = VLIVE(iota, (int32_t)(m - r));
        const vf tx = vselect(live, VLOAD(dtx + r), zero), ty = vselect(live, VLOAD(dty + r), zero);
        vi own;
        const vf a = pair_a(walls, vselect(live, VLOAD(dc + r), one), A, WR, &own);
        const vf d2 = vselect(live, tx * tx + ty * ty, one); /* d2 again: the same operations */
        const vf d = VSQRT(d2);
        const vf u = (d * c2) * a;
        const vf uc = VMIN(u, umax);
        const vi b = VIMIN(__builtin_convertvector(uc, vi), qmax);
        const vf f = uc - __builtin_convertvector(b, vf);
        const vf g = LOOKUP(w_t, b) + f * LOOKUP(dw_t, b);
        vf k = (two * g) / (a * d);
        if (walls) {
            const vf v = window_value(d2, a, c2, smin2);
            k = vselect(own | ((v > cut2) & (v < umax2)), k, zero);
        }
        *sx = add_lanes(*sx, k * tx);
        *sy = add_lanes(*sy, k * ty);
    }
}

void KERNEL(const dpc_density_job *job, const float *cx, const float *cy, const float *ca, uint32_t n, const float *q,
            unsigned nq, float *acc, float *scratch) {
    const vf c2 = vsplat(job->c2), cut2 = vsplat(job->cut2), umax = vsplat(job->umax), umax2 = vsplat(job->umax2);
    const vf smin2 = vsplat(job->smin2), WR = vsplat(WALL_H);
#if VW == 16
    const vi iota = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
#else
    const vi iota = {0, 1, 2, 3, 4, 5, 6, 7};
#endif
    const vi qmax = visplat(job->qmax);
    float *itx = scratch + 6 * DPC_DENSITY_DENSE, *ity = itx + DPC_DENSITY_DENSE, *ic = ity + DPC_DENSITY_DENSE;
    table_regs w_t, dw_t;
    LOAD_TABLE(&w_t, job->w, job->qmax + 2);
    LOAD_TABLE(&dw_t, job->dw, job->qmax + 2);
    /* Query p's window is packed while query p - 1's terms are summed: the terms read what the
     * window stored one query earlier, when those stores have reached the cache (reading them at
     * once waits for them: one load spans several stores), 0.8x the kernel's time on AMD Zen 5. */
    uint32_t packed[2] = {0, 0};
    for (unsigned p = 0; p <= nq; p++) {
        if (p < nq) {
            const float *qp = q + DPC_DENSITY_QUERY * p;
            float *d = scratch + 3 * DPC_DENSITY_DENSE * (p & 1);
            packed[p & 1] = window(cx, cy, ca, n, vsplat(qp[0]), vsplat(qp[1]), vsplat(qp[2]), c2, smin2, cut2, umax2,
                                   d, d + DPC_DENSITY_DENSE, d + 2 * DPC_DENSITY_DENSE);
        }
        if (p == 0) continue;
        const unsigned o = p - 1; /* the query whose terms are summed now */
        const float *qp = q + DPC_DENSITY_QUERY * o;
        const vf X = vsplat(qp[0]), Y = vsplat(qp[1]), A = vsplat(qp[2]);
        const float *dtx = scratch + 3 * DPC_DENSITY_DENSE * (o & 1), *dty = dtx + DPC_DENSITY_DENSE,
                    *dc = dty + DPC_DENSITY_DENSE;
        const uint32_t m = packed[o & 1];
        vf8 sx, sy;
        memcpy(&sx, acc + 16 * o, sizeof sx);
        memcpy(&sy, acc + 16 * o + 8, sizeof sy);
        /* the terms: the candidates', then their (glide-)mirror images' */
        if (job->walls)
            terms(1, dtx, dty, dc, m, iota, A, WR, c2, smin2, cut2, umax, umax2, qmax, &w_t, &dw_t, &sx, &sy);
        else terms(0, dtx, dty, dc, m, iota, A, WR, c2, smin2, cut2, umax, umax2, qmax, &w_t, &dw_t, &sx, &sy);
        if (qp[3] != 0.0f) {
            const vf NX = vsplat(qp[4]), NY = vsplat(qp[5]), D = vsplat(qp[6]);
            const vf GX = vsplat(0.0f - qp[7] * qp[5]), GY = vsplat(qp[7] * qp[4]); /* glide (-ny, nx) s */
            const uint32_t k = qp[7] == 0.0f ? images(0, dtx, dty, dc, m, iota, X, Y, A, WR, NX, NY, D, GX, GY, c2,
                                                      smin2, cut2, umax2, itx, ity, ic)
                                             : images(1, cx, cy, ca, n, iota, X, Y, A, WR, NX, NY, D, GX, GY, c2, smin2,
                                                      cut2, umax2, itx, ity, ic);
            terms(0, itx, ity, ic, k, iota, A, WR, c2, smin2, cut2, umax, umax2, qmax, &w_t, &dw_t, &sx, &sy);
        }
        memcpy(acc + 16 * o, &sx, sizeof sx);
        memcpy(acc + 16 * o + 8, &sy, sizeof sy);
    }
}
