/* Blue noise that follows a density (density.h states the definition). */
#include "density/density.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/error.h"
#include "common/threads.h"
#include "cpu/cpu_cascade.h"
#include "cpu/cpu_grid.h"
#include "density/density_kernel.h"
#include "density/walls.h"
#include "model/input.h"

#define PARALLEL_MIN_POINTS 2048
#define MAX_GRID 2048u /* cells per axis of the neighbour grid */
/* Local spacings are capped at the square's size; pairs see at most half of it (smin2). */
#define H_CAP 1.0

typedef struct density_map {
    uint32_t W, H;
    double *row_cdf; /* H + 1: the mass of rows below, total 1 */
    double *col_cdf; /* H * (W + 1): per row, the row's mass left of each cell, total 1 */
    float *h;        /* per cell: the local spacing (m rho)^(-1/2); 0 where rho = 0 */
    float h_max;
    dpc_walls walls;
} density_map;

static void map_free(density_map *d) {
    free(d->row_cdf);
    free(d->col_cdf);
    free(d->h);
    dpc_walls_free(&d->walls);
}

/* The cell holding a coordinate: floor(x * n), exact in double for float x and n < 2^29. */
static uint32_t cell_of(float x, uint32_t n) {
    uint32_t c = (uint32_t)((double)x * (double)n);
    return c < n ? c : n - 1;
}

static size_t cell_index(const density_map *d, float x, float y) {
    return (size_t)cell_of(y, d->H) * d->W + cell_of(x, d->W);
}

static float cell_h(const density_map *d, float x, float y) { return d->h[cell_index(d, x, y)]; }

/* A point closer than WALL_REACH h to a wall of its own sees the mirror images, across the wall's
 * line at its nearest point, of its candidates on its side, as the square's sides mirror the set:
 * the rows of points beside a wall see it as the continuation of their side. */
#define WALL_REACH 2.0

/* The square's sides are glide mirrors: the image of a point across a side is its mirror image
 * shifted along the side by GLIDE mean spacings (at most a quarter of the side), towards the
 * side's middle from the half the query lies in, and dropped where that leaves the side. A plain
 * mirror shows each point its own image, which holds the first points in a row half a spacing
 * from the side (the strip half a spacing wide along it held 1.2 times its count); shifted, the
 * images are other points of the same side and density, as a torus would show them. */
#define GLIDE 4.0

/* Where a wall runs straight it is a glide mirror too: when a point's nearest wall point lies
 * along a segment that goes on for WALL_GLIDE of the point's spacings towards the square's middle,
 * the point sees the images of its side's points across the wall's line shifted that far along
 * it, so that no row forms beside the wall; its group gathers candidates around the point's
 * shifted position as well. Elsewhere (a staircase of short segments) a wall is a plain mirror. */
#define WALL_GLIDE 4.0f

static double wall_reach(float h) {
    const double r = WALL_REACH * (double)h;
    return r < 0.5 ? r : 0.5;
}

dpc_status dpc_density_check(const dpc_model *model, const float *density, uint32_t width, uint32_t height) {
    const dpc_cascade *c = &model->cascade;
    if (c->dims != 2)
        return dpc_fail(DPC_ERROR_UNSUPPORTED,
                        "a density needs a 2-D model; this model has %u dimensions (densities over 3 or more "
                        "dimensions are not supported)",
                        c->dims);
    if (c->progressive_base)
        return dpc_fail(DPC_ERROR_UNSUPPORTED, "a density needs a set model; this model is progressive");
    if (c->grid_dims) return dpc_fail(DPC_ERROR_UNSUPPORTED, "a density needs a model without gridded dimensions");
    for (uint32_t l = 0; l < c->n_layers; l++) {
        const dpc_layer *L = &c->layers[l];
        if (L->n_sub != 1 || L->masks[0] != 3u || L->fixed)
            return dpc_fail(DPC_ERROR_UNSUPPORTED,
                            "a density needs a model whose layers filter the plane as a whole (one subspace xy, "
                            "e.g. bnot-2d); layer %u has %u subspaces",
                            l, L->n_sub);
    }
    if (!density) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "density is NULL");
    if (width == 0 || height == 0)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "density is %u x %u cells: both must be positive", width, height);
    if ((uint64_t)width * height > DPC_DENSITY_MAX_CELLS)
        return dpc_fail(DPC_ERROR_LIMIT, "density is %u x %u cells, at most %u in all", width, height,
                        DPC_DENSITY_MAX_CELLS);
    double total = 0.0;
    const size_t cells = (size_t)width * height;
    for (size_t i = 0; i < cells; i++) {
        const float v = density[i];
        if (!(v >= 0.0f) || isinf(v))
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                            "density value %g at cell (%zu, %zu): values must be finite and >= 0", (double)v, i % width,
                            i / width);
        total += (double)v;
    }
    if (!(total > 0.0)) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "density is zero everywhere");
    return DPC_OK;
}

