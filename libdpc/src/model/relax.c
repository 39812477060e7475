/* The prefix relaxation of docs/model-format.md §6.1 (relax.h).
 *
 * The force on point i sums over the prefixes P (base * 2^j < m points, and all m) and the
 * pairs (i, j) of each: d max(0, G(d) - G(R_P)), d = x_i - x_j (toroidal),
 * G(d) = exp(-|d|^2 / (2 s_P^2)), s_P = 0.85 / sqrt(|P|) (0.60 / sqrt(m) for all m), support
 * R_P = min(3.5 s_P, 1/2): minus the gradient of the Gaussian energy of blue noise at the prefix's own
 * scale, cut to go to 0 continuously at R_P (so that the result depends continuously on the
 * input: a hard cut-off made 1e-7 changes of the input grow to 1e-3 in 1,600 steps), and at most
 * 1/2 so that it vanishes where the torus's nearest image flips (times s_P^2: every prefix
 * pushes at its own scale). Plus minus the gradient of
 *   0.05 * sum_q |c_q(P)|^2 / (|q|^2 |P|),  c_q(P) = sum_{i in P} exp(2 pi i q.x_i),
 * over the integer q of a half-plane with 0 < |q| <= min(8, sqrt(|P|) / 4): the torus-scale
 * imbalance a smooth integrand sees. A pair feels every prefix that holds both its points, so
 * early points keep apart at the coarse scales and late ones only at the full set's. Step t of S
 * moves every point by 0.1 (1 - 0.8 t / S) times the force.
 *
 * Pairs come from a cell grid per prefix, every DPC_RELAX_REFRESH steps, within R_P + 0.4 s_P
 * (points move far less than 0.4 s_P in that time). The low-frequency force of point i is
 * one sum over q of Im(conj(A_q) exp(2 pi i q.x_i)) q / |q|^2, A_q being the weighted c_q of the
 * prefixes holding i: the c_q of every prefix come from one pass in point order. Everything
 * runs on a double copy of the points, written back (as float32) only when all steps are done. */
#include "model/relax.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/detmath.h"
#include "common/error.h"
#include "common/threads.h"

#define WIDTH 0.85      /* s_P sqrt(|P|) of a proper prefix */
#define WIDTH_FULL 0.60 /* ... of the whole set */
#define STEP 0.1
#define DECAY 0.2          /* the last step is this fraction of the first */
#define LOW_WEIGHT 0.05    /* of the low-frequency term */
#define LOW_RADIUS 8.0     /* its largest |q| */
#define SUPPORT 3.5        /* the pair term's support, in widths (at most 1/2) */
#define MARGIN 0.4         /* the neighbour search's reach beyond it, in widths */
#define MAX_PREFIXES 40    /* base * 2^j <= 2^32 */
#define MAX_LOW 8          /* integer part of LOW_RADIUS */
#define MAX_FREQS (17 * 9) /* a in -8..8, b in 0..8 */
/* The work of a step is cut into CHUNKS fixed parts (of every prefix's pairs, of the points),
 * each summed in its own order and the parts added in chunk order: the same bits whatever the
 * number of threads that run them. */
#define CHUNKS 8
#define THREADED_POINTS 2048 /* fewer points: one thread (a fork-join per phase costs more) */

typedef struct prefix {
    size_t n;
    double two_w2;   /* 2 s_P^2 */
    double support2; /* R_P^2 */
    double cut;      /* G(R_P), subtracted: the force goes to 0 at R_P */
    double reach;    /* neighbour search radius */
    double weight;   /* LOW_WEIGHT * 4 pi / |P| */
    double radius2;  /* its largest |q|^2 (0: no low frequencies) */
    uint32_t *pairs; /* [n_pairs][2] */
    size_t n_pairs, cap;
} prefix;

