/* Blue noise that follows a density (density.h states the definition). */
#include "density/density.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/error.h"
#include "common/threads.h"
#include "model/input.h"

#define PARALLEL_MIN_POINTS 2048
#define MAX_GRID 2048u /* cells per axis of the neighbour grid */

typedef struct density_map {
    uint32_t W, H;
    double *row_cdf; /* H + 1: the mass of rows below, total 1 */
    double *col_cdf; /* H * (W + 1): per row, the row's mass left of each cell, total 1 */
    float *h;        /* per cell: the local spacing (m rho)^(-1/2); 0 where rho = 0 */
    float h_max;
} density_map;

static void map_free(density_map *d) {
    free(d->row_cdf);
    free(d->col_cdf);
    free(d->h);
}

/* The cell holding a coordinate: floor(x * n), exact in double for float x and n < 2^29. */
static uint32_t cell_of(float x, uint32_t n) {
    uint32_t c = (uint32_t)((double)x * (double)n);
    return c < n ? c : n - 1;
}

static float cell_h(const density_map *d, float x, float y) {
    return d->h[(size_t)cell_of(y, d->H) * d->W + cell_of(x, d->W)];
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
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "density value %g at cell (%zu, %zu): values must be finite and >= 0",
                            (double)v, i % width, i / width);
        total += (double)v;
    }
    if (!(total > 0.0)) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "density is zero everywhere");
    return DPC_OK;
}

/* The inverse CDF and the per-cell spacing for m points. h is capped so that no radius of the
 * model exceeds half the square (a cell so sparse holds a point or two at most). */
