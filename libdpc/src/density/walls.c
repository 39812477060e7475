/* The walls of a density and the nearest one of a point (walls.h). */
#include "density/walls.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/error.h"

void dpc_walls_free(dpc_walls *w) {
    free(w->seg);
    free(w->side);
    free(w->start);
    free(w->at);
    free(w->span);
    free(w->gap);
    memset(w, 0, sizeof *w);
}

/* Cells with spacings a and b are divided by a wall. */
static int divided(float a, float b) {
    if (a == 0.0f || b == 0.0f) return (a == 0.0f) != (b == 0.0f);
    return !dpc_wall_compatible(a, b);
}

/* The bucket of a coordinate of [0, 1] (1 in the last). */
static uint32_t bucket_of(double v, uint32_t B) {
    if (!(v > 0.0)) return 0;
    const uint32_t b = (uint32_t)(v * (double)B);
    return b < B ? b : B - 1;
}

/* Walk the walls: vertical ones column boundary by column boundary, runs along y merged while
 * both sides keep their spacings; then horizontal ones likewise. emit(i, ...) gets them in order. */
typedef void emit_fn(dpc_walls *w, uint32_t i, double x0, double y0, double x1, double y1, float lo, float hi);

static uint32_t walk(dpc_walls *w, const float *h, uint32_t W, uint32_t H, emit_fn *emit) {
    uint32_t n = 0;
    for (uint32_t c = 0; c + 1 < W; c++) {
        const double x = (double)(c + 1) / (double)W;
        for (uint32_t r = 0; r < H;) {
            const float a = h[(size_t)r * W + c], b = h[(size_t)r * W + c + 1];
            if (!divided(a, b)) {
                r++;
                continue;
            }
            uint32_t e = r + 1;
            while (e < H && h[(size_t)e * W + c] == a && h[(size_t)e * W + c + 1] == b) e++;
            if (emit) emit(w, n, x, (double)r / (double)H, x, (double)e / (double)H, a, b);
            n++;
            r = e;
        }
    }
    for (uint32_t r = 0; r + 1 < H; r++) {
        const double y = (double)(r + 1) / (double)H;
        const float *lo = h + (size_t)r * W, *up = h + (size_t)(r + 1) * W;
        for (uint32_t c = 0; c < W;) {
            if (!divided(lo[c], up[c])) {
                c++;
                continue;
            }
            uint32_t e = c + 1;
            while (e < W && lo[e] == lo[c] && up[e] == up[c]) e++;
            if (emit) emit(w, n, (double)c / (double)W, y, (double)e / (double)W, y, lo[c], up[c]);
            n++;
            c = e;
        }
    }
    return n;
}

static void store(dpc_walls *w, uint32_t i, double x0, double y0, double x1, double y1, float lo, float hi) {
    double *s = w->seg + 4 * (size_t)i;
    s[0] = x0, s[1] = y0, s[2] = x1, s[3] = y1;
    w->side[2 * (size_t)i] = lo;
    w->side[2 * (size_t)i + 1] = hi;
}

/* The buckets a segment touches: a row or a column of them. */
static void seg_buckets(const double *s, uint32_t B, uint32_t *bx0, uint32_t *bx1, uint32_t *by0, uint32_t *by1) {
    *bx0 = bucket_of(s[0], B), *bx1 = bucket_of(s[2], B);
    *by0 = bucket_of(s[1], B), *by1 = bucket_of(s[3], B);
}

/* Every segment into the buckets it touches (a row or a column of them): counted into
 * start[b + 1] when fill is NULL, else its entry stored at at[fill[b]++]. Returns the entries. */
static size_t place(dpc_walls *w, uint32_t B, uint32_t *fill) {
    size_t entries = 0;
    for (uint32_t i = 0; i < w->n; i++) {
        uint32_t bx0, bx1, by0, by1;
        const double *sg = w->seg + 4 * (size_t)i;
        seg_buckets(sg, B, &bx0, &bx1, &by0, &by1);
        const float s0 = w->side[2 * (size_t)i], s1 = w->side[2 * (size_t)i + 1];
        const dpc_wall_entry e = {
            (float)sg[0], (float)sg[1], (float)sg[2], (float)sg[3], s0, s1, s0 * WALL_H, s1 * WALL_H, i};
        for (uint32_t by = by0; by <= by1; by++)
            for (uint32_t bx = bx0; bx <= bx1; bx++) {
                const size_t b = (size_t)by * B + bx;
                if (fill) w->at[fill[b]++] = e;
                else w->start[b + 1]++;
            }
        entries += (size_t)(bx1 - bx0 + 1) * (by1 - by0 + 1);
    }
    return entries;
}

/* The squared distance transform of one line of n samples (f: 0 or INFINITY in, squared distances
 * out, in sample units), by the lower envelope of parabolas (Felzenszwalb and Huttenlocher 2012);
 * v, z: room for n and n + 1. */
