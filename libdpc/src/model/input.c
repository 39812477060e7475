/* The input generators of docs/model-format.md §5 (input.h). */
#include "model/input.h"

#include <math.h>
#include <string.h>

#include "common/rng.h"

void dpc_input_uniform(uint64_t seed, size_t count, float *out) {
    const uint64_t state0 = dpc_mix64(seed);
    for (size_t c = 0; c < count; c++) out[c] = dpc_uniform_at(state0, c);
}

static uint32_t below(uint64_t state1, uint64_t *counter, uint32_t bound) {
    /* an integer in [0, bound): the high 32 bits of the next stream value, scaled */
    uint64_t z = dpc_mix64(state1 + (++*counter) * DPC_GOLDEN);
    return (uint32_t)(((z >> 32) * (uint64_t)bound) >> 32);
}

static uint32_t word_at(const float *out, size_t i) {
    uint32_t w;
    memcpy(&w, out + i, sizeof w);
    return w;
}

static void set_word(float *out, size_t i, uint32_t w) { memcpy(out + i, &w, sizeof w); }

/* Whether g^n <= m, without overflow. */
static int power_fits(uint64_t g, size_t n, size_t m) {
    uint64_t p = 1;
    for (size_t a = 0; a < n; a++) {
        p *= g;
        if (p > m) return 0;
    }
    return 1;
}

/* The stratified input for m points in n dimensions. The cell lists live in out itself (cell of
 * point i in word i; for n >= 2 the cell permutation in words m .. m + C), so the CPU and Vulkan
 * paths need no allocation. m <= DPC_MAX_POINTS < 2^32. */
void dpc_input_stratified(uint64_t seed, size_t m, size_t n, float *out) {
    uint32_t g = (uint32_t)floor(pow((double)m, 1.0 / (double)n)); /* then exactly: the largest g^n <= m */
    if (g < 1) g = 1;
    while (g > 1 && !power_fits(g, n, m)) g--;
    while (power_fits((uint64_t)g + 1, n, m)) g++;
    uint64_t cells = 1;
    for (size_t a = 0; a < n; a++) cells *= g;
    const size_t base = m / (size_t)cells, extra = m % (size_t)cells;
    const uint64_t state1 = dpc_mix64(seed ^ DPC_STREAM_STRATIFIED);
    uint64_t counter = 0;
    /* every cell `base` times, then `extra` distinct cells (a partial Fisher-Yates shuffle of all
     * cells; extra > 0 implies n >= 2, since g = m in 1-D, so words m .. m + cells are free) */
    for (size_t i = 0; i < base * (size_t)cells; i++) set_word(out, i, (uint32_t)(i % cells));
    if (extra) {
        for (size_t c = 0; c < cells; c++) set_word(out, m + c, (uint32_t)c);
        for (size_t t = 0; t < extra; t++) {
            const size_t j = t + below(state1, &counter, (uint32_t)(cells - t));
            const uint32_t wj = word_at(out, m + j);
            set_word(out, m + j, word_at(out, m + t));
            set_word(out, base * (size_t)cells + t, wj);
            set_word(out, m + t, wj);
        }
    }
    for (size_t i = m - 1; i > 0; i--) { /* random order: any prefix of the set covers the domain */
        const size_t j = below(state1, &counter, (uint32_t)(i + 1));
        const uint32_t wi = word_at(out, i);
        set_word(out, i, word_at(out, j));
        set_word(out, j, wi);
    }
    /* point i = its cell plus the uniform numbers of point i; from the last point down, so
     * point i's coordinates (words i n .. i n + n - 1 >= i) overwrite only cells already read */
    const uint64_t state0 = dpc_mix64(seed);
    const float below_one = 0x1.fffffep-1f;
    for (size_t i = m; i-- > 0;) {
        uint32_t cell = word_at(out, i);
        for (size_t a = 0; a < n; a++) {
            const uint32_t digit = cell % g;
            cell /= g;
            const float u = dpc_uniform_at(state0, i * n + a);
            const float x = (float)(((double)digit + (double)u) / (double)g);
            out[i * n + a] = x < 1.0f ? x : below_one;
        }
    }
}

static void fill_grid(const dpc_cascade *c, size_t m, float *x) {
    for (size_t i = 0; i < m; i++) {
        size_t rest = i;
        for (uint32_t g = 0; g < c->grid_dims; g++) {
            size_t cell = rest % c->grid_shape[g];
            rest /= c->grid_shape[g];
            x[i * c->dims + c->grid_axis[g]] = (float)(((double)cell + 0.5) / c->grid_shape[g]);
        }
    }
}

void dpc_input_fill(const dpc_cascade *c, dpc_input input, uint64_t seed, size_t m, float *x) {
    if (input == DPC_INPUT_STRATIFIED) dpc_input_stratified(seed, m, c->dims, x);
    else dpc_input_uniform(seed, m * c->dims, x);
    fill_grid(c, m, x);
}
