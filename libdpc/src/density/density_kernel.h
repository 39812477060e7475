/* The hot loop of a density layer (density.c), written once (density_kernel_body.h), compiled
 * for any CPU (density_kernel.c: the scalar path) and for AVX2 and AVX-512, and chosen by the
 * model's ISA path; every path gives the same bits. For a few query points it adds the terms
 * of a chunk of candidates (already in the coordinates of their mirror image) to per-lane sums.
 * With t = c_j - x_i, a = 1/h_i + 1/h_j (= 2 / h_ij), s = a c2:
 *     window:  cut^2 < d2 max(s s, smin2) < umax^2,   d2 = tx tx + ty ty (smin2 = 4 umax^2:
 *              no pair farther than half the square),
 *     term:    k = 2 g(u) / (a d),   d = sqrt(d2), u = (d c2) a,
 *              g(u) = w[q] + (u' - q) dw[q],  u' = min(u, umax), q = min(trunc(u'), qmax),
 *     sums:    the candidates in the window, in chunk order, go to lanes 0, 1, .., 7, 0, 1, ..:
 *              the lane of the r-th one is r mod 8, and each lane adds k tx (and k ty) in order.
 * With walls (job->walls), a pair whose 1/h differ more than W = WALL_H times (big > W small)
 * has a = 2 big (the smaller spacing): its term is that of a and 0 outside the window at a. And a
 * query with a wall (plane != 0) then adds the terms of the mirror images, of candidates with
 * e = t . n + D > 0 whose 1/h are within W of its own, in the window at the pair's a, in chunk
 * order, to lanes 0, 1, .. again: with s = 0 (a plain mirror) t' = t - 2 e n of the window's
 * candidates (the caller adds the query's own image); else (a glide mirror) t' = (t - 2 e n) - g,
 * g = s (-ny, nx) (gx = 0 - s ny, gy = s nx), of every candidate of the chunk, the query's own
 * position among them. The caller adds the 8 lane sums
 * in the tree (l, l + 4), (l, l + 2), (0, 1). Every step is an IEEE float32 operation (sqrt and
 * division correctly rounded; a multiply then an add, never an FMA) or an exact integer one, in
 * this order, on every path. */
#ifndef DPC_DENSITY_KERNEL_H
#define DPC_DENSITY_KERNEL_H

#include <stdint.h>

#define DPC_DENSITY_CHUNK 1024u /* candidates per chunk at most; chunks are padded to a multiple of 16 */
#define DPC_DENSITY_DENSE (DPC_DENSITY_CHUNK + 32u) /* floats per stream of the kernels' scratch */
#define DPC_DENSITY_QUERY 8u                        /* floats per query */

typedef struct dpc_density_job {
    const float *w, *dw; /* the kernel table and its slopes, qmax + 2 entries */
    float c2, cut2, umax, umax2, smin2;
    int32_t qmax;
    int walls; /* pairs of spacings more than WALL_H (walls.h) apart see the smaller one */
} dpc_density_job;

/* Query p is q[8p .. 8p+7] = x, y, 1/h, plane, nx, ny, D, s (plane != 0: a wall, the line
 * t . n + D = 0 through its nearest point, n the unit normal to the query's side, s the glide along
 * it); its lane sums
 * acc[16p .. 16p+7] (x) and acc[16p+8 .. 16p+15] (y) are added to. The chunk is cx, cy, ca[0 .. n)
 * (x, y, 1/h), n a multiple of 16 (padding out of every window). scratch: 9 * DPC_DENSITY_DENSE
 * floats. */
typedef void dpc_density_kernel(const dpc_density_job *job, const float *cx, const float *cy, const float *ca,
                                uint32_t n, const float *q, unsigned nq, float *acc, float *scratch);
typedef dpc_density_kernel *dpc_density_fn;

dpc_density_kernel dpc_density_kernel_generic;
#if defined(DPC_HAVE_AVX2)
dpc_density_kernel dpc_density_kernel_avx2;
dpc_density_kernel dpc_density_kernel_avx512;
#endif

#endif