static void edt_line(float *f, size_t stride, uint32_t n, float *d, uint32_t *v, float *z) {
    int64_t k = -1;
    for (uint32_t q = 0; q < n; q++) {
        const float fq = f[q * stride];
        if (fq == INFINITY) continue;
        float sq = -INFINITY;
        while (k >= 0) {
            const uint32_t r = v[k];
            sq = ((fq + (float)q * (float)q) - (f[r * stride] + (float)r * (float)r)) / (2.0f * (float)(q - r));
            if (sq > z[k]) break;
            k--;
        }
        k++;
        v[k] = q;
        z[k] = k == 0 ? -INFINITY : sq;
        z[k + 1] = INFINITY;
    }
    if (k < 0) return; /* no sample: all stay infinite */
    k = 0;
    for (uint32_t q = 0; q < n; q++) {
        while (z[k + 1] < (float)q) k++;
        const float t = (float)q - (float)v[k];
        d[q] = t * t + f[v[k] * stride];
    }
    for (uint32_t q = 0; q < n; q++) f[q * stride] = d[q];
}

/* The distance field: E x E cells marked where a segment passes, their Euclidean distance
 * transform between centres, less the diagonal (a point and a wall point each lie within half
 * a diagonal of their cells' centres). */
static int make_gap(dpc_walls *w, uint32_t E) {
    const size_t cells = (size_t)E * E;
    w->gap = (float *)malloc(cells * sizeof(float));
    float *d = (float *)malloc(((size_t)E + 1) * sizeof(float) * 2);
    uint32_t *v = (uint32_t *)malloc(((size_t)E + 1) * sizeof(uint32_t));
    if (!w->gap || !d || !v) {
        free(d), free(v);
        return 0;
    }
    float *g = w->gap;
    for (size_t c = 0; c < cells; c++) g[c] = INFINITY;
    for (uint32_t i = 0; i < w->n; i++) {
        const double *s = w->seg + 4 * (size_t)i;
        const uint32_t x0 = bucket_of(s[0], E), x1 = bucket_of(s[2], E), y0 = bucket_of(s[1], E),
                       y1 = bucket_of(s[3], E);
        for (uint32_t y = y0; y <= y1; y++)
            for (uint32_t x = x0; x <= x1; x++) g[(size_t)y * E + x] = 0.0f;
    }
    for (uint32_t x = 0; x < E; x++) edt_line(g + x, E, E, d, v, d + E + 1);             /* columns */
    for (uint32_t y = 0; y < E; y++) edt_line(g + (size_t)y * E, 1, E, d, v, d + E + 1); /* rows */
    const float diag = sqrtf(2.0f);
    for (size_t c = 0; c < cells; c++) {
        const float r = g[c] == INFINITY ? INFINITY : sqrtf(g[c]) - diag;
        g[c] = r > 0.0f ? r / (float)E * (1.0f - 1e-6f) : 0.0f; /* a little low: a bound */
    }
    free(d), free(v);
    w->E = E;
    return 1;
}

dpc_status dpc_walls_init(dpc_walls *w, const float *h, uint32_t W, uint32_t H, uint32_t B, uint32_t E) {
    memset(w, 0, sizeof *w);
    const uint32_t n = walk(w, h, W, H, NULL);
    if (n == 0) return DPC_OK;
    if (n <= DPC_WALLS_FEW) B = 1; /* a few segments: one bucket, scanned whole */
    w->B = B;
    w->seg = (double *)malloc((size_t)n * 4 * sizeof(double));
    w->side = (float *)malloc((size_t)n * 2 * sizeof(float));
    w->start = (uint32_t *)calloc((size_t)B * B + 1, sizeof(uint32_t));
    if (!w->seg || !w->side || !w->start) goto oom;
    w->n = n;
    walk(w, h, W, H, store);
    const size_t entries = place(w, B, NULL); /* counts, then starts */
    if (entries > UINT32_MAX) goto oom;
    for (size_t b = 0; b < (size_t)B * B; b++) w->start[b + 1] += w->start[b];
    w->at = (dpc_wall_entry *)malloc((entries ? entries : 1) * sizeof(dpc_wall_entry));
    uint32_t *fill = (uint32_t *)malloc((size_t)B * B * sizeof(uint32_t));
    if (!w->at || !fill) {
        free(fill);
        goto oom;
    }
    memcpy(fill, w->start, (size_t)B * B * sizeof(uint32_t));
    place(w, B, fill);
    free(fill);
    w->span = (float *)malloc((size_t)B * B * 2 * sizeof(float));
    if (!w->span) goto oom;
    for (size_t b = 0; b < (size_t)B * B; b++) {
        float lo = INFINITY, hi = 0.0f;
        for (uint32_t k = w->start[b]; k < w->start[b + 1]; k++) {
            const float s0 = w->at[k].s0, s1 = w->at[k].s1;
            const float s_min = s0 == 0.0f ? s1 : s1 == 0.0f ? s0 : s0 < s1 ? s0 : s1;
            const float s_max = s0 > s1 ? s0 : s1;
            /* h sees a side s when s / WALL_H <= h <= s WALL_H (a margin of 2^-20 for rounding) */
            const float a = s_min / WALL_H * (1.0f - 0x1p-20f), c = s_max * WALL_H * (1.0f + 0x1p-20f);
            lo = a < lo ? a : lo;
            hi = c > hi ? c : hi;
        }
        w->span[2 * b] = lo, w->span[2 * b + 1] = hi;
    }
    if (!make_gap(w, E)) goto oom;
    return DPC_OK;
oom:
    dpc_walls_free(w);
    return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for the walls of a %u x %u density", W, H);
}

