/* The order within a progressive level (level_order.h, docs/model-format.md §6).
 *
 * Two rules pick the level's next point. A quota keeps the picks spread at the coarse scales: the
 * torus is split into a tree of cells (the first two coordinates halved at each depth, one in
 * 1-D) down to cells that hold about LEAF_POINTS or more of the level's points on average, and
 * the pick walks down from the root into the child whose share of the picks lags its share of
 * the level's points most. Within that, the energy fills the emptiest place: a point's energy is
 * the sum of b(d) = (1 - d^2 / R^2)^3 (0 beyond R) over the held points and the picks so far, d
 * the toroidal distance, R = min(2 N^(-1/dims), 1/2) for the N = n + a points the level
 * completes (about two mean spacings); ties between children go to the one holding the least
 * energy, and in the last cell the least energy is picked (ties: the lower index). Without the
 * quota a prefix is spread locally but keeps torus-scale imbalances, which smooth integrands see
 * (docs/progressive.md, "Between the levels").
 *
 * b is a polynomial rather than a Gaussian so that the arithmetic is +, -, *, / on doubles, and
 * the cells are exact binary fractions: the same order on every machine, and the float64
 * reference (tests/python/reference_cascade.py) computes it bit for bit. Each cell of the tree
 * holds the least energy among its points not yet picked; a pick updates the energies within R
 * (found through a grid of cells at least R wide, apart from the tree, whose leaves hold about
 * LEAF_POINTS or more and are wider) and the cells above the touched ones. The order in which a
 * pick visits the points does not matter: each point takes one term per pick, in the picks' order. */
#include "model/level_order.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/error.h"
#include "cpu/cpu_grid.h"

#define REACH 2.0        /* R in mean spacings N^(-1/dims) */
#define LEAF_POINTS 8    /* the quota's finest cells hold at least this many points on average */
#define GRID_SLACK 0.999 /* neighbour cells a little wider than R: no rounding loses a neighbour */
#define NONE UINT32_MAX

typedef struct level {
    uint32_t dims;
    double r2;      /* R^2 */
    unsigned bits;  /* 2: a cell has 4 children (the first two coordinates halved); 1 in 1-D */
    unsigned depth; /* the quota's depth */
    /* by sorted position s (the level's points by leaf, leaves in tree order): */
    uint32_t *pt;   /* the point's index in the level */
    uint32_t *leaf; /* its leaf */
    double *e;
    unsigned char *picked;
    uint32_t *leaf_start; /* [leaves + 1] */
    /* per node (depth t, cell c: node (2^(bits t) - 1) / (2^bits - 1) + c) */
    uint32_t *count, *taken; /* the level's points in the cell; picks so far */
    double *best_e;          /* least energy among its points not picked (best_s = NONE: none left) */
    uint32_t *best_s;
    uint32_t *dirty; /* leaves whose energies changed since their minimum was taken */
    unsigned char *is_dirty;
    size_t n_dirty;
    /* the neighbour search's grid over the first (two) coordinates: G cells per axis, each at
     * least R wide; per cell its points' sorted positions and coordinates (dims floats each) */
    uint32_t G;
    uint32_t *grid_cell_of; /* by sorted position: the point's grid cell */
    uint32_t *grid_start;   /* [G^bits + 1] */
    uint32_t *grid_s;
    float *grid_x;
} level;

/* R^2 for N points: N^(-1/dims) by 64 halvings of [0, 1] (powers by repeated products, so every
 * machine finds the same root), times REACH, squared, at most 1/4. */
static double reach2(size_t count, uint32_t dims) {
    double lo = 0.0, hi = 1.0;
    for (int it = 0; it < 64; it++) {
        const double mid = 0.5 * (lo + hi);
        double p = mid;
        for (uint32_t k = 1; k < dims; k++) p *= mid;
        if (p * (double)count >= 1.0) hi = mid;
        else lo = mid;
    }
    const double r = REACH * hi;
    return r * r < 0.25 ? r * r : 0.25;
}

/* b(|p - q|): the squared toroidal distance summed over the coordinates in order */
static double bump(const level *L, const float *p, const float *q) {
    double d2 = 0.0;
    for (uint32_t k = 0; k < L->dims; k++) {
        double d = (double)p[k] - (double)q[k];
        d = d > 0.5 ? d - 1.0 : d < -0.5 ? d + 1.0 : d;
        d2 = k ? d2 + d * d : d * d;
    }
    if (!(d2 < L->r2)) return 0.0;
    const double t = 1.0 - d2 / L->r2;
    return t * t * t;
}