/* The inverse CDF and the per-cell spacing for m points (at most H_CAP). */
static dpc_status map_init(density_map *d, const float *density, uint32_t W, uint32_t H, size_t m) {
    memset(d, 0, sizeof *d);
    d->W = W;
    d->H = H;
    d->row_cdf = (double *)malloc((H + 1) * sizeof(double));
    d->col_cdf = (double *)malloc((size_t)H * (W + 1) * sizeof(double));
    d->h = (float *)malloc((size_t)W * H * sizeof(float));
    if (!d->row_cdf || !d->col_cdf || !d->h) {
        map_free(d);
        return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for a %u x %u density", W, H);
    }
    double total = 0.0;
    d->row_cdf[0] = 0.0;
    for (uint32_t y = 0; y < H; y++) {
        double *cc = d->col_cdf + (size_t)y * (W + 1);
        double row = 0.0;
        cc[0] = 0.0;
        for (uint32_t x = 0; x < W; x++) {
            row += (double)density[(size_t)y * W + x];
            cc[x + 1] = row;
        }
        for (uint32_t x = 1; x <= W; x++) cc[x] = row > 0.0 ? cc[x] / row : 0.0;
        if (row > 0.0) cc[W] = 1.0;
        total += row;
        d->row_cdf[y + 1] = total;
    }
    for (uint32_t y = 1; y <= H; y++) d->row_cdf[y] /= total;
    d->row_cdf[H] = 1.0;
    const double per_cell = (double)W * (double)H / total;
    float h_max = 0.0f;
    for (size_t i = 0; i < (size_t)W * H; i++) {
        const double rho = (double)density[i] * per_cell;
        float h = 0.0f;
        if (rho > 0.0) {
            const double hd = 1.0 / sqrt((double)m * rho);
            h = (float)(hd <= H_CAP ? hd : H_CAP);
        }
        d->h[i] = h;
        if (h > h_max) h_max = h;
    }
    d->h_max = h_max;
    /* buckets of the walls about a mean spacing wide, the distance field's cells a quarter of it */
    const double b = floor(sqrt((double)m)), e = floor(4.0 * sqrt((double)m));
    const dpc_status st = dpc_walls_init(&d->walls, d->h, W, H,
                                         b < 1.0     ? 1u
                                         : b > 512.0 ? 512u
                                                     : (uint32_t)b,
                                         e < 16.0     ? 16u
                                         : e > 2048.0 ? 2048u
                                                      : (uint32_t)e);
    if (st != DPC_OK) map_free(d);
    return st;
}

/* The first index k in [1, n] with cdf[k] > u (cdf[0] <= u < cdf[n] = 1): the cell k - 1 has mass. */
static uint32_t find_cell(const double *cdf, uint32_t n, double u) {
    uint32_t lo = 1, hi = n;
    while (lo < hi) {
        const uint32_t mid = lo + (hi - lo) / 2;
        if (cdf[mid] > u) hi = mid;
        else lo = mid + 1;
    }
    return lo - 1;
}

/* (cell + f) / n as a float inside that cell (rounding may land on a neighbour's edge). */
static float in_cell(uint32_t cell, double f, uint32_t n) {
    float v = (float)(((double)cell + f) / (double)n);
    while (v > 0.0f && cell_of(v, n) > cell) v = nextafterf(v, 0.0f);
    while (cell_of(v, n) < cell) v = nextafterf(v, 1.0f);
    return v;
}

/* Map a point of [0,1)^2 through the inverse CDF: the row by the second coordinate, then the cell
 * within the row by the first; the fractions within the cell are kept. */
static void map_point(const density_map *d, float *p) {
    const double u = (double)p[0], v = (double)p[1];
    const uint32_t r = find_cell(d->row_cdf, d->H, v);
    const double fy = (v - d->row_cdf[r]) / (d->row_cdf[r + 1] - d->row_cdf[r]);
    const double *cc = d->col_cdf + (size_t)r * (d->W + 1);
    const uint32_t k = find_cell(cc, d->W, u);
    const double fx = (u - cc[k]) / (cc[k + 1] - cc[k]);
    p[0] = in_cell(k, fx < 1.0 ? fx : 0.0, d->W);
    p[1] = in_cell(r, fy < 1.0 ? fy : 0.0, d->H);
}

/* ---- one layer ---------------------------------------------------------------------------- */

/* The neighbour grid: G x G cells about the radius at the mean spacing wide, and a cell holding
 * more than SPLIT_MIN points cut into k x k leaves of about LEAF_POINTS (a dense spot otherwise
 * makes every point of it scan thousands); a cell not cut is one leaf. The points are sorted by
 * cell, and within a cut cell by leaf (row-major), each sort stable. A leaf's query points,
 * GROUP_MAX at a time, share one run of candidates: the points of every leaf (of every mirror
 * image) that one of them may reach, in a fixed order (images, cell rows, cells, leaf rows,
 * leaves, sorted order), gathered in image coordinates and in chunks of RUN_CAP. The run depends
 * on the group alone, so neither the thread count nor the ISA path changes it; the kernel
 * (density_kernel.h) fixes the rest of the evaluation order. */
#define SPLIT_MIN 48u
#define LEAF_POINTS 16u
#define GROUP_MAX 32u
#define RUN_CAP DPC_DENSITY_CHUNK
#define FAR_AWAY 1.0e4f /* the padding's coordinates: beyond every reach */

typedef struct layer_pass {
    const float *sx, *sy, *sa, *sh;     /* sorted: x, y, 1/h, h (readable 16 floats past m) */
    const uint32_t *start;              /* G * G + 1 cell starts */
    const float *hmax, *hmin;           /* per cell: the largest and smallest h of its points */
    const uint32_t *kdiv;               /* per cell: k, leaves per axis */
    const uint32_t *leaf_off;           /* per cell: its first leaf (G * G + 1) */
    const uint32_t *leaf_start;         /* per leaf: its first point (n_leaves + 1) */
    const float *leaf_hmax, *leaf_hmin; /* per leaf: the largest and smallest h of its points */
    const density_map *map;
    uint32_t G, n_leaves;
    float rho, h_max;
    float glide; /* the shift along a side of the images across it (GLIDE) */
    dpc_density_job job;
    dpc_density_fn kernel;
    float *scratch; /* SLOT_FLOATS per slot */
    float *delta;   /* m x 2, sorted order */
} layer_pass;