/* The nearest point of bucket b's walls of spacing h (hw = h WALL_H) closer than sqrt(*best):
 * updates *best, *found and (*fx, *fy). A side s is h's own when s > 0, s WALL_H >= h and s <= hw
 * (dpc_wall_compatible); a segment is h's wall when exactly one side is. */
static void scan_bucket(const dpc_walls *w, size_t b, float x, float y, float h, float hw, float *best, int64_t *found,
                        float *fx, float *fy) {
    if (!(h >= w->span[2 * b] && h <= w->span[2 * b + 1])) return;
    for (uint32_t k = w->start[b]; k < w->start[b + 1]; k++) {
        const dpc_wall_entry *e = w->at + k;
        const int own0 = e->s0 > 0.0f && e->s0w >= h && e->s0 <= hw;
        const int own1 = e->s1 > 0.0f && e->s1w >= h && e->s1 <= hw;
        if (own0 == own1) continue;
        const float cx = x < e->x0 ? e->x0 : x > e->x1 ? e->x1 : x; /* the closest point */
        const float cy = y < e->y0 ? e->y0 : y > e->y1 ? e->y1 : y;
        const float d2 = (x - cx) * (x - cx) + (y - cy) * (y - cy);
        if (d2 < *best || (d2 == *best && e->id < *found)) *best = d2, *found = e->id, *fx = cx, *fy = cy;
    }
}

int dpc_walls_nearest(const dpc_walls *w, double x, double y, float h, double R, double *wx, double *wy, double *nx,
                      double *ny, double run[2]) {
    if (w->n == 0) return 0;
    const int64_t B = w->B;
    const int64_t bx = bucket_of(x, w->B), by = bucket_of(y, w->B);
    const int64_t bx0 = bucket_of(x - R, w->B), bx1 = bucket_of(x + R, w->B);
    const int64_t by0 = bucket_of(y - R, w->B), by1 = bucket_of(y + R, w->B);
    /* the point's distance to its bucket's nearest side: ring r >= 1 is at least (r - 1) / B + edge away */
    const double inv_b = 1.0 / (double)B, ex = x - (double)bx * inv_b, ey = y - (double)by * inv_b;
    double edge = ex < inv_b - ex ? ex : inv_b - ex;
    edge = ey < edge ? ey : edge;
    edge = inv_b - ey < edge ? inv_b - ey : edge;
    edge = edge > 0.0 ? edge : 0.0;
    const float xf = (float)x, yf = (float)y, hw = h * WALL_H;
    float best = (float)(R * R), fx = 0.0f, fy = 0.0f;
    int64_t found = -1;
    for (int64_t r = 0;; r++) {
        if (r > 0) {
            const double gap = (double)(r - 1) * inv_b + edge;
            if (gap * gap > (double)best) break; /* (equal: a tie may follow) */
        }
        if (bx - r < bx0 && bx + r > bx1 && by - r < by0 && by + r > by1) break; /* beyond reach */
        for (int64_t qy = by - r; qy <= by + r; qy++) {
            if (qy < by0 || qy > by1) continue;
            const int64_t step = (qy == by - r || qy == by + r) ? 1 : 2 * r; /* the ring only */
            for (int64_t qx = bx - r; qx <= bx + r; qx += step > 0 ? step : 1) {
                if (qx < bx0 || qx > bx1) continue;
                scan_bucket(w, (size_t)qy * (size_t)B + (size_t)qx, xf, yf, h, hw, &best, &found, &fx, &fy);
            }
        }
    }
    if (found < 0) return 0;
    *wx = fx, *wy = fy;
    const double *s = w->seg + 4 * (size_t)found;
    const int vertical = s[0] == s[2];
    if (vertical) run[0] = (double)fy - s[1], run[1] = s[3] - (double)fy;
    else run[0] = (double)fx - s[0], run[1] = s[2] - (double)fx;
    const double d = sqrt((double)best);
    if (d > 0.0) {
        *nx = ((double)xf - fx) / d, *ny = ((double)yf - fy) / d;
    } else { /* on the wall: towards the side of its own spacing */
        const double sgn = dpc_wall_compatible(h, w->side[2 * (size_t)found]) ? -1.0 : 1.0;
        *nx = vertical ? sgn : 0.0;
        *ny = vertical ? 0.0 : sgn;
    }
    return 1;
}