static size_t node_base(const level *L, unsigned t) {
    return (((size_t)1 << (L->bits * t)) - 1) / ((1u << L->bits) - 1);
}

/* floor(v 2^t), at most 2^t - 1: exact, so every machine puts a point in the same cell */
static size_t axis_cell(float v, unsigned t) {
    const size_t g = (size_t)1 << t, c = (size_t)((double)v * (double)g);
    return c < g ? c : g - 1;
}

/* the cell at depth t of axis cells (cx, cy): coordinate 0's bit above coordinate 1's at each
 * depth, so a cell's children are 4 consecutive cells of the next depth */
static size_t cell_from_xy(const level *L, size_t cx, size_t cy, unsigned t) {
    if (L->bits == 1) return cx;
    size_t code = 0;
    for (unsigned b = 0; b < t; b++) code |= ((cx >> b) & 1u) << (2 * b + 1) | ((cy >> b) & 1u) << (2 * b);
    return code;
}

static size_t cell_of(const level *L, const float *p, unsigned t) {
    return cell_from_xy(L, axis_cell(p[0], t), L->bits == 2 ? axis_cell(p[1], t) : 0, t);
}

/* (e, index) order: the least energy, then the lower index */
static int before(const level *L, double e, uint32_t s, double e2, uint32_t s2) {
    if (s2 == NONE) return s != NONE;
    if (s == NONE) return 0;
    return e < e2 || (e == e2 && L->pt[s] < L->pt[s2]);
}

/* The search grid's cell of v on an axis of g cells: a point two cells away is farther than R. */
static size_t grid_cell(float v, size_t g) {
    const size_t c = (size_t)((double)v * (double)g);
    return c < g ? c : g - 1;
}

/* Add b(p, x) to the energy of every point not yet picked within R of p. Energies only grow, so a
 * leaf's least energy changes only where its least point's grows (or is picked): only that makes
 * the leaf dirty. */
static void spread(level *L, const float *p) {
    const size_t g = L->G, dims = L->dims, leaf0 = node_base(L, L->depth);
    const size_t cx = grid_cell(p[0], g), cy = L->bits == 2 ? grid_cell(p[1], g) : 0;
    const size_t n0 = g < 3 ? g : 3, n1 = L->bits == 2 ? n0 : 1; /* distinct cells per axis */
    for (size_t v = 0; v < n1; v++) {
        const size_t vy = L->bits == 1 ? 0 : g < 3 ? v : (cy + g - 1 + v) % g;
        for (size_t u = 0; u < n0; u++) {
            const size_t ux = g < 3 ? u : (cx + g - 1 + u) % g, cell = vy * g + ux;
            for (uint32_t k = L->grid_start[cell]; k < L->grid_start[cell + 1]; k++) {
                const uint32_t s = L->grid_s[k];
                if (L->picked[s]) continue;
                const double b = bump(L, p, L->grid_x + (size_t)k * dims);
                if (b == 0.0) continue;
                L->e[s] += b;
                const uint32_t f = L->leaf[s];
                if (L->best_s[leaf0 + f] == s && !L->is_dirty[f]) {
                    L->is_dirty[f] = 1;
                    L->dirty[L->n_dirty++] = f;
                }
            }
        }
    }
}

/* A leaf's least energy again, and every cell above it. */
static void refresh(level *L, uint32_t f) {
    const size_t children = (size_t)1 << L->bits;
    size_t node = node_base(L, L->depth) + f;
    double be = 0.0;
    uint32_t bs = NONE;
    for (uint32_t s = L->leaf_start[f]; s < L->leaf_start[f + 1]; s++)
        if (!L->picked[s] && before(L, L->e[s], s, be, bs)) be = L->e[s], bs = s;
    L->best_e[node] = be, L->best_s[node] = bs;
    size_t c = f;
    for (unsigned t = L->depth; t-- > 0;) {
        c /= children;
        node = node_base(L, t) + c;
        const size_t first = node_base(L, t + 1) + c * children;
        be = 0.0, bs = NONE;
        for (size_t j = 0; j < children; j++)
            if (before(L, L->best_e[first + j], L->best_s[first + j], be, bs))
                be = L->best_e[first + j], bs = L->best_s[first + j];
        L->best_e[node] = be, L->best_s[node] = bs;
    }
}