typedef struct relax {
    size_t m;
    double *x;    /* [m][2] */
    double *part; /* [CHUNKS][m][2]: each chunk's pair forces */
    double *csum; /* [CHUNKS][n_prefix][2][n_freq]: each chunk's points' share of every prefix's c_q */
    double eta;   /* this step's size */
    unsigned threads;
    size_t n_prefix;
    prefix p[MAX_PREFIXES];
    int low;                 /* the largest integer |q| component of any prefix (0: none) */
    size_t n_freq;           /* q = (a, b) of a half-plane, |q| <= the largest radius: rows b = 0 .. low */
    size_t row[MAX_LOW + 2]; /* row b: frequencies row[b] .. row[b + 1], a increasing from a_first[b] */
    int a_first[MAX_LOW + 1];
    double q2[MAX_FREQS], newton_a[MAX_FREQS], newton_b[MAX_FREQS]; /* |q|^2, q / |q|^2 */
    double *c;                          /* [n_prefix][2][n_freq]: re, im of c_q of each prefix, then the weighted A_q */
    uint32_t *cell_start, *cell_points; /* the grid of one search */
} relax;

/* x_i - x_j on the torus, in [-1/2, 1/2] */
static double wrap(double d) { return d > 0.5 ? d - 1.0 : d < -0.5 ? d + 1.0 : d; }

static int add_pair(prefix *P, uint32_t i, uint32_t j) {
    if (P->n_pairs == P->cap) {
        const size_t cap = P->cap ? 2 * P->cap : 1024;
        uint32_t *grown = (uint32_t *)realloc(P->pairs, cap * 2 * sizeof *grown);
        if (!grown) return 0;
        P->pairs = grown;
        P->cap = cap;
    }
    P->pairs[2 * P->n_pairs] = i;
    P->pairs[2 * P->n_pairs + 1] = j;
    P->n_pairs++;
    return 1;
}

static int close_enough(const double *x, uint32_t i, uint32_t j, double reach2) {
    const double dx = wrap(x[2 * i] - x[2 * j]), dy = wrap(x[2 * i + 1] - x[2 * j + 1]);
    return dx * dx + dy * dy <= reach2;
}

/* The cell of point p in a grid of G x G cells over [0, 1)^2, row-major. */
static size_t cell_of(const double *p, size_t G) {
    size_t cx = (size_t)(p[0] * (double)G), cy = (size_t)(p[1] * (double)G);
    cx = cx < G ? cx : G - 1;
    cy = cy < G ? cy : G - 1;
    return cy * G + cx;
}

/* The pairs i < j < n within reach: from a grid of G x G cells of side >= reach, each point
 * against its 3 x 3 cells (G >= 3, so no cell is visited twice), or all pairs for G < 3. */
static int search(relax *R, prefix *P) {
    const double *x = R->x;
    const double reach2 = P->reach * P->reach;
    const size_t n = P->n;
    P->n_pairs = 0;
    size_t G = (size_t)floor(1.0 / (P->reach * (1.0 + 1e-9))); /* the margin: cells a rounding wider */
    const size_t most = (size_t)floor(sqrt((double)n)) + 1;    /* about one point per cell at most */
    if (G > most) G = most;
    if (G < 3) {
        for (uint32_t i = 0; i < n; i++)
            for (uint32_t j = i + 1; j < n; j++)
                if (close_enough(x, i, j, reach2) && !add_pair(P, i, j)) return 0;
        return 1;
    }
    uint32_t *start = R->cell_start, *pts = R->cell_points;
    memset(start, 0, (G * G + 1) * sizeof *start);
    for (size_t i = 0; i < n; i++) start[cell_of(x + 2 * i, G) + 1]++; /* counting sort, stable */
    for (size_t k = 0; k < G * G; k++) start[k + 1] += start[k];
    for (size_t i = 0; i < n; i++) pts[start[cell_of(x + 2 * i, G)]++] = (uint32_t)i;
    for (size_t k = G * G; k > 0; k--) start[k] = start[k - 1]; /* back to the cells' starts */
    start[0] = 0;
    for (uint32_t i = 0; i < n; i++) {
        const size_t c = cell_of(x + 2 * i, G), cx = c % G, cy = c / G;
        for (size_t oy = 0; oy < 3; oy++)
            for (size_t ox = 0; ox < 3; ox++) {
                const size_t cell = ((cy + G + oy - 1) % G) * G + (cx + G + ox - 1) % G;
                for (uint32_t k = start[cell]; k < start[cell + 1]; k++) {
                    const uint32_t j = pts[k];
                    if (j > i && close_enough(x, i, j, reach2) && !add_pair(P, i, j)) return 0;
                }
            }
    }
    return 1;
}