static dpc_status map_init(density_map *d, const dpc_cascade *c, const float *density, uint32_t W, uint32_t H,
                           size_t m) {
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
    double rho_max = 0.0;
    for (uint32_t l = 0; l < c->n_layers; l++)
        if ((double)c->layers[l].radius[0] > rho_max) rho_max = (double)c->layers[l].radius[0];
    const double h_cap = 0.5 / rho_max;
    const double per_cell = (double)W * (double)H / total;
    float h_max = 0.0f;
    for (size_t i = 0; i < (size_t)W * H; i++) {
        const double rho = (double)density[i] * per_cell;
        float h = 0.0f;
        if (rho > 0.0) {
            const double hd = 1.0 / sqrt((double)m * rho);
            h = (float)(hd <= h_cap ? hd : h_cap);
        }
        d->h[i] = h;
        if (h > h_max) h_max = h;
    }
    d->h_max = h_max;
    return DPC_OK;
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

typedef struct layer_pass {
    const density_map *map;
    size_t m;
    const float *x;                /* m x 2, caller order */
    const float *h;                 /* per point: the local spacing */
    const float *sx, *sy, *sa; /* sorted by grid cell: x, y, 1/h */
    const uint32_t *start;          /* G * G + 1 cell starts */
    const float *hmax;              /* per cell: the largest h of its points */
    uint32_t G;
    const float *w, *dw;
    float rho, c2, cut, umax; /* c2 = (b - 1) / (2 rho) */
    int32_t qmax;
    float *delta; /* m x 2 */
} layer_pass;

/* The distance from v to the span [lo, hi] (0 inside). */
static float span_gap(float v, float lo, float hi) {
    return v < lo ? lo - v : v > hi ? v - hi : 0.0f;
}

/* The pair spacing's bound rho h_ij for h_j <= hc (h_ij grows with h_j), with a margin for rounding. */
static float reach(float rho, float hi, float hc) {
    return rho * (2.0f * hi * hc / (hi + hc)) * 1.001f;
}

/* The sum over the candidates of cells [gx0, gx1] x [gy0, gy1] seen through the image
 * x' = ax + bx x, y' = ay + by y, in row-major cell order and sorted order within a cell. A cell
 * none of whose points can reach the query (its nearest edge beyond the reach of its largest h)
 * is passed over: its terms are zero, so the bits are those of scanning it. */
static void scan(const layer_pass *p, float xi, float yi, float hi_, float ai, uint32_t gx0, uint32_t gx1, uint32_t gy0,
                 uint32_t gy1, float ax, float bx, float ay, float by, float *acc) {
    const uint32_t G = p->G;
    const float inv_g = 1.0f / (float)G;
    for (uint32_t gy = gy0; gy <= gy1; gy++) {
        const float ya = ay + by * ((float)gy * inv_g), yb = ay + by * ((float)(gy + 1) * inv_g);
        const float gap_y = span_gap(yi, ya < yb ? ya : yb, ya < yb ? yb : ya);
        for (uint32_t gx = gx0; gx <= gx1; gx++) {
            const size_t cell = (size_t)gy * G + gx;
            const uint32_t lo = p->start[cell], hi = p->start[cell + 1];
            if (lo == hi) continue;
            const float xa = ax + bx * ((float)gx * inv_g), xb = ax + bx * ((float)(gx + 1) * inv_g);
            const float gap_x = span_gap(xi, xa < xb ? xa : xb, xa < xb ? xb : xa);
            const float R = reach(p->rho, hi_, p->hmax[cell]);
            if (gap_x * gap_x + gap_y * gap_y >= R * R) continue;
            const float R2 = R * R;
            for (uint32_t j = lo; j < hi; j++) {
                const float dx = (ax + bx * p->sx[j]) - xi;
                const float dy = (ay + by * p->sy[j]) - yi;
                const float d2 = dx * dx + dy * dy;
                if (!(d2 < R2)) continue;
                const float d = sqrtf(d2);
                const float a = ai + p->sa[j]; /* 2 / h_ij */
                const float u = (d * p->c2) * a;
                if (!(u > p->cut && u < p->umax)) continue;
                int32_t q = (int32_t)u;
                if (q > p->qmax) q = p->qmax;
                const float f = u - (float)q;
                const float g = p->w[q] + f * p->dw[q];
                const float k = (2.0f * g) / (a * d);
                acc[0] += k * dx;
                acc[1] += k * dy;
            }
        }
    }
}

/* The cells [g0, g1] of an axis holding originals in [lo, hi] (clipped to [0, 1]); 0 if none. */
static int cell_span(float lo, float hi, uint32_t G, uint32_t *g0, uint32_t *g1) {
    if (hi < 0.0f || lo > 1.0f || lo > hi) return 0;
    *g0 = lo <= 0.0f ? 0 : cell_of(lo < 1.0f ? lo : nextafterf(1.0f, 0.0f), G);
    *g1 = hi >= 1.0f ? G - 1 : cell_of(hi, G);
    return 1;
}

static void layer_range(void *ctx, unsigned slot, size_t lo, size_t hi) {
    (void)slot;
    const layer_pass *p = (const layer_pass *)ctx;
    for (size_t i = lo; i < hi; i++) {
        const float xi = p->x[2 * i], yi = p->x[2 * i + 1], hi_ = p->h[i], ai = 1.0f / hi_;
        const float R = reach(p->rho, hi_, p->map->h_max);
        float acc[2] = {0.0f, 0.0f};
        /* images per axis: 0 the set, 1 mirrored at 0 (-x), 2 mirrored at 1 (2 - x) */
        for (int iy = 0; iy < 3; iy++) {
            const float ay = iy == 2 ? 2.0f : 0.0f, by = iy ? -1.0f : 1.0f;
            float ylo = yi - R, yhi = yi + R;
            if (iy == 1) ylo = -yi - R, yhi = R - yi;
            if (iy == 2) ylo = 2.0f - yi - R, yhi = 2.0f - yi + R;
            uint32_t gy0, gy1;
            if (!cell_span(ylo, yhi, p->G, &gy0, &gy1)) continue;
            for (int ix = 0; ix < 3; ix++) {
                const float ax = ix == 2 ? 2.0f : 0.0f, bx = ix ? -1.0f : 1.0f;
                float xlo = xi - R, xhi = xi + R;
                if (ix == 1) xlo = -xi - R, xhi = R - xi;
                if (ix == 2) xlo = 2.0f - xi - R, xhi = 2.0f - xi + R;
                uint32_t gx0, gx1;
                if (!cell_span(xlo, xhi, p->G, &gx0, &gx1)) continue;
                scan(p, xi, yi, hi_, ai, gx0, gx1, gy0, gy1, ax, bx, ay, by, acc);
            }
        }
        p->delta[2 * i] = acc[0];
        p->delta[2 * i + 1] = acc[1];
    }
}

/* A coordinate after a step: mirrored at the square's edges; NaN when it stays outside. */
static float reflect(float v) {
    if (v < 0.0f) v = -v;
    else if (v >= 1.0f) v = 2.0f - v;
    return (v >= 0.0f && v < 1.0f) ? v : NAN;
}

typedef struct workspace {
    float *h, *delta, *sx, *sy, *sa, *hmax;
    uint32_t *cell, *start;
} workspace;

static void workspace_free(workspace *w) {
    free(w->h);
    free(w->delta);
    free(w->sx);
    free(w->sy);
    free(w->sa);
    free(w->hmax);
    free(w->cell);
    free(w->start);
}

static dpc_status run_layers(const dpc_cascade *c, const density_map *map, unsigned threads, size_t m, float *x) {
    uint32_t G = (uint32_t)sqrt((double)m / 2.0);
    if (G < 1) G = 1;
    if (G > MAX_GRID) G = MAX_GRID;
    const size_t cells = (size_t)G * G;
    workspace w;
    w.h = (float *)malloc(m * sizeof(float));
    w.delta = (float *)malloc(2 * m * sizeof(float));
    w.sx = (float *)malloc(m * sizeof(float));
    w.sy = (float *)malloc(m * sizeof(float));
    w.sa = (float *)malloc(m * sizeof(float));
    w.cell = (uint32_t *)malloc(m * sizeof(uint32_t));
    w.start = (uint32_t *)calloc(cells + 1, sizeof(uint32_t));
    w.hmax = (float *)malloc(cells * sizeof(float));
    if (!w.h || !w.delta || !w.sx || !w.sy || !w.sa || !w.cell || !w.start || !w.hmax) {
        workspace_free(&w);
        return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for %zu points", m);
    }
    if (m < PARALLEL_MIN_POINTS) threads = 1;
    for (uint32_t l = 0; l < c->n_layers; l++) {
        const dpc_layer *L = &c->layers[l];
        /* the points' spacing and grid cells; a stable counting sort by cell */
        memset(w.start, 0, (cells + 1) * sizeof(uint32_t));
        memset(w.hmax, 0, cells * sizeof(float));
        for (size_t i = 0; i < m; i++) {
            w.h[i] = cell_h(map, x[2 * i], x[2 * i + 1]);
            w.cell[i] = cell_of(x[2 * i + 1], G) * G + cell_of(x[2 * i], G);
            w.start[w.cell[i] + 1]++;
            if (w.h[i] > w.hmax[w.cell[i]]) w.hmax[w.cell[i]] = w.h[i];
        }
        for (size_t k = 0; k < cells; k++) w.start[k + 1] += w.start[k];
        for (size_t i = 0; i < m; i++) {
            const uint32_t at = w.start[w.cell[i]]++;
            w.sx[at] = x[2 * i];
            w.sy[at] = x[2 * i + 1];
            w.sa[at] = 1.0f / w.h[i];
        }
        for (size_t k = cells; k > 0; k--) w.start[k] = w.start[k - 1];
        w.start[0] = 0;
        layer_pass p;
        p.map = map;
        p.m = m;
        p.x = x;
        p.h = w.h;
        p.sx = w.sx;
        p.sy = w.sy;
        p.sa = w.sa;
        p.start = w.start;
        p.hmax = w.hmax;
        p.G = G;
        p.w = L->kernels;
        p.dw = L->slopes;
        p.rho = L->radius[0];
        p.umax = (float)(L->bins - 1);
        p.c2 = p.umax / p.rho * 0.5f;
        p.cut = L->eps * (p.umax / p.rho);
        p.qmax = (int32_t)L->bins - 2;
        p.delta = w.delta;
        dpc_parallel_ranges(threads, m, layer_range, &p);
        for (size_t i = 0; i < m; i++) {
            const float nx = reflect(x[2 * i] + w.delta[2 * i]);
            const float ny = reflect(x[2 * i + 1] + w.delta[2 * i + 1]);
            if (nx != nx || ny != ny || cell_h(map, nx, ny) == 0.0f) continue; /* the step is not taken */
            x[2 * i] = nx;
            x[2 * i + 1] = ny;
        }
    }
    workspace_free(&w);
    return DPC_OK;
}

dpc_status dpc_density_generate(const dpc_model *model, const float *density, uint32_t width, uint32_t height,
                                uint64_t seed, size_t m, float *out) {
    const dpc_cascade *c = &model->cascade;
    density_map map;
    dpc_status st = map_init(&map, c, density, width, height, m);
    if (st != DPC_OK) return st;
    dpc_input_fill(c, model->input, seed, m, out);
    for (size_t i = 0; i < m; i++) map_point(&map, out + 2 * i);
    st = run_layers(c, &map, model->engine.threads, m, out);
    map_free(&map);
    return st;
}