static void refresh_dirty(level *L) {
    for (size_t k = 0; k < L->n_dirty; k++) {
        refresh(L, L->dirty[k]);
        L->is_dirty[L->dirty[k]] = 0;
    }
    L->n_dirty = 0;
}

/* The next pick's sorted position: down the tree by the quota, then the least energy. */
static uint32_t next_pick(const level *L) {
    const size_t children = (size_t)1 << L->bits;
    size_t c = 0;
    for (unsigned t = 1; t <= L->depth; t++) {
        const size_t parent = node_base(L, t - 1) + c, first = node_base(L, t) + c * children;
        size_t best = NONE;
        int64_t best_deficit = 0;
        for (size_t j = 0; j < children; j++) {
            const size_t k = first + j;
            if (L->taken[k] == L->count[k]) continue;
            /* (its share of the picks after this one) - (its picks), times the parent's count */
            const int64_t deficit =
                (int64_t)(L->taken[parent] + 1) * L->count[k] - (int64_t)L->taken[k] * L->count[parent];
            if (best == NONE || deficit > best_deficit ||
                (deficit == best_deficit && before(L, L->best_e[k], L->best_s[k], L->best_e[best], L->best_s[best])))
                best = k, best_deficit = deficit;
        }
        c = best - node_base(L, t);
    }
    return L->best_s[node_base(L, L->depth) + c];
}

/* Cells per axis of the search grid for R^2 = r2: as many as leave each at least R wide (with a
 * margin for the rounding of a point's cell and of its distance), at least 1. */
static uint32_t grid_axis(double r2) {
    const double g = floor(GRID_SLACK / sqrt(r2));
    return g < 1.0 ? 1u : (uint32_t)g;
}

static unsigned depth_for(size_t a, unsigned bits) {
    unsigned d = 0;
    while (((size_t)LEAF_POINTS << (bits * (d + 1))) <= a) d++;
    return d;
}

/* Reorder the level x[n .. n + a) after the held points x[0 .. n), in L's buffers (sized for
 * the largest level) and `sorted` (a * dims floats). */
static void order_level(level *L, float *sorted, float *x, size_t n, size_t a) {
    const uint32_t dims = L->dims;
    float *level_x = x + n * dims;
    L->r2 = reach2(n + a, dims), L->depth = depth_for(a, L->bits), L->G = grid_axis(L->r2);
    const size_t leaves = (size_t)1 << (L->bits * L->depth), nodes = node_base(L, L->depth) + leaves;
    memset(L->e, 0, a * sizeof *L->e);
    memset(L->picked, 0, a);
    memset(L->leaf_start, 0, (leaves + 1) * sizeof *L->leaf_start);
    memset(L->taken, 0, nodes * sizeof *L->taken); /* no leaf is dirty: every level ends with refresh_dirty */
    for (size_t k = 0; k < a; k++) L->leaf_start[cell_of(L, level_x + k * dims, L->depth) + 1]++; /* counting sort */
    for (size_t f = 0; f < leaves; f++) L->leaf_start[f + 1] += L->leaf_start[f];
    for (size_t k = 0; k < a; k++) {
        const size_t f = cell_of(L, level_x + k * dims, L->depth);
        const uint32_t s = L->leaf_start[f]++;
        L->pt[s] = (uint32_t)k, L->leaf[s] = (uint32_t)f;
    }
    for (size_t f = leaves; f > 0; f--) L->leaf_start[f] = L->leaf_start[f - 1]; /* the cursors ran to each end */
    L->leaf_start[0] = 0;
    for (unsigned t = 0; t <= L->depth; t++) /* cell counts: a cell's points are its leaves' */
        for (size_t c = 0; c < ((size_t)1 << (L->bits * t)); c++) {
            const size_t shift = (size_t)L->bits * (L->depth - t);
            L->count[node_base(L, t) + c] = L->leaf_start[(c + 1) << shift] - L->leaf_start[c << shift];
        }
    for (size_t k = 0; k < nodes; k++) L->best_e[k] = 0.0, L->best_s[k] = NONE;
    const size_t g = L->G, grid_cells = L->bits == 2 ? g * g : g; /* the search grid */
    for (uint32_t s = 0; s < a; s++) {
        const float *p = level_x + (size_t)L->pt[s] * dims;
        L->grid_cell_of[s] = (uint32_t)((L->bits == 2 ? grid_cell(p[1], g) * g : 0) + grid_cell(p[0], g));
    }
    dpc_grid_sort(L->grid_cell_of, a, grid_cells, L->grid_start, L->grid_s);
    for (size_t k = 0; k < a; k++)
        memcpy(L->grid_x + k * dims, level_x + (size_t)L->pt[L->grid_s[k]] * dims, dims * sizeof *L->grid_x);
    /* the held points, in index order (no leaf is dirty: best_s is NONE until the refresh) */
    for (size_t j = 0; j < n; j++) spread(L, x + j * dims);
    for (size_t f = 0; f < leaves; f++) refresh(L, (uint32_t)f); /* every leaf, touched or not */
    for (size_t out = 0; out < a; out++) {
        const uint32_t s = next_pick(L);
        L->picked[s] = 1;
        for (unsigned t = 0; t <= L->depth; t++)
            L->taken[node_base(L, t) + (L->leaf[s] >> (L->bits * (L->depth - t)))]++;
        const float *p = level_x + (size_t)L->pt[s] * dims;
        memcpy(sorted + out * dims, p, dims * sizeof *sorted);
        if (!L->is_dirty[L->leaf[s]]) {
            L->is_dirty[L->leaf[s]] = 1;
            L->dirty[L->n_dirty++] = L->leaf[s];
        }
        spread(L, p);
        refresh_dirty(L);
    }
    memcpy(level_x, sorted, a * dims * sizeof *sorted);
}