#define SLOT_FLOATS (3u * (RUN_CAP + 16u) + (DPC_DENSITY_QUERY + 16u) * GROUP_MAX + 9u * DPC_DENSITY_DENSE)

/* The distance from the span [a, b] to the span [lo, hi] (0 where they meet). */
static float span_gap(float a, float b, float lo, float hi) { return b < lo ? lo - b : a > hi ? a - hi : 0.0f; }

/* The pair spacing's bound rho h_ij for h_j <= hc (h_ij grows with h_j), with a margin for rounding. */
static float reach(float rho, float hi, float hc) {
    const float r = rho * (2.0f * hi * hc / (hi + hc));
    return (r < 0.5f ? r : 0.5f) * 1.001f;
}

/* The cells [g0, g1] of an axis of n holding originals in [lo, hi] (clipped to [0, 1]); 0 if none. */
static int cell_span(float lo, float hi, uint32_t n, uint32_t *g0, uint32_t *g1) {
    if (hi < 0.0f || lo > 1.0f || lo > hi) return 0;
    *g0 = lo <= 0.0f ? 0 : cell_of(lo < 1.0f ? lo : nextafterf(1.0f, 0.0f), n);
    *g1 = hi >= 1.0f ? n - 1 : cell_of(hi, n);
    return 1;
}

/* Image k of an axis: v -> off + sgn v (0: the set, 1: mirrored at 0, 2: mirrored at 1). */
static const float img_off[3] = {0.0f, 0.0f, 2.0f}, img_sgn[3] = {1.0f, -1.0f, -1.0f};

/* The originals [lo, hi] whose image k lies within R of [v0, v1]; k = 0 with a shift s: v -> s + v. */
static void image_span(int k, float s, float v0, float v1, float R, float *lo, float *hi) {
    if (k == 0) *lo = v0 - R - s, *hi = v1 + R - s;
    else if (k == 1) *lo = -v1 - R, *hi = R - v0;
    else *lo = 2.0f - v1 - R, *hi = 2.0f - v0 + R;
}

/* The gap from the image (off + sgn [i, i + 1] / n) of span i of an axis of n to [v0, v1]. */
static float image_gap(float off, float sgn, uint32_t i, float inv_n, float v0, float v1) {
    const float a = off + sgn * ((float)i * inv_n), b = off + sgn * ((float)(i + 1) * inv_n);
    return span_gap(a < b ? a : b, a < b ? b : a, v0, v1);
}

typedef struct group {
    float *cx, *cy, *ca; /* the chunk: RUN_CAP (+ 16 of padding) each */
    uint32_t n;
    float *q; /* the queries (density_kernel.h) */
    unsigned nq;
    float *acc;           /* nq x 16 lane sums */
    float *dense;         /* the kernel's scratch */
    uint32_t r0, r1;      /* the range waiting to be appended */
    float ax, bx, ay, by; /* the image it is seen through */
    int clip_x, clip_y;   /* the image keeps only the points whose shifted coordinate stays in [0, 1) */
    float qlo, qhi;       /* the queries' smallest and largest h */
    float wlo, whi;       /* the waiting range's */
    float clo, chi;       /* the chunk's */
} group;

/* Pad the chunk to whole vectors (far away: out of every window) and add its terms. Where the
 * chunk's spacings and the queries' are all within WALL_H of each other (with a margin for the
 * kernel's rounding of 1/h), no pair sees the smaller spacing, and the kernel skips that test. */
static void flush(const layer_pass *p, group *g) {
    uint32_t n = g->n;
    for (; n % 16u; n++) g->cx[n] = FAR_AWAY, g->cy[n] = FAR_AWAY, g->ca[n] = 0.0f;
    const float wh = WALL_H * (1.0f - 0x1p-16f);
    dpc_density_job job = p->job;
    job.walls = !(g->chi <= wh * g->qlo && g->qhi <= wh * g->clo);
    p->kernel(&job, g->cx, g->cy, g->ca, n, g->q, g->nq, g->acc, g->dense);
    g->n = 0;
    g->clo = INFINITY, g->chi = 0.0f;
}

typedef float v8 __attribute__((vector_size(32)));