/* Chunk c's share of one prefix's pair forces: a push along x_i - x_j, weighted by the pair's
 * cut Gaussian, into the chunk's own buffer f. */
static void pair_forces(const relax *R, const prefix *P, size_t c, double *f) {
    const double *x = R->x;
    const size_t lo = P->n_pairs * c / CHUNKS, hi = P->n_pairs * (c + 1) / CHUNKS;
    for (size_t k = lo; k < hi; k++) {
        const uint32_t i = P->pairs[2 * k], j = P->pairs[2 * k + 1];
        const double dx = wrap(x[2 * i] - x[2 * j]), dy = wrap(x[2 * i + 1] - x[2 * j + 1]);
        const double d2 = dx * dx + dy * dy;
        if (!(d2 < P->support2)) continue; /* beyond the support: no force */
        const double g = dpc_exp_neg(-d2 / P->two_w2) - P->cut;
        if (!(g > 0.0)) continue; /* just inside R_P, rounded: max(0, .) */
        f[2 * i] += dx * g;
        f[2 * i + 1] += dy * g;
        f[2 * j] -= dx * g;
        f[2 * j + 1] -= dy * g;
    }
}

/* exp(2 pi i q.x) of a point for every q (re, im), from the powers of exp(2 pi i x_d): row by
 * row, contiguous in a (the compiler's vectors compute each lane as the scalar code would). */
static void waves(const relax *R, const double *xi, double *e_re, double *e_im) {
    double pr[2 * MAX_LOW + 1], pi[2 * MAX_LOW + 1]; /* exp(2 pi i a x_0), a = -low .. low */
    dpc_cplx py[MAX_LOW + 1];
    const int L = R->low;
    const dpc_cplx x1 = dpc_turn(xi[0]);
    dpc_cplx px = {1.0, 0.0};
    py[0] = (dpc_cplx){1.0, 0.0};
    py[1] = dpc_turn(xi[1]);
    for (int a = 0; a <= L; a++) {
        pr[L + a] = pr[L - a] = px.re;
        pi[L + a] = px.im;
        pi[L - a] = -px.im;
        px = dpc_cmul(px, x1);
        if (a >= 1 && a < L) py[a + 1] = dpc_cmul(py[a], py[1]);
    }
    for (int b = 0; b <= L; b++) {
        const size_t f0 = R->row[b], count = R->row[b + 1] - f0;
        const double *ar = pr + L + R->a_first[b], *ai = pi + L + R->a_first[b];
        const double br = py[b].re, bi = py[b].im;
        for (size_t k = 0; k < count; k++) {
            e_re[f0 + k] = ar[k] * br - ai[k] * bi;
            e_im[f0 + k] = ar[k] * bi + ai[k] * br;
        }
    }
}

/* Phase A of a step, chunk c: its share of every prefix's pair forces, and its points' share of
 * every prefix's c_q (the running sum in point order, kept at each prefix's end). */
static void phase_a(relax *R, size_t c) {
    const size_t m = R->m, F = R->n_freq;
    double *f = R->part + c * 2 * m;
    memset(f, 0, 2 * m * sizeof *f);
    for (size_t q = 0; q < R->n_prefix; q++) pair_forces(R, &R->p[q], c, f);
    if (!F) return;
    double e_re[MAX_FREQS], e_im[MAX_FREQS], sum_re[MAX_FREQS] = {0}, sum_im[MAX_FREQS] = {0};
    double *out = R->csum + c * R->n_prefix * 2 * F;
    const size_t lo = m * c / CHUNKS, hi = m * (c + 1) / CHUNKS;
    size_t p = 0;
    for (; p < R->n_prefix && R->p[p].n <= lo; p++) /* prefixes that end before the chunk: no share */
        memset(out + p * 2 * F, 0, 2 * F * sizeof *out);
    for (size_t i = lo; i < hi; i++) {
        waves(R, R->x + 2 * i, e_re, e_im);
        for (size_t k = 0; k < F; k++) {
            sum_re[k] += e_re[k];
            sum_im[k] += e_im[k];
        }
        for (; p < R->n_prefix && R->p[p].n == i + 1; p++) {
            memcpy(out + p * 2 * F, sum_re, F * sizeof *sum_re);
            memcpy(out + p * 2 * F + F, sum_im, F * sizeof *sum_im);
        }
    }
    for (; p < R->n_prefix; p++) { /* prefixes that end after the chunk: all of it */
        memcpy(out + p * 2 * F, sum_re, F * sizeof *sum_re);
        memcpy(out + p * 2 * F + F, sum_im, F * sizeof *sum_im);
    }
}

