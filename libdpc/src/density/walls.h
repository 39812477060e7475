/* Walls of a density (density.h): the boundaries between 4-neighbour grid cells whose densities
 * differ more than 4 times (spacings: WALL_H = 2 times) or of which one is zero. A wall stops
 * steps and is a mirror: a point near one sees, besides the points on its side, their images
 * across the nearest wall of its own, as at the square's sides. A point's own walls depend on its
 * spacing h: those with the cell on one side of a spacing within WALL_H of h and on the other
 * side not. */
#ifndef DPC_DENSITY_WALLS_H
#define DPC_DENSITY_WALLS_H

#include <stddef.h>
#include <stdint.h>

#include "dpc/dpc.h"

#define WALL_H 2.0f

/* Spacings h_i and h_j (> 0: a point's own) see each other: neither is more than WALL_H times
 * the other, and h_j is not zero. */
static inline int dpc_wall_compatible(float hi, float hj) {
    return hj > 0.0f && hj * WALL_H >= hi && hj <= hi * WALL_H;
}

/* A segment as a bucket holds it: its box and its sides' spacings (s) and their WALL_H multiples. */
typedef struct dpc_wall_entry {
    float x0, y0, x1, y1;
    float s0, s1, s0w, s1w;
    uint32_t id;
} dpc_wall_entry;

typedef struct dpc_walls {
    uint32_t n;                /* segments (axis-parallel, collinear neighbours with equal sides merged) */
    double *seg;               /* n x 4: x0, y0, x1, y1 (x0 == x1: vertical; y0 == y1: horizontal) */
    float *side;               /* n x 2: the spacing of the cells left of / below it, and right of / above */
    uint32_t B;                /* buckets per axis of the square */
    uint32_t *start;           /* per bucket (row-major, B * B + 1): its entries at[start[b] .. start[b+1]) */
    struct dpc_wall_entry *at; /* a segment's copy per bucket it touches */
    float *span;               /* per bucket: the spacings [lo, hi] its segments can be walls of (lo > hi: none) */
    uint32_t E;                /* cells per axis of the distance field */
    float *gap;                /* E x E: a lower bound of the distance from any point of the cell to any wall */
} dpc_walls;

/* The walls of a W x H grid of spacings h (0: zero density); B buckets per axis (1 for at most
 * DPC_WALLS_FEW segments); E cells per axis of the distance field. */
#define DPC_WALLS_FEW 32u
dpc_status dpc_walls_init(dpc_walls *w, const float *h, uint32_t W, uint32_t H, uint32_t B, uint32_t E);

/* No wall (of any spacing) lies within R of (x, y) in [0,1)^2: known from the distance field. */
static inline int dpc_walls_far(const dpc_walls *w, float x, float y, double R) {
    if (!w->gap) return 0;
    uint32_t cx = (uint32_t)((double)x * w->E), cy = (uint32_t)((double)y * w->E);
    cx = cx < w->E ? cx : w->E - 1;
    cy = cy < w->E ? cy : w->E - 1;
    return (double)w->gap[(size_t)cy * w->E + cx] >= R;
}
void dpc_walls_free(dpc_walls *w);

/* The nearest point of a wall of a point at (x, y) with spacing h (> 0) closer than R: 1 and the
 * point (wx, wy), the unit normal (nx, ny) pointing to the point's side and how far its segment runs
 * on from that point down and up its axis (run[0], run[1]); 0 when there is none.
 * Buckets are searched in square rings around the point's, each row by row, until no closer one
 * can follow; of equally near segments, the first in the walk (vertical ones column by column,
 * then horizontal ones row by row). */
int dpc_walls_nearest(const dpc_walls *w, double x, double y, float h, double R, double *wx, double *wy, double *nx,
                      double *ny, double run[2]);

#endif