/* Append the waiting range of sorted points, seen through its image, to the chunk. */
static void append(const layer_pass *p, group *g) {
    uint32_t j0 = g->r0;
    const uint32_t j1 = g->r1;
    const v8 oxv = (v8){0} + g->ax, sxv = (v8){0} + g->bx, oyv = (v8){0} + g->ay, syv = (v8){0} + g->by;
    const int clip_x = g->clip_x, clip = g->clip_x | g->clip_y;
    while (j0 < j1) {
        if (g->n == RUN_CAP) flush(p, g);
        g->clo = g->wlo < g->clo ? g->wlo : g->clo;
        g->chi = g->whi > g->chi ? g->whi : g->chi;
        const uint32_t len = j1 - j0 < RUN_CAP - g->n ? j1 - j0 : RUN_CAP - g->n;
        /* whole vectors of 8: the sorted arrays are readable, and the chunk writable, 16 floats
         * past their ends; what lies past the range is overwritten before the kernel reads it */
        float *cx = g->cx + g->n, *cy = g->cy + g->n, *ca = g->ca + g->n;
        for (uint32_t k = 0; k < len; k += 8) {
            v8 vx, vy, va;
            memcpy(&vx, p->sx + j0 + k, sizeof vx);
            memcpy(&vy, p->sy + j0 + k, sizeof vy);
            memcpy(&va, p->sa + j0 + k, sizeof va);
            vx = oxv + sxv * vx;
            vy = oyv + syv * vy;
            memcpy(cx + k, &vx, sizeof vx);
            memcpy(cy + k, &vy, sizeof vy);
            memcpy(ca + k, &va, sizeof va);
        }
        if (clip) { /* a point whose image leaves the side's span is far away */
            const float *c = clip_x ? cx : cy;
            for (uint32_t k = 0; k < len; k++)
                if (!(c[k] >= 0.0f && c[k] < 1.0f)) cx[k] = FAR_AWAY, cy[k] = FAR_AWAY, ca[k] = 0.0f;
        }
        g->n += len;
        j0 += len;
    }
    g->r0 = g->r1 = j1;
    g->wlo = INFINITY, g->whi = 0.0f;
}

/* Add the sorted points [a, b) (spacings within [lo, hi]) to the run: one range with the waiting
 * one where they touch. */
static void add_range(const layer_pass *p, group *g, uint32_t a, uint32_t b, float lo, float hi) {
    if (a != g->r1) {
        append(p, g);
        g->r0 = a;
        g->wlo = INFINITY, g->whi = 0.0f;
    }
    g->r1 = b;
    g->wlo = lo < g->wlo ? lo : g->wlo;
    g->whi = hi > g->whi ? hi : g->whi;
}

/* The sum of lane sums l[0 .. 8) in the canonical tree. */
static float lane_tree(const float *l) { return ((l[0] + l[4]) + (l[2] + l[6])) + ((l[1] + l[5]) + (l[3] + l[7])); }

/* The leaves of cut cell (gx, gy) (k per axis) that may hold a point within reach of the group:
 * bbox [bx0, bx1] x [by0, by1], largest h hq; [xlo, xhi] x [ylo, yhi] the originals within the
 * group's widest reach. */
static void scan_leaves(const layer_pass *p, group *g, uint32_t gx, uint32_t gy, const float box[4], float hq,
                        float xlo, float xhi, float ylo, float yhi) {
    const size_t cell = (size_t)gy * p->G + gx;
    const uint32_t k = p->kdiv[cell], n = p->G * k, first = p->leaf_off[cell];
    uint32_t lx0, lx1, ly0, ly1;
    if (!cell_span(xlo, xhi, n, &lx0, &lx1) || !cell_span(ylo, yhi, n, &ly0, &ly1)) return;
    /* the cell's own leaves only */
    lx0 = lx0 > gx * k ? lx0 - gx * k : 0;
    ly0 = ly0 > gy * k ? ly0 - gy * k : 0;
    if (lx1 < gx * k || ly1 < gy * k) return;
    lx1 = lx1 - gx * k < k - 1 ? lx1 - gx * k : k - 1;
    ly1 = ly1 - gy * k < k - 1 ? ly1 - gy * k : k - 1;
    const float inv_n = 1.0f / (float)n;
    for (uint32_t ly = ly0; ly <= ly1; ly++) {
        const float gap_y = image_gap(g->ay, g->by, gy * k + ly, inv_n, box[2], box[3]);
        for (uint32_t lx = lx0; lx <= lx1; lx++) {
            const uint32_t leaf = first + ly * k + lx;
            const uint32_t a = p->leaf_start[leaf], b = p->leaf_start[leaf + 1];
            if (a == b) continue;
            const float gap_x = image_gap(g->ax, g->bx, gx * k + lx, inv_n, box[0], box[1]);
            const float Rc = reach(p->rho, hq, p->leaf_hmax[leaf]);
            if (gap_x * gap_x + gap_y * gap_y < Rc * Rc) add_range(p, g, a, b, p->leaf_hmin[leaf], p->leaf_hmax[leaf]);
        }
    }
}

/* The factor k of one term (density_kernel.h) for t = (tx, ty) and a, 0 outside the window: the
 * kernel's float operations in its order, on one value. */
static float own_term(const dpc_density_job *job, float tx, float ty, float a) {
    const float d2 = tx * tx + ty * ty, s = a * job->c2, s2 = s * s;
    const float v = d2 * (s2 < job->smin2 ? job->smin2 : s2);
    if (!(v > job->cut2 && v < job->umax2)) return 0.0f;
    const float d = sqrtf(d2), u = (d * job->c2) * a;
    const float uc = u < job->umax ? u : job->umax;
    int32_t b = (int32_t)uc;
    b = b < job->qmax ? b : job->qmax;
    const float f = uc - (float)b;
    const float g = job->w[b] + f * job->dw[b];
    return (2.0f * g) / (a * d);
}

/* Add to the lane sums of the group's queries the terms of every candidate within reach of their
 * bounding box: the runs of each mirror image of the set in turn. */
