/* The output balance of docs/model-format.md §5.1 (balance.h).
 *
 * c_q = sum_j exp(-2 pi i q.x_j) over the frequencies q of a half-space with 0 < |q| <= k. Moving
 * every point along the gradient of the potential sum_q Re(beta_q exp(2 pi i q.x)) changes c_q by
 * 4 pi^2 |q|^2 m beta_q to first order (the cross terms are sums of exp(2 pi i (q' - q).x) over a
 * set that is already uniform at these scales), so beta_q = -c_q / (4 pi^2 |q|^2 m) cancels it:
 * the step is delta(x_i) = sum_q q Im(c_q exp(2 pi i q.x_i)) / (pi |q|^2 m), a smooth pair filter
 * over the whole torus, sum_j sin(2 pi q.(x_i - x_j)), evaluated through its Fourier series.
 * Three such Newton steps leave |c_q|^2 / m near float32 rounding for a blue-noise set (1e-6 of
 * it for white noise), which moves by about 0.5 % of its mean spacing (a few % at most): its
 * spectrum above the balanced band and its minimum distance stay as they were. */
#include "model/balance.h"

#include <math.h>
#include <stdlib.h>

#include "common/detmath.h"
#include "common/error.h"

uint32_t dpc_balance_radius(uint32_t k, size_t m, size_t n) {
    uint32_t j = 0;
    while (j < k) { /* is (4 (j + 1))^n <= m? */
        const uint64_t b = 4ull * (j + 1);
        uint64_t p = 1;
        size_t d = 0;
        for (; d < n && p <= (uint64_t)m / b; d++) p *= b;
        if (d < n) break;
        j++;
    }
    return j;
}

/* The frequencies: integer vectors with 0 < |q|^2 <= k^2 whose first nonzero component is
 * positive (the other half are their negatives, c_-q = conj(c_q)), depth first in dimension order. */
typedef struct freqs {
    size_t n, count, cap;
    int8_t *q; /* [cap][n] */
    int8_t cur[DPC_MAX_DIMS];
} freqs;

static int enumerate(freqs *f, size_t d, long budget, int nonzero) {
    if (d == f->n) {
        if (!nonzero) return 1;
        if (f->count == f->cap) return 0;
        if (f->q)
            for (size_t e = 0; e < f->n; e++) f->q[f->count * f->n + e] = f->cur[e];
        f->count++;
        return 1;
    }
    long r = 0;
    while ((r + 1) * (r + 1) <= budget) r++;
    for (long v = nonzero ? -r : 0; v <= r; v++) {
        f->cur[d] = (int8_t)v;
        if (!enumerate(f, d + 1, budget - v * v, nonzero || v != 0)) return 0;
    }
    f->cur[d] = 0;
    return 1;
}

size_t dpc_balance_frequencies(uint32_t k, size_t n) {
    if (k > DPC_BALANCE_MAX_K || n == 0 || n > DPC_MAX_DIMS) return 0;
    freqs f = {n, 0, DPC_BALANCE_MAX_FREQS, NULL, {0}};
    return enumerate(&f, 0, (long)k * k, 0) ? f.count : 0;
}

/* exp(2 pi i q.x) from the powers p[d * (k + 1) + a] = exp(2 pi i a x_d). */
static dpc_cplx wave(const dpc_cplx *p, const int8_t *q, size_t n, uint32_t k) {
    dpc_cplx z = {1.0, 0.0};
    for (size_t d = 0; d < n; d++) {
        if (!q[d]) continue;
        dpc_cplx e = p[d * (k + 1) + (size_t)abs(q[d])];
        if (q[d] < 0) e.im = -e.im;
        z = dpc_cmul(z, e);
    }
    return z;
}

static void powers(const float *x, size_t n, uint32_t k, dpc_cplx *p) {
    for (size_t d = 0; d < n; d++) {
        dpc_cplx *row = p + d * (k + 1);
        row[0] = (dpc_cplx){1.0, 0.0};
        if (k) row[1] = dpc_turn((double)x[d]);
        for (uint32_t a = 2; a <= k; a++) row[a] = dpc_cmul(row[a - 1], row[1]);
    }
}

dpc_status dpc_balance_points(float *x, size_t m, size_t n, uint32_t k, size_t first) {
    if (!k || first >= m) return DPC_OK;
    if (k > DPC_BALANCE_MAX_K || n == 0 || n > DPC_MAX_DIMS)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "balance radius %u in %zu dimensions: at most %u in 1..%u", k, n,
                        DPC_BALANCE_MAX_K, DPC_MAX_DIMS);
    freqs f = {n, 0, DPC_BALANCE_MAX_FREQS, NULL, {0}};
    f.q = (int8_t *)malloc(f.cap * n);
    dpc_cplx *c = (dpc_cplx *)malloc(f.cap * sizeof *c);
    double *w = (double *)malloc(f.cap * sizeof *w);
    dpc_cplx *p = (dpc_cplx *)malloc(n * (k + 1) * sizeof *p);
    double *step = (double *)malloc(n * sizeof *step);
    dpc_status st = DPC_OK;
    if (!f.q || !c || !w || !p || !step) {
        st = dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "cannot allocate the balance's frequency tables");
        goto done;
    }
    if (!enumerate(&f, 0, (long)k * k, 0)) {
        st = dpc_fail(DPC_ERROR_LIMIT, "balance radius %u in %zu dimensions holds more than %u frequencies", k, n,
                      DPC_BALANCE_MAX_FREQS);
        goto done;
    }
    for (size_t j = 0; j < f.count; j++) {
        long q2 = 0;
        for (size_t d = 0; d < n; d++) q2 += (long)f.q[j * n + d] * f.q[j * n + d];
        w[j] = 1.0 / (3.141592653589793 * (double)q2 * (double)(m - first));
    }
    const int iterations = first ? DPC_BALANCE_LEVEL_ITERATIONS : DPC_BALANCE_ITERATIONS;
    for (int it = 0; it < iterations; it++) {
        for (size_t j = 0; j < f.count; j++) c[j] = (dpc_cplx){0.0, 0.0};
        for (size_t i = 0; i < m; i++) { /* c_q = sum_i exp(-2 pi i q.x_i), in point order */
            powers(x + i * n, n, k, p);
            for (size_t j = 0; j < f.count; j++) {
                const dpc_cplx z = wave(p, f.q + j * n, n, k);
                c[j].re += z.re;
                c[j].im -= z.im;
            }
        }
        for (size_t i = first; i < m; i++) {
            float *xi = x + i * n;
            powers(xi, n, k, p);
            for (size_t d = 0; d < n; d++) step[d] = 0.0;
            for (size_t j = 0; j < f.count; j++) {
                const dpc_cplx z = wave(p, f.q + j * n, n, k);
                const double a = w[j] * (c[j].re * z.im + c[j].im * z.re); /* w_q Im(c_q z) */
                for (size_t d = 0; d < n; d++)
                    if (f.q[j * n + d]) step[d] += a * (double)f.q[j * n + d];
            }
            for (size_t d = 0; d < n; d++) {
                double v = (double)xi[d] + step[d];
                v -= floor(v);
                const float y = (float)v;
                xi[d] = y < 1.0f ? y : 0.0f; /* v just below 1 rounds to 1: the torus's 0 */
            }
        }
    }
done:
    free(f.q);
    free(c);
    free(w);
    free(p);
    free(step);
    return st;
}