/* Between the phases: c_q of every prefix (the chunks' shares in chunk order), then A_q of the
 * points of prefix p's level: the weighted c_q of p and of every larger prefix. */
static void weigh(relax *R) {
    const size_t F = R->n_freq, stride = R->n_prefix * 2 * F;
    for (size_t k = 0; k < stride; k++) {
        double v = 0.0;
        for (size_t c = 0; c < CHUNKS; c++) v += R->csum[c * stride + k];
        R->c[k] = v;
    }
    for (size_t q = R->n_prefix; q-- > 0;) {
        const prefix *P = &R->p[q];
        double *re = R->c + 2 * q * F, *im = re + F;
        for (size_t f = 0; f < F; f++) {
            double ar = 0.0, ai = 0.0;
            if (R->q2[f] <= P->radius2) {
                ar = P->weight * re[f];
                ai = P->weight * im[f];
            }
            if (q + 1 < R->n_prefix) {
                ar += re[2 * F + f];
                ai += im[2 * F + f];
            }
            re[f] = ar;
            im[f] = ai;
        }
    }
}

/* Phase B of a step, chunk c's points: the pair forces of every chunk (in chunk order), the
 * low-frequency force, the move. Point i's force reads only x_i, so it moves at once. */
static void phase_b(relax *R, size_t c) {
    const size_t m = R->m, F = R->n_freq;
    const size_t lo = m * c / CHUNKS, hi = m * (c + 1) / CHUNKS;
    double e_re[MAX_FREQS], e_im[MAX_FREQS], s[MAX_FREQS];
    size_t p = 0;
    for (size_t i = lo; i < hi; i++) {
        double fa = 0.0, fb = 0.0;
        for (size_t k = 0; k < CHUNKS; k++) {
            fa += R->part[(k * m + i) * 2];
            fb += R->part[(k * m + i) * 2 + 1];
        }
        if (F) {
            while (R->p[p].n <= i) p++;
            const double *Ar = R->c + 2 * p * F, *Ai = Ar + F;
            waves(R, R->x + 2 * i, e_re, e_im);
            for (size_t f = 0; f < F; f++) s[f] = Ar[f] * e_im[f] - Ai[f] * e_re[f]; /* Im(conj(A_q) e_q) */
            double la = 0.0, lb = 0.0;
            for (size_t f = 0; f < F; f++) {
                la += s[f] * R->newton_a[f];
                lb += s[f] * R->newton_b[f];
            }
            fa += la;
            fb += lb;
        }
        for (int d = 0; d < 2; d++) {
            double v = R->x[2 * i + d] + R->eta * (d ? fb : fa);
            v -= floor(v);
            R->x[2 * i + d] = v < 1.0 ? v : 0.0; /* a tiny negative v rounds up to 1: the torus's 0 */
        }
    }
}

typedef struct phase_job {
    relax *R;
    void (*run)(relax *, size_t);
    unsigned workers;
} phase_job;

static void phase_worker(void *ctx, unsigned slot) {
    const phase_job *j = (const phase_job *)ctx;
    for (size_t c = slot; c < CHUNKS; c += j->workers) j->run(j->R, c);
}

static void phase(relax *R, void (*run)(relax *, size_t)) {
    phase_job j = {R, run, R->threads};
    if (R->threads <= 1) {
        for (size_t c = 0; c < CHUNKS; c++) run(R, c);
        return;
    }
    dpc_run_workers(R->threads, phase_worker, &j);
}

static void relax_free(relax *R) {
    for (size_t q = 0; q < R->n_prefix; q++) free(R->p[q].pairs);
    free(R->x);
    free(R->part);
    free(R->csum);
    free(R->c);
    free(R->cell_start);
    free(R->cell_points);
}