static void gather(const layer_pass *p, group *g) {
    const float hq = g->qhi;
    /* the queries' box, and the box of where their candidates lie: around each query, and around
     * its position shifted by its glide along a wall (s (-ny, nx)) */
    float box[4] = {g->q[0], g->q[0], g->q[1], g->q[1]}; /* x0, x1, y0, y1 */
    float reach_box[4];
    memcpy(reach_box, box, sizeof box);
    for (unsigned k = 0; k < g->nq; k++) {
        const float *q = g->q + DPC_DENSITY_QUERY * k;
        const float gx = q[0] - q[7] * q[5], gy = q[1] + q[7] * q[4]; /* q[7] = 0: the query itself */
        box[0] = q[0] < box[0] ? q[0] : box[0];
        box[1] = q[0] > box[1] ? q[0] : box[1];
        box[2] = q[1] < box[2] ? q[1] : box[2];
        box[3] = q[1] > box[3] ? q[1] : box[3];
        const float x0 = gx < q[0] ? gx : q[0], x1 = gx > q[0] ? gx : q[0];
        const float y0 = gy < q[1] ? gy : q[1], y1 = gy > q[1] ? gy : q[1];
        reach_box[0] = x0 < reach_box[0] ? x0 : reach_box[0];
        reach_box[1] = x1 > reach_box[1] ? x1 : reach_box[1];
        reach_box[2] = y0 < reach_box[2] ? y0 : reach_box[2];
        reach_box[3] = y1 > reach_box[3] ? y1 : reach_box[3];
    }
    memset(g->acc, 0, 16 * g->nq * sizeof(float));
    g->n = 0;
    g->wlo = g->clo = INFINITY, g->whi = g->chi = 0.0f;
    const uint32_t G = p->G;
    const float inv_g = 1.0f / (float)G;
    const float R = reach(p->rho, hq, p->h_max);
    /* the images across a side glide along it towards the side's middle (the group lies in one
     * half of each axis: the grid is even) */
    const float sx = box[0] < 0.5f ? -p->glide : p->glide, sy = box[2] < 0.5f ? -p->glide : p->glide;
    memcpy(box, reach_box, sizeof box);
    for (int iy = 0; iy < 3; iy++) {
        float ylo, yhi, xlo, xhi;
        uint32_t gy0, gy1, gx0, gx1;
        for (int ix = 0; ix < 3; ix++) {
            /* across a left or right side (ix > 0, iy = 0) y shifts by sy; across the bottom or
             * top x by sx; the set and the corners' images do not shift */
            const float ty = ix > 0 && iy == 0 ? sy : 0.0f, tx = iy > 0 && ix == 0 ? sx : 0.0f;
            image_span(iy, ty, box[2], box[3], R, &ylo, &yhi);
            if (!cell_span(ylo, yhi, G, &gy0, &gy1)) continue;
            g->ay = iy ? img_off[iy] : ty, g->by = img_sgn[iy];
            image_span(ix, tx, box[0], box[1], R, &xlo, &xhi);
            if (!cell_span(xlo, xhi, G, &gx0, &gx1)) continue;
            g->ax = ix ? img_off[ix] : tx, g->bx = img_sgn[ix];
            g->clip_x = tx != 0.0f, g->clip_y = ty != 0.0f;
            g->r0 = g->r1 = 0;
            for (uint32_t gy = gy0; gy <= gy1; gy++) {
                const float gap_y = image_gap(g->ay, g->by, gy, inv_g, box[2], box[3]);
                const uint32_t *st = p->start + (size_t)gy * G;
                const float *hm = p->hmax + (size_t)gy * G;
                for (uint32_t gx = gx0; gx <= gx1; gx++) {
                    if (st[gx] == st[gx + 1]) continue;
                    const float gap_x = image_gap(g->ax, g->bx, gx, inv_g, box[0], box[1]);
                    const float Rc = reach(p->rho, hq, hm[gx]);
                    if (!(gap_x * gap_x + gap_y * gap_y < Rc * Rc)) continue; /* no point of it in reach */
                    if (p->kdiv[(size_t)gy * G + gx] == 1)
                        add_range(p, g, st[gx], st[gx + 1], p->hmin[(size_t)gy * G + gx], hm[gx]);
                    else scan_leaves(p, g, gx, gy, box, hq, xlo, xhi, ylo, yhi);
                }
            }
            append(p, g);
        }
    }
    if (g->n) flush(p, g);
}

/* The sorted points [s0, s1) (one leaf's, at most GROUP_MAX) as one group; a point near a wall of
 * its own adds the mirror images (the kernel those of its candidates, here its own). */
