/* The toroidal cell grid shared by the inference engine (cpu_cascade.c) and the training
 * kernels (cpu_layer_train.c): points sorted by cell id c_0 + G (c_1 + G (c_2 + ...)), so a row
 * of cells along axis 0 is one contiguous index range (two where it wraps). */
#ifndef DPC_CPU_GRID_H
#define DPC_CPU_GRID_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

/* Stable counting sort of m points by their cell ids cell_of[i] < cells: perm[s] is the point at
 * sorted position s, start[c] the first sorted position of cell c (start has cells + 1 entries,
 * start[cells] = m). Points keep their index order within a cell, so the result is fixed. */
static inline void dpc_grid_sort(const uint32_t *cell_of, size_t m, size_t cells, uint32_t *start, uint32_t *perm) {
    memset(start, 0, (cells + 1) * sizeof(uint32_t));
    for (size_t i = 0; i < m; i++) start[cell_of[i] + 1]++;
    for (size_t c = 0; c < cells; c++) start[c + 1] += start[c];
    /* Place with a moving cursor, then restore the starts (each cursor ends at the next start). */
    for (size_t i = 0; i < m; i++) perm[start[cell_of[i]]++] = (uint32_t)i;
    for (size_t c = cells; c > 0; c--) start[c] = start[c - 1];
    start[0] = 0;
}

/* Candidate index ranges for a point in cell `id` of a k-D grid with G cells per axis: the
 * (2R+1)^(k-1) rows of 2R+1 cells around it, in a fixed order. start[c] is the first sorted
 * index of cell c. Needs 2R+1 <= G (each row wraps at most once) and k <= 8; ranges has room
 * for 2 (2R+1)^(k-1) pairs. Returns the number of non-empty ranges written; *inside (unless
 * NULL) says whether those cells stay inside the grid on every axis, without going round. */
static inline unsigned dpc_grid_ranges(unsigned k, uint32_t G_, uint32_t R_, const uint32_t *start, uint32_t id,
                                       uint32_t *ranges, int *inside) {
    const int32_t G = (int32_t)G_, R = (int32_t)R_;
    int32_t c[8], off[8];
    int in = 1;
    for (unsigned q = 0; q < k; q++) {
        c[q] = (int32_t)(id % (uint32_t)G);
        id /= (uint32_t)G;
        off[q] = -R;
        in &= c[q] >= R && c[q] + R < G;
    }
    if (inside) *inside = in;
    /* Each row's cells along axis 0, as offsets from its start: one span, or two where it goes
     * round (the same for every row). */
    const int32_t lo = c[0] - R, hi = c[0] + R;
    uint32_t a[2], b[2];
    unsigned parts = 1;
    if (lo < 0) {
        a[0] = (uint32_t)(lo + G), b[0] = (uint32_t)G, a[1] = 0, b[1] = (uint32_t)(hi + 1), parts = 2;
    } else if (hi >= G) {
        a[0] = (uint32_t)lo, b[0] = (uint32_t)G, a[1] = 0, b[1] = (uint32_t)(hi - G + 1), parts = 2;
    } else {
        a[0] = (uint32_t)lo, b[0] = (uint32_t)(hi + 1);
    }
    unsigned n = 0;
    for (;;) {
        uint32_t base = 0; /* cell id of (0, c1+o1, c2+o2, ...) */
        for (unsigned q = k; q-- > 1;) {
            int32_t v = c[q] + off[q];
            v += v < 0 ? G : v >= G ? -G : 0;
            base = base * (uint32_t)G + (uint32_t)v;
        }
        base *= (uint32_t)G;
        for (unsigned z = 0; z < parts; z++) { /* written always, kept when not empty: no branch */
            const uint32_t s0 = start[base + a[z]], s1 = start[base + b[z]];
            ranges[2 * n] = s0;
            ranges[2 * n + 1] = s1;
            n += s1 > s0;
        }
        unsigned q = 1; /* odometer over axes 1..k-1 */
        while (q < k && ++off[q] > R) off[q++] = -R;
        if (q >= k) break;
    }
    return n;
}

#endif