dpc_status dpc_relax_points(float *x, size_t m, uint32_t base, uint32_t steps, unsigned threads, dpc_relax_hook hook,
                            void *ctx) {
    if (m < 2 || !steps) return DPC_OK;
    if (!base) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "the relaxation's base must be positive");
    relax R;
    memset(&R, 0, sizeof R);
    R.m = m;
    R.threads = m < THREADED_POINTS ? 1 : threads < CHUNKS ? threads : CHUNKS;
    for (size_t n = base; n < m; n *= 2) { /* the proper prefixes, then the whole set */
        R.p[R.n_prefix++].n = n;
        if (n > SIZE_MAX / 2 || R.n_prefix == MAX_PREFIXES - 1) break;
    }
    R.p[R.n_prefix++].n = m;
    double largest = 0.0;
    for (size_t q = 0; q < R.n_prefix; q++) {
        prefix *P = &R.p[q];
        const double w = (P->n == m ? WIDTH_FULL : WIDTH) / sqrt((double)P->n);
        P->two_w2 = 2.0 * (w * w);
        const double support = SUPPORT * w < 0.5 ? SUPPORT * w : 0.5;
        P->support2 = support * support;
        P->cut = dpc_exp_neg(-P->support2 / P->two_w2);
        P->reach = support + MARGIN * w < 0.7072 ? support + MARGIN * w : 0.7072; /* 0.7072 > sqrt(2) / 2: all */
        P->weight = LOW_WEIGHT * 4.0 * 3.141592653589793 / (double)P->n;
        double r = sqrt((double)P->n) / 4.0;
        r = r < LOW_RADIUS ? r : LOW_RADIUS;
        P->radius2 = r >= 1.0 ? r * r : 0.0;
        if (r >= 1.0 && (int)r > R.low) R.low = (int)r;
        if (P->radius2 > largest) largest = P->radius2;
    }
    for (int b = 0; b <= R.low; b++) { /* the half-plane b > 0, or b = 0 and a > 0: rows of b */
        R.row[b] = R.n_freq;
        R.a_first[b] = 0;
        for (int a = -R.low; a <= R.low; a++) {
            const double q2 = (double)(a * a + b * b);
            if ((b > 0 || a > 0) && q2 <= largest) {
                if (R.n_freq == R.row[b]) R.a_first[b] = a;
                R.q2[R.n_freq] = q2;
                R.newton_a[R.n_freq] = (double)a / q2;
                R.newton_b[R.n_freq] = (double)b / q2;
                R.n_freq++;
            }
        }
    }
    R.row[R.low + 1] = R.n_freq;
    const size_t cells = (size_t)floor(sqrt((double)m)) + 2;
    R.x = (double *)malloc(2 * m * sizeof *R.x);
    R.part = (double *)malloc(CHUNKS * 2 * m * sizeof *R.part);
    R.csum = (double *)malloc((CHUNKS * 2 * R.n_prefix * R.n_freq + 1) * sizeof *R.csum);
    R.c = (double *)malloc((2 * R.n_prefix * R.n_freq + 1) * sizeof *R.c);
    R.cell_start = (uint32_t *)malloc((cells * cells + 1) * sizeof *R.cell_start);
    R.cell_points = (uint32_t *)malloc(m * sizeof *R.cell_points);
    dpc_status st = DPC_OK;
    if (!R.x || !R.part || !R.csum || !R.c || !R.cell_start || !R.cell_points) {
        st = dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "cannot allocate the relaxation of %zu points", m);
        goto done;
    }
    for (size_t i = 0; i < 2 * m; i++) R.x[i] = (double)x[i];
    for (uint32_t t = 0; t < steps; t++) {
        if (hook && (st = hook(ctx)) != DPC_OK) goto done; /* every step: a large set's step takes tens of ms */
        if (t % DPC_RELAX_REFRESH == 0) {
            for (size_t q = 0; q < R.n_prefix; q++)
                if (!search(&R, &R.p[q])) {
                    st = dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "cannot allocate the relaxation's neighbour pairs");
                    goto done;
                }
        }
        R.eta = STEP * (1.0 - (1.0 - DECAY) * (double)t / (double)steps);
        phase(&R, phase_a);
        weigh(&R);
        phase(&R, phase_b);
    }
    for (size_t i = 0; i < 2 * m; i++) {
        const float y = (float)R.x[i];
        x[i] = y < 1.0f ? y : 0.0f; /* v just below 1 rounds to 1: the torus's 0 */
    }
done:
    relax_free(&R);
    return st;
}