static void run_group(const layer_pass *p, float *slot, uint32_t s0, uint32_t s1) {
    group g;
    g.cx = slot;
    g.cy = slot + (RUN_CAP + 16);
    g.ca = slot + 2 * (RUN_CAP + 16);
    g.q = slot + 3 * (RUN_CAP + 16);
    g.acc = g.q + DPC_DENSITY_QUERY * GROUP_MAX;
    g.dense = g.acc + 16 * GROUP_MAX;
    g.nq = s1 - s0;
    float hq = 0.0f, hlo = INFINITY;
    memset(g.q, 0, DPC_DENSITY_QUERY * g.nq * sizeof(float));
    for (unsigned k = 0; k < g.nq; k++) {
        const uint32_t i = s0 + k;
        float *q = g.q + DPC_DENSITY_QUERY * k;
        q[0] = p->sx[i], q[1] = p->sy[i], q[2] = p->sa[i];
        hq = p->sh[i] > hq ? p->sh[i] : hq;
        hlo = p->sh[i] < hlo ? p->sh[i] : hlo;
        /* its nearest wall, if closer than WALL_REACH h: the kernel adds the mirror images */
        if (!p->map->walls.n) continue;
        const double x = p->sx[i], y = p->sy[i], far = wall_reach(p->sh[i]);
        if (dpc_walls_far(&p->map->walls, p->sx[i], p->sy[i], far)) continue; /* none near */
        double wx, wy, nx, ny, run[2];
        if (!dpc_walls_nearest(&p->map->walls, x, y, p->sh[i], far, &wx, &wy, &nx, &ny, run)) continue;
        q[3] = 1.0f, q[4] = (float)nx, q[5] = (float)ny;
        q[6] = (float)((x - wx) * nx + (y - wy) * ny); /* the distance to the mirror's line */
        /* a glide along the line, (-ny, nx) or its opposite, the one towards the square's middle,
         * where the nearest point lies along its segment (n on an axis) and the segment runs on
         * for the glide's length that way */
        if (nx != 0.0 && ny != 0.0) continue;
        const double along = -ny * (0.5 - x) + nx * (0.5 - y), sgn = along < 0.0 ? -1.0 : 1.0;
        const float glide = WALL_GLIDE * p->sh[i];
        const double up = nx != 0.0 ? sgn * nx : sgn * -ny; /* the glide's direction on the segment's axis */
        if (run[up > 0.0] >= (double)glide) q[7] = sgn < 0.0 ? -glide : glide;
    }
    g.qlo = hlo, g.qhi = hq;
    gather(p, &g);
    for (unsigned k = 0; k < g.nq; k++) {
        const float *q = g.q + DPC_DENSITY_QUERY * k;
        float *d = p->delta + 2 * (size_t)(s0 + k);
        d[0] = lane_tree(g.acc + 16 * k);
        d[1] = lane_tree(g.acc + 16 * k + 8);
        if (q[3] != 0.0f && q[7] == 0.0f) { /* a plain mirror: the point's own image, at t = -2 D n */
            const float f = q[6] + q[6], tx = 0.0f - f * q[4], ty = 0.0f - f * q[5];
            const float k_own = own_term(&p->job, tx, ty, q[2] + q[2]);
            d[0] = d[0] + k_own * tx;
            d[1] = d[1] + k_own * ty;
        }
    }
}

/* The leaves whose first sorted point is in [lo, hi). */
static void layer_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    const layer_pass *p = (const layer_pass *)ctx;
    float *scratch = p->scratch + (size_t)slot * SLOT_FLOATS;
    const uint32_t *ls = p->leaf_start;
    size_t a = 0, b = p->n_leaves; /* the first leaf starting at or after lo */
    while (a < b) {
        const size_t mid = a + (b - a) / 2;
        if (ls[mid] < lo) a = mid + 1;
        else b = mid;
    }
    for (size_t l = a; l < p->n_leaves && ls[l] < hi; l++)
        for (uint32_t s = ls[l]; s < ls[l + 1]; s += GROUP_MAX)
            run_group(p, scratch, s, ls[l + 1] - s < GROUP_MAX ? ls[l + 1] : s + GROUP_MAX);
}

/* A coordinate after a step: mirrored at the square's edges; NaN when it stays outside. */
static float reflect(float v) {
    if (v < 0.0f) v = -v;
    else if (v >= 1.0f) v = 2.0f - v;
    return (v >= 0.0f && v < 1.0f) ? v : NAN;
}

typedef struct workspace {
    float *x[2], *y[2], *h[2]; /* the points in the order of the last sort, and the next sort's */
    uint32_t *id[2];           /* their index in the caller's order */
    float *a, *delta, *hmax, *hmin, *leaf_hmax, *leaf_hmin, *scratch;
    uint32_t *cell, *perm, *start, *kdiv, *leaf_off, *leaf_start;
} workspace;

static void workspace_free(workspace *w) {
    for (int k = 0; k < 2; k++) free(w->x[k]), free(w->y[k]), free(w->h[k]), free(w->id[k]);
    free(w->a);
    free(w->delta);
    free(w->hmax);
    free(w->hmin);
    free(w->leaf_hmax);
    free(w->leaf_hmin);
    free(w->scratch);
    free(w->cell);
    free(w->perm);
    free(w->start);
    free(w->kdiv);
    free(w->leaf_off);
    free(w->leaf_start);
}

/* The kernel of the model's ISA path: every one gives the same bits (density_kernel.h). */
static dpc_density_fn pick_kernel(dpc_isa isa) {
#if defined(DPC_HAVE_AVX2)
    if (isa == DPC_ISA_AVX512 && dpc_cpu_isa_available(DPC_ISA_AVX512)) return dpc_density_kernel_avx512;
    if (isa == DPC_ISA_AVX2 && dpc_cpu_isa_available(DPC_ISA_AVX2)) return dpc_density_kernel_avx2;
#else
    (void)isa;
#endif
    return dpc_density_kernel_generic;
}

/* The neighbour grid of a layer: cells about the radius at the mean spacing wide, so that a
 * cell's points find their candidates in the 3 x 3 cells around it where the density is flat. */
static uint32_t grid_size(size_t m, float rho) {
    const double g = floor(sqrt((double)m) / (double)rho);
    const uint32_t n = g < 2.0 ? 2u : g > (double)MAX_GRID ? MAX_GRID : (uint32_t)g;
    return n - n % 2u; /* even: a cell, and so a leaf and a group, lies in one half of each axis */
}