dpc_status dpc_order_level_points(float *x, size_t m, uint32_t dims, size_t base) {
    size_t largest = dpc_first_level(m, base);
    for (size_t n = largest; n < m; n += dpc_level_size(n, m))
        if (dpc_level_size(n, m) > largest) largest = dpc_level_size(n, m);
    if (largest < 2) return DPC_OK; /* no level to reorder */
    /* buffers for the largest level, all taken before any point moves */
    level L = {.dims = dims, .bits = dims > 1 ? 2 : 1};
    L.depth = depth_for(largest, L.bits);
    const size_t leaves = (size_t)1 << (L.bits * L.depth), nodes = node_base(&L, L.depth) + leaves;
    float *sorted = malloc(largest * dims * sizeof *sorted);
    L.pt = malloc(largest * sizeof *L.pt);
    L.leaf = malloc(largest * sizeof *L.leaf);
    L.e = malloc(largest * sizeof *L.e);
    L.picked = malloc(largest);
    L.leaf_start = malloc((leaves + 1) * sizeof *L.leaf_start);
    L.count = malloc(nodes * sizeof *L.count);
    L.taken = malloc(nodes * sizeof *L.taken);
    L.best_e = malloc(nodes * sizeof *L.best_e);
    L.best_s = malloc(nodes * sizeof *L.best_s);
    L.dirty = malloc(leaves * sizeof *L.dirty);
    L.is_dirty = calloc(leaves, 1);
    const size_t g = grid_axis(reach2(m, dims)), grid_cells = L.bits == 2 ? g * g : g; /* the finest: N = m */
    L.grid_cell_of = malloc(largest * sizeof *L.grid_cell_of);
    L.grid_start = malloc((grid_cells + 1) * sizeof *L.grid_start);
    L.grid_s = malloc(largest * sizeof *L.grid_s);
    L.grid_x = malloc(largest * dims * sizeof *L.grid_x);
    dpc_status st = DPC_OK;
    if (!sorted || !L.pt || !L.leaf || !L.e || !L.picked || !L.leaf_start || !L.count || !L.taken || !L.best_e ||
        !L.best_s || !L.dirty || !L.is_dirty || !L.grid_cell_of || !L.grid_start || !L.grid_s || !L.grid_x)
        st = dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory ordering levels of up to %zu points", largest);
    else {
        size_t n = dpc_first_level(m, base);
        if (n > 1) order_level(&L, sorted, x, 0, n);
        for (size_t a; n < m; n += a)
            if ((a = dpc_level_size(n, m)) > 1) order_level(&L, sorted, x, n, a);
    }
    free(sorted);
    free(L.pt);
    free(L.leaf);
    free(L.e);
    free(L.picked);
    free(L.leaf_start);
    free(L.count);
    free(L.taken);
    free(L.best_e);
    free(L.best_s);
    free(L.dirty);
    free(L.is_dirty);
    free(L.grid_cell_of);
    free(L.grid_start);
    free(L.grid_s);
    free(L.grid_x);
    return st;
}