/* Leaves per axis for a cell of n points. */
static uint32_t leaves_for(uint32_t n) {
    uint32_t k = 1;
    if (n > SPLIT_MIN)
        while ((uint64_t)k * k * LEAF_POINTS < n) k++;
    return k;
}

/* Cut the cells of more than SPLIT_MIN points into leaves: sort their points (x, y, h, id, in
 * place, stable, tmp_* as room) by leaf, and fill the leaf tables. */
static void make_leaves(workspace *w, uint32_t G, size_t m, float *x, float *y, float *h, uint32_t *id, float *tx,
                        float *ty, float *th, uint32_t *tid) {
    const size_t cells = (size_t)G * G;
    uint32_t L = 0;
    for (size_t c = 0; c < cells; c++) {
        const uint32_t s0 = w->start[c], s1 = w->start[c + 1], k = leaves_for(s1 - s0);
        w->kdiv[c] = k;
        w->leaf_off[c] = L;
        if (k == 1) {
            w->leaf_start[L] = s0;
            w->leaf_hmin[L] = w->hmin[c];
            w->leaf_hmax[L++] = w->hmax[c];
            continue;
        }
        const uint32_t gx = (uint32_t)(c % G), gy = (uint32_t)(c / G), n = G * k, kk = k * k;
        uint32_t *ls = w->leaf_start + L;
        float *lh = w->leaf_hmax + L;
        float *ll = w->leaf_hmin + L;
        memset(lh, 0, kk * sizeof(float));
        for (uint32_t q = 0; q < kk; q++) ll[q] = INFINITY;
        for (uint32_t i = s0; i < s1; i++) {
            uint32_t lx = cell_of(x[i], n), ly = cell_of(y[i], n);
            lx = lx < gx * k ? 0 : lx - gx * k < k ? lx - gx * k : k - 1;
            ly = ly < gy * k ? 0 : ly - gy * k < k ? ly - gy * k : k - 1;
            const uint32_t leaf = ly * k + lx;
            w->cell[i] = leaf;
            if (h[i] > lh[leaf]) lh[leaf] = h[i];
            if (h[i] < ll[leaf]) ll[leaf] = h[i];
        }
        uint32_t *perm = w->perm + s0; /* offsets from s0 */
        dpc_grid_sort(w->cell + s0, s1 - s0, kk, ls, perm);
        for (uint32_t q = 0; q <= kk; q++) ls[q] += s0;
        for (uint32_t t = s0; t < s1; t++) {
            const uint32_t i = s0 + perm[t - s0];
            tx[t] = x[i], ty[t] = y[i], th[t] = h[i], tid[t] = id[i];
        }
        memcpy(x + s0, tx + s0, (s1 - s0) * sizeof(float));
        memcpy(y + s0, ty + s0, (s1 - s0) * sizeof(float));
        memcpy(h + s0, th + s0, (s1 - s0) * sizeof(float));
        memcpy(id + s0, tid + s0, (s1 - s0) * sizeof(uint32_t));
        L += kk;
    }
    w->leaf_off[cells] = L;
    w->leaf_start[L] = (uint32_t)m;
}

static dpc_status run_layers(const dpc_cascade *c, const density_map *map, dpc_isa isa, unsigned threads, size_t m,
                             float *x) {
    uint32_t G_max = 1;
    for (uint32_t l = 0; l < c->n_layers; l++) {
        const uint32_t G = grid_size(m, c->layers[l].radius[0]);
        if (G > G_max) G_max = G;
    }
    const size_t max_cells = (size_t)G_max * G_max;
    /* leaves: at most one per cell not cut, k^2 <= n / 4 + 1 for a cut one (n > SPLIT_MIN) */
    const size_t max_leaves = max_cells + m / 4 + 1;
    if (m < PARALLEL_MIN_POINTS || threads < 1) threads = 1;
    if (threads > DPC_MAX_THREADS) threads = DPC_MAX_THREADS;
    workspace w;
    int ok = 1;
    for (int k = 0; k < 2; k++) {
        w.x[k] = (float *)calloc(m + 16, sizeof(float)); /* + 16: append() reads whole vectors */
        w.y[k] = (float *)calloc(m + 16, sizeof(float));
        w.h[k] = (float *)malloc(m * sizeof(float));
        w.id[k] = (uint32_t *)malloc(m * sizeof(uint32_t));
        ok = ok && w.x[k] && w.y[k] && w.h[k] && w.id[k];
    }
    w.a = (float *)calloc(m + 16, sizeof(float));
    w.delta = (float *)malloc(2 * m * sizeof(float));
    w.scratch = (float *)calloc((size_t)threads * SLOT_FLOATS, sizeof(float));
    w.cell = (uint32_t *)malloc(m * sizeof(uint32_t));
    w.perm = (uint32_t *)malloc(m * sizeof(uint32_t));
    w.start = (uint32_t *)calloc(max_cells + 1, sizeof(uint32_t));
    w.hmax = (float *)malloc(max_cells * sizeof(float));
    w.hmin = (float *)malloc(max_cells * sizeof(float));
    w.kdiv = (uint32_t *)malloc(max_cells * sizeof(uint32_t));
    w.leaf_off = (uint32_t *)malloc((max_cells + 1) * sizeof(uint32_t));
    w.leaf_start = (uint32_t *)malloc((max_leaves + 1) * sizeof(uint32_t));
    w.leaf_hmax = (float *)malloc(max_leaves * sizeof(float));
    w.leaf_hmin = (float *)malloc(max_leaves * sizeof(float));
    if (!ok || !w.a || !w.delta || !w.scratch || !w.cell || !w.perm || !w.start || !w.hmax || !w.hmin || !w.kdiv ||
        !w.leaf_off || !w.leaf_start || !w.leaf_hmax || !w.leaf_hmin) {
        workspace_free(&w);
        return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for %zu points", m);
    }
    /* The points stay in the order of the last sort (each sort stable), so that a step's density
     * look-up and the next sort walk the plane cell by cell; the caller's order comes back at
     * the end. */
    float *px = w.x[0], *py = w.y[0], *ph = w.h[0];
    uint32_t *pid = w.id[0];
    for (size_t i = 0; i < m; i++) {
        px[i] = x[2 * i];
        py[i] = x[2 * i + 1];
        ph[i] = cell_h(map, px[i], py[i]);
        pid[i] = (uint32_t)i;
    }
    for (uint32_t l = 0; l < c->n_layers; l++) {
        const dpc_layer *L = &c->layers[l];
        const uint32_t G = grid_size(m, L->radius[0]);
        const size_t cells = (size_t)G * G;
        float *sx = w.x[(l + 1) & 1], *sy = w.y[(l + 1) & 1], *sh = w.h[(l + 1) & 1];
        uint32_t *sid = w.id[(l + 1) & 1];
        /* the points' grid cells; a stable counting sort by cell */
        memset(w.hmax, 0, cells * sizeof(float));
        for (size_t c2 = 0; c2 < cells; c2++) w.hmin[c2] = INFINITY;
        for (size_t i = 0; i < m; i++) {
            const uint32_t cell = cell_of(py[i], G) * G + cell_of(px[i], G);
            w.cell[i] = cell;
            if (ph[i] > w.hmax[cell]) w.hmax[cell] = ph[i];
            if (ph[i] < w.hmin[cell]) w.hmin[cell] = ph[i];
        }
        dpc_grid_sort(w.cell, m, cells, w.start, w.perm);
        for (size_t s = 0; s < m; s++) {
            const uint32_t i = w.perm[s];
            sx[s] = px[i];
            sy[s] = py[i];
            sh[s] = ph[i];
            sid[s] = pid[i];
        }
        make_leaves(&w, G, m, sx, sy, sh, sid, px, py, ph, pid);
        for (size_t i = 0; i < m; i++) w.a[i] = 1.0f / sh[i];
        layer_pass p;
        p.sx = sx;
        p.sy = sy;
        p.sa = w.a;
        p.sh = sh;
        p.start = w.start;
        p.hmax = w.hmax;
        p.hmin = w.hmin;
        p.kdiv = w.kdiv;
        p.leaf_off = w.leaf_off;
        p.leaf_start = w.leaf_start;
        p.leaf_hmax = w.leaf_hmax;
        p.leaf_hmin = w.leaf_hmin;
        p.map = map;
        p.G = G;
        p.n_leaves = w.leaf_off[cells];
        p.rho = L->radius[0];
        p.h_max = map->h_max;
        p.glide = (float)fmin(GLIDE / sqrt((double)m), 0.25);
        p.job.w = L->kernels;
        p.job.dw = L->slopes;
        p.job.umax = (float)(L->bins - 1);
        p.job.c2 = p.job.umax / p.rho * 0.5f;
        const float cut = L->eps * (p.job.umax / p.rho);
        p.job.cut2 = cut * cut;
        p.job.umax2 = p.job.umax * p.job.umax;
        p.job.smin2 = 4.0f * p.job.umax2; /* d < 1/2 */
        p.job.qmax = (int32_t)L->bins - 2;
        p.kernel = pick_kernel(isa);
        p.scratch = w.scratch;
        p.delta = w.delta;
        dpc_parallel_ranges(threads, m, layer_range, &p);
        for (size_t i = 0; i < m; i++) {
            const float nx = reflect(sx[i] + w.delta[2 * i]);
            const float ny = reflect(sy[i] + w.delta[2 * i + 1]);
            if (nx != nx || ny != ny) continue; /* the step is not taken */
            const float h = cell_h(map, nx, ny);
            /* nor across a wall: into a cell whose density differs more than WALL times (a cell of
             * zero density among them), so strong edges keep their counts */
            if (!dpc_wall_compatible(sh[i], h)) continue;
            sx[i] = nx;
            sy[i] = ny;
            sh[i] = h;
        }
        px = sx, py = sy, ph = sh, pid = sid;
    }
    for (size_t i = 0; i < m; i++) {
        x[2 * (size_t)pid[i]] = px[i];
        x[2 * (size_t)pid[i] + 1] = py[i];
    }
    workspace_free(&w);
    return DPC_OK;
}

dpc_status dpc_density_generate(const dpc_model *model, const float *density, uint32_t width, uint32_t height,
                                uint64_t seed, size_t m, float *out) {
    const dpc_cascade *c = &model->cascade;
    density_map map;
    dpc_status st = map_init(&map, density, width, height, m);
    if (st != DPC_OK) return st;
    dpc_input_fill(c, model->input, seed, m, out);
    for (size_t i = 0; i < m; i++) map_point(&map, out + 2 * i);
    st = run_layers(c, &map, model->engine.isa, model->engine.threads, m, out);
    map_free(&map);
    return st;
}
