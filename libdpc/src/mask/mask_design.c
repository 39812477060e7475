/* Annealed threshold masks (docs/masks.md, "Annealed masks").
 *
 * A mask is T frames of n x n ranks, each frame a permutation of 0 ... S - 1 (S = n * n). Each
 * frame starts as a void-and-cluster mask; then pairs of ranks within a frame are swapped under
 * a Metropolis rule on the energy
 *   sum over frames f, frequencies q:  w_mask(q) |M_f(q)|^2 + w(q) sum_l kappa_l |B_fl(q)|^2
 *   + sum over pixels p, levels l, temporal frequencies k:  kappa_time_l w_time(k) |C_pl(k)|^2
 *   + sum over q, box corners (i, j):  w(q) joint_kappa_ij |D_ij(q)|^2
 * with M_f the DFT of frame f's ranks, B_fl that of its pattern [rank < threshold_l] at the
 * levels l / 64, C_pl that of pixel p's sequence [rank_f < threshold_l] - threshold_l / S along
 * the frames (k = 0 included: each pixel should fall below each level its share of the frames),
 * and, for a vector mask (its two channels are the two "frames"), D_ij that of the box pattern
 * [rank_0 < corner_i][rank_1 < corner_j] at the corners k / 8. Every term is normalised so that
 * white noise scores 1 per frequency; w(q) = exp(-|q|^2 / 2 sigma^2), sigma = 6 n / 64 cycles
 * per tile.
 *
 * A swap's energy change costs O(frequencies): the level patterns are kept as kappa-weighted
 * prefix sums over levels (per frame, per pixel for the temporal term, per box row for the joint
 * term), and a swap flips exactly the levels between the two ranks.
 *
 * Determinism: plain double operations in a fixed order, the build's -ffp-contract=off, and
 * detmath's exp, sin and cos, so a design is the same bits on every machine and compiler. */
#include "mask/mask_design.h"

#include <stdlib.h>
#include <string.h>

#include "common/detmath.h"
#include "common/error.h"
#include "common/rng.h"

#define SIGMA_Q_AT_64 6.0  /* Gaussian frequency weight, cycles per tile at n = 64 (scales with n) */
#define MASK_WEIGHT 0.5    /* the rank-normalised mask's own spectrum against the levels' */
#define TIME_WEIGHT 2.0    /* each pixel's values along time against the frames' spectra */
#define TIME_SIGMA 0.125   /* sigma of the temporal weight, as a fraction of the frame count */
#define TIME_DC_WEIGHT 2.0 /* extra weight of k = 0 (a pixel's share of frames below each level) */
#define JOINT_WEIGHT 0.1   /* a vector mask's joint box patterns against its channels' spectra */
#define JOINT_LEVELS 8     /* box corners k / 8, k = 1 ... 7 */
#define LEVELS 64          /* thresholds k / 64, k = 1 ... 63 */
#define REACH 8            /* pixels, for the spatial half of the proposals */
#define T_START 0.003      /* temperatures, in units of the mean uphill step at the start */
#define LN_T_END_OVER_T_START (-3.4011973816621555) /* ln(0.0001 / 0.003) */
#define VAC_SIGMA 1.5                               /* void-and-cluster's Gaussian filter, pixels (Ulichney 1993) */
#define VAC_DENSITY 0.1                             /* void-and-cluster's initial share of ones */
#define PROGRESS_EVERY 65536

/* ---- the generator: SplitMix64 ------------------------------------------------------------- */

typedef struct splitmix {
    uint64_t s;
} splitmix;

static uint64_t next_u64(splitmix *r) {
    r->s += DPC_GOLDEN;
    return dpc_mix64(r->s);
}
static double next_uniform(splitmix *r) { return (double)(next_u64(r) >> 11) * 0x1.0p-53; }
static int next_below(splitmix *r, int n) { return (int)(((next_u64(r) >> 32) * (uint64_t)n) >> 32); }

/* Polls of the progress callback during the start (void-and-cluster, the first spectra), which
 * makes no proposals: done = 0, total = the proposals to come (at least 1), after about
 * POLL_WORK inner-loop steps (milliseconds). */
#define POLL_WORK (1ull << 22)
typedef struct poller {
    const dpc_mask_options *o;
    uint64_t total, work;
    int stopped; /* the callback asked to stop: it is not called again */
} poller;

/* Count `work` more steps; whether the callback asked to stop (now or before). */
static int poll_stop(poller *p, uint64_t work) {
    if (!p || !p->o->progress) return 0;
    if (p->stopped) return 1;
    p->work += work;
    if (p->work < POLL_WORK) return 0;
    p->work = 0;
    p->stopped = p->o->progress(p->o->user, 0, p->total) != 0;
    return p->stopped;
}

/* ---- void-and-cluster ----------------------------------------------------------------------- */

typedef struct vac_field {
    int n, radius;
    double *kernel; /* (2 radius + 1)^2 */
    double *e;      /* filtered pattern */
    uint8_t *on;
} vac_field;

static void vac_toggle(vac_field *v, int p, int on) {
    const int n = v->n, r = v->radius, x = p % n, y = p / n, w = 2 * r + 1;
    const double sign = on ? 1.0 : -1.0;
    v->on[p] = (uint8_t)on;
    for (int dy = -r; dy <= r; dy++) {
        double *row = v->e + (size_t)((y + dy + n) % n) * n;
        const double *k = v->kernel + (size_t)(dy + r) * w;
        for (int dx = -r; dx <= r; dx++) row[(x + dx + n) % n] += sign * k[dx + r];
    }
}

/* The 1 with the highest filtered value (want = 1), or the 0 with the lowest (want = 0); the
 * first such pixel on ties. */
static int vac_extreme(const vac_field *v, int want) {
    const int s = v->n * v->n;
    int best = -1;
    for (int p = 0; p < s; p++) {
        if (v->on[p] != want) continue;
        if (best < 0 || (want ? v->e[p] > v->e[best] : v->e[p] < v->e[best])) best = p;
    }
    return best;
}

static dpc_status void_and_cluster(uint32_t size, uint64_t seed, int32_t *ranks, poller *poll) {
    const int n = (int)size, s = n * n;
    int radius = (int)(6.0 * VAC_SIGMA); /* exp(-r^2 / 2 sigma^2) below 1e-7 beyond */
    if (radius > (n - 1) / 2) radius = (n - 1) / 2;
    const int w = 2 * radius + 1;
    vac_field v = {n, radius, NULL, NULL, NULL};
    v.kernel = (double *)malloc(sizeof(double) * (size_t)w * w);
    v.e = (double *)calloc((size_t)s * 2, sizeof(double));
    v.on = (uint8_t *)calloc((size_t)s * 2, 1);
    int *order = (int *)malloc(sizeof(int) * (size_t)s);
    if (!v.kernel || !v.e || !v.on || !order) {
        free(v.kernel), free(v.e), free(v.on), free(order);
        return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for a %u x %u void-and-cluster mask", size, size);
    }
    for (int dy = -radius; dy <= radius; dy++)
        for (int dx = -radius; dx <= radius; dx++)
            v.kernel[(dy + radius) * w + dx + radius] =
                dpc_exp_neg(-(double)(dx * dx + dy * dy) / (2.0 * VAC_SIGMA * VAC_SIGMA));
    int ones = (int)(VAC_DENSITY * s + 0.5);
    if (ones < 1) ones = 1;
    if (ones > s / 2) ones = s / 2;
    /* initial pattern: the first `ones` pixels of a partial Fisher-Yates shuffle */
    splitmix rng = {seed * DPC_STREAM_MASK_START + DPC_STREAM_MASK_START_ADD};
    for (int p = 0; p < s; p++) order[p] = p;
    for (int i = 0; i < ones; i++) {
        const int j = i + next_below(&rng, s - i), t = order[i];
        order[i] = order[j], order[j] = t;
        vac_toggle(&v, order[i], 1);
    }
    /* relax: tightest cluster -> largest void until the pixel removed is the one refilled */
    for (long long it = 0; it < 50LL * s && !poll_stop(poll, 2 * (uint64_t)s); it++) {
        const int c = vac_extreme(&v, 1);
        vac_toggle(&v, c, 0);
        const int z = vac_extreme(&v, 0);
        vac_toggle(&v, z, 1);
        if (z == c) break;
    }
    double *proto_e = v.e + s;
    uint8_t *proto_on = v.on + s;
    memcpy(proto_e, v.e, sizeof(double) * (size_t)s);
    memcpy(proto_on, v.on, (size_t)s);
    for (int rank = ones - 1; rank >= 0 && !poll_stop(poll, s); rank--) { /* phase 1: remove tightest clusters */
        const int c = vac_extreme(&v, 1);
        vac_toggle(&v, c, 0);
        ranks[c] = rank;
    }
    memcpy(v.e, proto_e, sizeof(double) * (size_t)s);
    memcpy(v.on, proto_on, (size_t)s);
    for (int rank = ones; rank < s && !poll_stop(poll, s); rank++) { /* phases 2, 3: fill the largest voids */
        const int z = vac_extreme(&v, 0);
        vac_toggle(&v, z, 1);
        ranks[z] = rank;
    }
    free(v.kernel), free(v.e), free(v.on), free(order);
    return poll && poll->stopped ? dpc_fail(DPC_ERROR_CANCELLED, "the progress callback cancelled the mask design")
                                 : DPC_OK;
}

dpc_status dpc_void_and_cluster_ranks(uint32_t size, uint64_t seed, int32_t *ranks) {
    return void_and_cluster(size, seed, ranks, NULL);
}

/* ---- the annealer ---------------------------------------------------------------------------- */

typedef struct annealer {
    int T, n, S, Q, K, Kt, J, rank_reach;
    int pow2;                                /* n is a power of two: phases by a mask, not a division */
    int *rank, *pixel_of_rank;               /* T * S */
    int *qx, *qy;                            /* Q, reduced mod n */
    double *wm, *wl, *wj;                    /* mask, level and joint weights per frequency */
    int *thr, *level_of_rank;                /* K thresholds; per rank, the first level above it */
    double *kpre;                            /* K + 1: prefix sums of the levels' kappa */
    double *wt, *kpt;                        /* Kt temporal weights; K + 1 prefix sums of kappa_time */
    double *cosv, *sinv;                     /* n: cos and -sin of 2 pi k / n */
    double *tcos, *tsin;                     /* Kt * T */
    int *jthr, *joint_level_of_rank;         /* J; S */
    double *jkap;                            /* J * J */
    double *Mr, *Mi;                         /* T * Q: the ranks' DFT */
    double *Pr, *Pi;                         /* T * (K + 1) * Q: kappa-weighted prefix sums of B */
    double *Vr, *Vi;                         /* S * (K + 1) * Kt: same for C, per pixel */
    double *Dr, *Di;                         /* 2 * J * J * Q: box patterns, both orientations */
    double *DPr, *DPi;                       /* 2 * J * (J + 1) * Q: their prefix sums over j */
    double *dr, *di, *ear, *eai, *ebr, *ebi; /* Q: scratch of the last delta() */
} annealer;

static size_t pidx(const annealer *a, int f, int l) { return ((size_t)f * (a->K + 1) + l) * a->Q; }
static size_t tidx(const annealer *a, int p, int l) { return ((size_t)p * (a->K + 1) + l) * a->Kt; }
static size_t didx(const annealer *a, int o, int i, int j) { return (((size_t)o * a->J + i) * a->J + j) * a->Q; }
static size_t dpidx(const annealer *a, int o, int i, int j) { return (((size_t)o * a->J + i) * (a->J + 1) + j) * a->Q; }
static double joint_kappa(const annealer *a, int o, int i, int j) {
    return o == 0 ? a->jkap[i * a->J + j] : a->jkap[j * a->J + i];
}
/* The phase index (q . (x, y)) mod n of frequency i at pixel (x, y). */
static int phase(const annealer *a, int i, int x, int y) {
    const int v = a->qx[i] * x + a->qy[i] * y;
    return a->pow2 ? v & (a->n - 1) : v % a->n;
}

/* For each rank r, the first level whose threshold is above it: the levels from there on hold r. */
static void first_level_above(const int *thr, int levels, int S, int *out) {
    for (int r = 0, l = 0; r < S; r++) {
        while (l < levels && thr[l] <= r) l++;
        out[r] = l;
    }
}

static void annealer_free(annealer *a) {
    void *blocks[] = {a->rank,
                      a->pixel_of_rank,
                      a->qx,
                      a->qy,
                      a->wm,
                      a->wl,
                      a->wj,
                      a->thr,
                      a->level_of_rank,
                      a->kpre,
                      a->wt,
                      a->kpt,
                      a->cosv,
                      a->sinv,
                      a->tcos,
                      a->tsin,
                      a->jthr,
                      a->joint_level_of_rank,
                      a->jkap,
                      a->Mr,
                      a->Mi,
                      a->Pr,
                      a->Pi,
                      a->Vr,
                      a->Vi,
                      a->Dr,
                      a->Di,
                      a->DPr,
                      a->DPi,
                      a->dr,
                      a->di,
                      a->ear,
                      a->eai,
                      a->ebr,
                      a->ebi};
    for (size_t k = 0; k < sizeof blocks / sizeof blocks[0]; k++) free(blocks[k]);
}

/* Frequencies of the half plane (one of each +-q pair) with weight above e^-8, in a fixed order. */
static int count_frequencies(int n, double sigma, int *qx, int *qy, double *w) {
    int q = 0;
    for (int y = -(n / 2) + 1; y <= n / 2; y++)
        for (int x = -(n / 2) + 1; x <= n / 2; x++) {
            const double r2 = (double)(x * x + y * y);
            if (!(y > 0 || (y == 0 && x > 0)) || r2 > 16.0 * sigma * sigma) continue;
            if (qx)
                qx[q] = ((x % n) + n) % n, qy[q] = ((y % n) + n) % n, w[q] = dpc_exp_neg(-0.5 * r2 / (sigma * sigma));
            q++;
        }
    return q;
}

uint64_t dpc_mask_state_bytes(uint32_t size, uint32_t frames, uint32_t channels) {
    const int n = (int)size;
    const uint64_t t = (uint64_t)frames * channels, s = (uint64_t)size * size;
    const uint64_t q = (uint64_t)count_frequencies(n, SIGMA_Q_AT_64 * n / 64.0, NULL, NULL, NULL);
    const uint64_t kt = frames > 1 ? frames / 2 + 1 : 0;
    return 16ull * LEVELS * (t * q + s * kt);
}

#define ALLOC(ptr, count) \
    if (!((ptr) = calloc((size_t)(count) > 0 ? (size_t)(count) : 1, sizeof *(ptr)))) goto oom

static dpc_status annealer_init(annealer *a, int n, int frames, int joint) {
    memset(a, 0, sizeof *a);
    const int S = n * n, T = joint ? 2 : frames;
    const double sigma = SIGMA_Q_AT_64 * n / 64.0;
    a->T = T, a->n = n, a->S = S, a->K = LEVELS - 1, a->rank_reach = S / 64 > 1 ? S / 64 : 1;
    a->pow2 = (n & (n - 1)) == 0;
    a->Q = count_frequencies(n, sigma, NULL, NULL, NULL);
    a->Kt = (!joint && frames > 1) ? frames / 2 + 1 : 0;
    a->J = joint ? JOINT_LEVELS - 1 : 0;
    const int Q = a->Q, K = a->K, Kt = a->Kt, J = a->J;
    ALLOC(a->rank, (size_t)T * S);
    ALLOC(a->pixel_of_rank, (size_t)T * S);
    ALLOC(a->qx, Q);
    ALLOC(a->qy, Q);
    ALLOC(a->wm, Q);
    ALLOC(a->wl, Q);
    ALLOC(a->wj, Q);
    ALLOC(a->thr, K);
    ALLOC(a->level_of_rank, S);
    ALLOC(a->kpre, K + 1);
    ALLOC(a->wt, Kt);
    ALLOC(a->kpt, K + 1);
    ALLOC(a->cosv, n);
    ALLOC(a->sinv, n);
    ALLOC(a->tcos, (size_t)Kt * T);
    ALLOC(a->tsin, (size_t)Kt * T);
    ALLOC(a->jthr, J);
    ALLOC(a->joint_level_of_rank, S);
    ALLOC(a->jkap, (size_t)J * J);
    ALLOC(a->Mr, (size_t)T * Q);
    ALLOC(a->Mi, (size_t)T * Q);
    ALLOC(a->Pr, (size_t)T * (K + 1) * Q);
    ALLOC(a->Pi, (size_t)T * (K + 1) * Q);
    ALLOC(a->Vr, (size_t)S * (K + 1) * Kt);
    ALLOC(a->Vi, (size_t)S * (K + 1) * Kt);
    ALLOC(a->Dr, (size_t)2 * J * J * Q);
    ALLOC(a->Di, (size_t)2 * J * J * Q);
    ALLOC(a->DPr, (size_t)2 * J * (J + 1) * Q);
    ALLOC(a->DPi, (size_t)2 * J * (J + 1) * Q);
    ALLOC(a->dr, Q);
    ALLOC(a->di, Q);
    ALLOC(a->ear, Q);
    ALLOC(a->eai, Q);
    ALLOC(a->ebr, Q);
    ALLOC(a->ebi, Q);

    /* weights: each term scores 1 per frequency for white noise (docs/masks.md) */
    count_frequencies(n, sigma, a->qx, a->qy, a->wl);
    double wsum = 0;
    for (int i = 0; i < Q; i++) wsum += a->wl[i];
    const double spatial = 1.0 / (wsum * (joint ? 2 : frames));
    const double var_rank = ((double)S * S - 1.0) / 12.0; /* white ranks: E|DFT|^2 = S var at q != 0 */
    for (int i = 0; i < Q; i++) {
        a->wm[i] = MASK_WEIGHT * spatial * a->wl[i] / (S * var_rank);
        a->wj[i] = joint ? a->wl[i] : 0.0;
    }
    double wt_sum = 0;
    for (int k = 0; k < Kt; k++) {
        const double x = k / (TIME_SIGMA * frames);
        a->wt[k] = dpc_exp_neg(-0.5 * x * x);
        if (k > 0 && 2 * k != frames) a->wt[k] *= 2.0; /* the half spectrum stands for k and T - k */
        if (k == 0) a->wt[k] *= TIME_DC_WEIGHT;
        wt_sum += a->wt[k];
    }
    for (int l = 0; l < K; l++) {
        const double level = (double)(l + 1) / LEVELS;
        a->thr[l] = (int)(((int64_t)2 * (l + 1) * S + LEVELS) / (2 * LEVELS)); /* round(level S) */
        const double kappa = spatial / (S * level * (1 - level) * K);
        a->kpre[l + 1] = a->kpre[l] + kappa;
        /* white noise: E|C(k)|^2 = T L (1 - L) for each pixel, level and k (k = 0 included) */
        const double kt = Kt ? TIME_WEIGHT / (wt_sum * S * frames * level * (1 - level) * K) : 0.0;
        a->kpt[l + 1] = a->kpt[l] + kt;
    }
    first_level_above(a->thr, K, S, a->level_of_rank);
    for (int k = 0; k < n; k++) {
        const dpc_cplx e = dpc_turn((double)k / n);
        a->cosv[k] = e.re, a->sinv[k] = -e.im;
    }
    for (int k = 0; k < Kt; k++)
        for (int f = 0; f < T; f++) {
            const dpc_cplx e = dpc_turn((double)((k * f) % T) / T);
            a->tcos[k * T + f] = e.re, a->tsin[k * T + f] = -e.im;
        }
    for (int i = 0; i < J; i++) a->jthr[i] = (int)(((int64_t)2 * (i + 1) * S + JOINT_LEVELS) / (2 * JOINT_LEVELS));
    for (int i = 0; i < J; i++)
        for (int j = 0; j < J; j++) {
            const double share = (double)(i + 1) * (j + 1) / (JOINT_LEVELS * JOINT_LEVELS);
            /* white noise: E|D(q)|^2 = S ab (1 - ab) */
            a->jkap[i * J + j] = JOINT_WEIGHT / (wsum * S * share * (1 - share) * J * J);
        }
    first_level_above(a->jthr, J, S, a->joint_level_of_rank);
    return DPC_OK;
oom:
    annealer_free(a);
    return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for a %d x %d x %d mask design", n, n, T);
}

static void joint_prefix_row(annealer *a, int o, int i) {
    const int Q = a->Q;
    for (int q = 0; q < Q; q++) a->DPr[dpidx(a, o, i, 0) + q] = 0, a->DPi[dpidx(a, o, i, 0) + q] = 0;
    for (int j = 0; j < a->J; j++) {
        const double k = joint_kappa(a, o, i, j);
        for (int q = 0; q < Q; q++) {
            a->DPr[dpidx(a, o, i, j + 1) + q] = a->DPr[dpidx(a, o, i, j) + q] + k * a->Dr[didx(a, o, i, j) + q];
            a->DPi[dpidx(a, o, i, j + 1) + q] = a->DPi[dpidx(a, o, i, j) + q] + k * a->Di[didx(a, o, i, j) + q];
        }
    }
}

/* All spectra from the ranks (the start of a run). */
static dpc_status rebuild(annealer *a, poller *poll) {
    const int T = a->T, S = a->S, Q = a->Q, K = a->K, Kt = a->Kt, J = a->J;
    double *br = (double *)malloc(sizeof(double) * (size_t)K * Q),
           *bi = (double *)malloc(sizeof(double) * (size_t)K * Q);
    if (!br || !bi) {
        free(br), free(bi);
        return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for a mask design's spectra");
    }
    for (int f = 0; f < T; f++) {
        memset(br, 0, sizeof(double) * (size_t)K * Q), memset(bi, 0, sizeof(double) * (size_t)K * Q);
        double *mr = a->Mr + (size_t)f * Q, *mi = a->Mi + (size_t)f * Q;
        for (int p = 0; p < S; p++) {
            if (poll_stop(poll, (uint64_t)Q * K)) {
                free(br), free(bi);
                return dpc_fail(DPC_ERROR_CANCELLED, "the progress callback cancelled the mask design");
            }
            const int r = a->rank[(size_t)f * S + p], l0 = a->level_of_rank[r];
            for (int i = 0; i < Q; i++) {
                const int k = phase(a, i, p % a->n, p / a->n);
                mr[i] += r * a->cosv[k], mi[i] += r * a->sinv[k];
                for (int l = l0; l < K; l++) br[(size_t)l * Q + i] += a->cosv[k], bi[(size_t)l * Q + i] += a->sinv[k];
            }
        }
        for (int l = 1; l <= K; l++) {
            const double k = a->kpre[l] - a->kpre[l - 1];
            for (int i = 0; i < Q; i++) {
                a->Pr[pidx(a, f, l) + i] = a->Pr[pidx(a, f, l - 1) + i] + k * br[(size_t)(l - 1) * Q + i];
                a->Pi[pidx(a, f, l) + i] = a->Pi[pidx(a, f, l - 1) + i] + k * bi[(size_t)(l - 1) * Q + i];
            }
        }
    }
    free(br), free(bi);
    for (int p = 0; p < S && Kt > 0; p++) {
        if (poll_stop(poll, (uint64_t)K * Kt * T))
            return dpc_fail(DPC_ERROR_CANCELLED, "the progress callback cancelled the mask design");
        for (int l = 1; l <= K; l++) { /* C_pl(k) = sum_f ([rank_f < thr] - thr / S) e_f(k) */
            const double share = (double)a->thr[l - 1] / S, c = a->kpt[l] - a->kpt[l - 1];
            for (int k = 0; k < Kt; k++) {
                double sr = 0, si = 0;
                for (int f = 0; f < T; f++) {
                    const double b = (a->rank[(size_t)f * S + p] < a->thr[l - 1] ? 1.0 : 0.0) - share;
                    sr += b * a->tcos[k * T + f], si += b * a->tsin[k * T + f];
                }
                a->Vr[tidx(a, p, l) + k] = a->Vr[tidx(a, p, l - 1) + k] + c * sr;
                a->Vi[tidx(a, p, l) + k] = a->Vi[tidx(a, p, l - 1) + k] + c * si;
            }
        }
    }
    for (int p = 0; p < S && J > 0; p++) {
        if (poll_stop(poll, (uint64_t)Q * J * J))
            return dpc_fail(DPC_ERROR_CANCELLED, "the progress callback cancelled the mask design");
        const int l0 = a->joint_level_of_rank[a->rank[p]], l1 = a->joint_level_of_rank[a->rank[(size_t)S + p]];
        for (int q = 0; q < Q; q++) {
            const int k = phase(a, q, p % a->n, p / a->n);
            for (int i = l0; i < J; i++)
                for (int j = l1; j < J; j++) {
                    a->Dr[didx(a, 0, i, j) + q] += a->cosv[k], a->Di[didx(a, 0, i, j) + q] += a->sinv[k];
                    a->Dr[didx(a, 1, j, i) + q] += a->cosv[k], a->Di[didx(a, 1, j, i) + q] += a->sinv[k];
                }
        }
    }
    for (int o = 0; o < 2 && J > 0; o++)
        for (int i = 0; i < J; i++) joint_prefix_row(a, o, i);
    return DPC_OK;
}

static double energy(const annealer *a) {
    const int T = a->T, S = a->S, Q = a->Q, K = a->K, Kt = a->Kt, J = a->J;
    double e = 0;
    for (int f = 0; f < T; f++) {
        const double *mr = a->Mr + (size_t)f * Q, *mi = a->Mi + (size_t)f * Q;
        for (int i = 0; i < Q; i++) e += a->wm[i] * (mr[i] * mr[i] + mi[i] * mi[i]);
        for (int l = 1; l <= K; l++) {
            const double k = a->kpre[l] - a->kpre[l - 1];
            for (int i = 0; i < Q; i++) {
                const double br = a->Pr[pidx(a, f, l) + i] - a->Pr[pidx(a, f, l - 1) + i];
                const double bi = a->Pi[pidx(a, f, l) + i] - a->Pi[pidx(a, f, l - 1) + i];
                e += a->wl[i] * (br * br + bi * bi) / k;
            }
        }
    }
    for (int p = 0; p < S && Kt > 0; p++)
        for (int l = 1; l <= K; l++) {
            const double c = a->kpt[l] - a->kpt[l - 1];
            for (int k = 0; k < Kt; k++) {
                const double br = a->Vr[tidx(a, p, l) + k] - a->Vr[tidx(a, p, l - 1) + k];
                const double bi = a->Vi[tidx(a, p, l) + k] - a->Vi[tidx(a, p, l - 1) + k];
                e += a->wt[k] * (br * br + bi * bi) / c;
            }
        }
    for (int i = 0; i < J; i++)
        for (int j = 0; j < J; j++)
            for (int q = 0; q < Q; q++) {
                const double br = a->Dr[didx(a, 0, i, j) + q], bi = a->Di[didx(a, 0, i, j) + q];
                e += a->jkap[i * J + j] * a->wj[q] * (br * br + bi * bi);
            }
    return e;
}

/* A frame f and two of its pixels, a with the lower rank: half the time b is within REACH
 * pixels on the torus, half the time the pixel of a rank within rank_reach of a's. */
static void propose(const annealer *a, splitmix *rng, int *f, int *pa, int *pb) {
    const int S = a->S, n = a->n;
    *f = a->T > 1 ? next_below(rng, a->T) : 0;
    const int *rank = a->rank + (size_t)*f * S;
    int pa_ = next_below(rng, S), pb_;
    if (next_u64(rng) & 1) {
        const int r = rank[pa_] + next_below(rng, 2 * a->rank_reach + 1) - a->rank_reach;
        pb_ = r < 0 || r >= S ? pa_ : a->pixel_of_rank[(size_t)*f * S + r];
    } else if (2 * REACH + 1 >= n) {
        pb_ = next_below(rng, S);
    } else {
        const int bx = (pa_ % n + next_below(rng, 2 * REACH + 1) - REACH + n) % n;
        const int by = (pa_ / n + next_below(rng, 2 * REACH + 1) - REACH + n) % n;
        pb_ = by * n + bx;
    }
    if (rank[pa_] > rank[pb_]) {
        const int t = pa_;
        pa_ = pb_, pb_ = t;
    }
    *pa = pa_, *pb = pb_;
}

/* Energy change of swapping the ranks of pixels pa and pb in frame f (rank pa < rank pb); leaves
 * e_b - e_a per frequency in dr, di for apply(). */
static double delta(annealer *a, int f, int pa, int pb) {
    const int S = a->S, Q = a->Q, Kt = a->Kt, J = a->J, T = a->T;
    const int ra = a->rank[(size_t)f * S + pa], rb = a->rank[(size_t)f * S + pb];
    const int lo = a->level_of_rank[ra], hi = a->level_of_rank[rb];
    const double dv = (double)(rb - ra);
    const double *mr = a->Mr + (size_t)f * Q, *mi = a->Mi + (size_t)f * Q;
    double e = 0;
    const int n = a->n, xa = pa % n, ya = pa / n, xb = pb % n, yb = pb / n;
    for (int i = 0; i < Q; i++) {
        const int ka = phase(a, i, xa, ya), kb = phase(a, i, xb, yb);
        const double xr = a->cosv[kb] - a->cosv[ka], xi = a->sinv[kb] - a->sinv[ka];
        a->dr[i] = xr, a->di[i] = xi;
        if (J > 0) a->ear[i] = a->cosv[ka], a->eai[i] = a->sinv[ka], a->ebr[i] = a->cosv[kb], a->ebi[i] = a->sinv[kb];
        /* the mask's DFT changes by (rb - ra)(e_a - e_b) = -dv (e_b - e_a) */
        e += a->wm[i] * (dv * dv * (xr * xr + xi * xi) - 2 * dv * (mr[i] * xr + mi[i] * xi));
    }
    if (hi > lo) {
        const double ks = a->kpre[hi] - a->kpre[lo];
        const double *hr = a->Pr + pidx(a, f, hi), *hi_ = a->Pi + pidx(a, f, hi);
        const double *lr = a->Pr + pidx(a, f, lo), *li = a->Pi + pidx(a, f, lo);
        for (int i = 0; i < Q; i++) {
            const double sr = hr[i] - lr[i], si = hi_[i] - li[i];
            e += a->wl[i] * (2 * (sr * a->dr[i] + si * a->di[i]) + ks * (a->dr[i] * a->dr[i] + a->di[i] * a->di[i]));
        }
    }
    const double kt = Kt > 0 ? a->kpt[hi] - a->kpt[lo] : 0.0;
    if (kt != 0) { /* at frame f, pixel pa leaves the flipped levels' patterns and pb joins them */
        for (int k = 0; k < Kt; k++) {
            const double c = a->tcos[k * T + f], s = a->tsin[k * T + f];
            const double ar = a->Vr[tidx(a, pa, hi) + k] - a->Vr[tidx(a, pa, lo) + k];
            const double ai = a->Vi[tidx(a, pa, hi) + k] - a->Vi[tidx(a, pa, lo) + k];
            const double br = a->Vr[tidx(a, pb, hi) + k] - a->Vr[tidx(a, pb, lo) + k];
            const double bi = a->Vi[tidx(a, pb, hi) + k] - a->Vi[tidx(a, pb, lo) + k];
            e += a->wt[k] * (2 * ((br - ar) * c + (bi - ai) * s) + 2 * kt);
        }
    }
    if (J > 0) { /* box patterns: channel f's levels i in [jlo, jhi) lose pa and gain pb where the
                  * other channel's value of the pixel is below level j */
        const int jlo = a->joint_level_of_rank[ra], jhi = a->joint_level_of_rank[rb];
        const int la = a->joint_level_of_rank[a->rank[(size_t)(1 - f) * S + pa]];
        const int lb = a->joint_level_of_rank[a->rank[(size_t)(1 - f) * S + pb]];
        for (int i = jlo; i < jhi; i++) {
            double both = 0, one = 0;
            for (int j = 0; j < J; j++) {
                const int ina = j >= la, inb = j >= lb;
                if (ina && inb) both += joint_kappa(a, f, i, j);
                else if (ina || inb) one += joint_kappa(a, f, i, j);
            }
            const double *er = a->DPr + dpidx(a, f, i, J), *ei = a->DPi + dpidx(a, f, i, J);
            const double *ar = a->DPr + dpidx(a, f, i, la), *ai = a->DPi + dpidx(a, f, i, la);
            const double *br = a->DPr + dpidx(a, f, i, lb), *bi = a->DPi + dpidx(a, f, i, lb);
            for (int q = 0; q < Q; q++) {
                const double sar = er[q] - ar[q], sai = ei[q] - ai[q]; /* sum over j >= la */
                const double sbr = er[q] - br[q], sbi = ei[q] - bi[q]; /* sum over j >= lb */
                const double d2 = a->dr[q] * a->dr[q] + a->di[q] * a->di[q];
                e += a->wj[q] *
                     (2 * (sbr * a->ebr[q] + sbi * a->ebi[q] - sar * a->ear[q] - sai * a->eai[q]) + both * d2 + one);
            }
        }
    }
    return e;
}

static void apply(annealer *a, int f, int pa, int pb) {
    const int S = a->S, Q = a->Q, K = a->K, Kt = a->Kt, J = a->J, T = a->T;
    int *ra = a->rank + (size_t)f * S + pa, *rb = a->rank + (size_t)f * S + pb;
    const int lo = a->level_of_rank[*ra], hi = a->level_of_rank[*rb];
    const double dv = (double)(*rb - *ra);
    double *mr = a->Mr + (size_t)f * Q, *mi = a->Mi + (size_t)f * Q;
    for (int i = 0; i < Q; i++) mr[i] -= dv * a->dr[i], mi[i] -= dv * a->di[i];
    for (int j = lo + 1; j <= K && hi > lo; j++) {
        const double c = a->kpre[j < hi ? j : hi] - a->kpre[lo];
        double *pr = a->Pr + pidx(a, f, j), *pi = a->Pi + pidx(a, f, j);
        for (int i = 0; i < Q; i++) pr[i] += c * a->dr[i], pi[i] += c * a->di[i];
    }
    for (int j = lo + 1; j <= K && Kt > 0 && hi > lo; j++) {
        const double c = a->kpt[j < hi ? j : hi] - a->kpt[lo];
        for (int k = 0; k < Kt; k++) {
            const double er = c * a->tcos[k * T + f], ei = c * a->tsin[k * T + f];
            a->Vr[tidx(a, pa, j) + k] -= er, a->Vi[tidx(a, pa, j) + k] -= ei;
            a->Vr[tidx(a, pb, j) + k] += er, a->Vi[tidx(a, pb, j) + k] += ei;
        }
    }
    if (J > 0) {
        const int jlo = a->joint_level_of_rank[*ra], jhi = a->joint_level_of_rank[*rb];
        const int la = a->joint_level_of_rank[a->rank[(size_t)(1 - f) * S + pa]];
        const int lb = a->joint_level_of_rank[a->rank[(size_t)(1 - f) * S + pb]];
        for (int i = jlo; i < jhi; i++) {
            for (int j = 0; j < J; j++) {
                const double ca = j >= la ? 1.0 : 0.0, cb = j >= lb ? 1.0 : 0.0;
                if (ca == 0 && cb == 0) continue;
                for (int q = 0; q < Q; q++) {
                    const double xr = cb * a->ebr[q] - ca * a->ear[q], xi = cb * a->ebi[q] - ca * a->eai[q];
                    a->Dr[didx(a, f, i, j) + q] += xr, a->Di[didx(a, f, i, j) + q] += xi;
                    a->Dr[didx(a, 1 - f, j, i) + q] += xr, a->Di[didx(a, 1 - f, j, i) + q] += xi;
                }
            }
            joint_prefix_row(a, f, i);
        }
        for (int j = 0; j < J && jhi > jlo; j++) joint_prefix_row(a, 1 - f, j);
    }
    const int t = *ra;
    *ra = *rb, *rb = t;
    a->pixel_of_rank[(size_t)f * S + *ra] = pa, a->pixel_of_rank[(size_t)f * S + *rb] = pb;
}

static dpc_status anneal(annealer *a, uint64_t steps, uint64_t seed, const dpc_mask_options *o, poller *poll,
                         dpc_mask_stats *stats) {
    const int T = a->T, S = a->S;
    for (int f = 0; f < T; f++)
        for (int p = 0; p < S; p++) a->pixel_of_rank[(size_t)f * S + a->rank[(size_t)f * S + p]] = p;
    dpc_status st = rebuild(a, poll);
    if (st != DPC_OK) return st;
    splitmix rng = {seed * DPC_STREAM_MASK_ANNEAL + DPC_STREAM_MASK_ANNEAL_ADD};
    stats->energy_start = energy(a);
    stats->accepted = 0;
    double scale = 1.0, sum = 0;
    int count = 0;
    for (int t = 0; t < 4000 && steps > 0; t++) { /* the mean uphill step sets the temperatures */
        int f, pa, pb;
        propose(a, &rng, &f, &pa, &pb);
        if (pa == pb) continue;
        const double d = delta(a, f, pa, pb);
        if (d > 0) sum += d, count++;
    }
    if (count > 0 && sum > 0) scale = sum / count;
    for (uint64_t t = 0; t < steps; t++) {
        if (o->progress && t % PROGRESS_EVERY == 0 && o->progress(o->user, t, steps))
            return dpc_fail(DPC_ERROR_CANCELLED, "the progress callback cancelled the mask design");
        int f, pa, pb;
        propose(a, &rng, &f, &pa, &pb);
        if (pa == pb) continue;
        const double d = delta(a, f, pa, pb);
        int take = d < 0;
        if (!take) {
            const double temp = scale * T_START * dpc_exp_neg(LN_T_END_OVER_T_START * (double)t / (double)steps);
            take = next_uniform(&rng) < dpc_exp_neg(-d / temp);
        }
        if (take) apply(a, f, pa, pb), stats->accepted++;
    }
    if (o->progress && steps > 0 && o->progress(o->user, steps, steps))
        return dpc_fail(DPC_ERROR_CANCELLED, "the progress callback cancelled the mask design");
    stats->energy_end = energy(a);
    return DPC_OK;
}

dpc_status dpc_mask_design_run(const dpc_mask_options *o, uint64_t seed, uint32_t *out, dpc_mask_stats *stats) {
    const int n = (int)o->size, S = n * n, C = (int)o->channels, joint = C == 2;
    const int T = joint ? 2 : (int)o->frames;
    annealer a;
    dpc_status st = annealer_init(&a, n, (int)o->frames, joint);
    if (st != DPC_OK) return st;
    const uint64_t steps = (uint64_t)o->steps_per_pixel * (uint64_t)S * (uint64_t)T;
    poller poll = {o, steps ? steps : 1, 0, 0};
    for (int f = 0; f < T && st == DPC_OK; f++) /* one void-and-cluster start per frame or channel */
        st = void_and_cluster(o->size, seed + 1000003ull * (uint64_t)f, a.rank + (size_t)f * S, &poll);
    dpc_mask_stats local = {0, 0, 0};
    if (st == DPC_OK) st = anneal(&a, steps, seed, o, &poll, &local);
    if (st == DPC_OK) {
        for (int f = 0; f < T; f++)
            for (int p = 0; p < S; p++) {
                const uint32_t r = (uint32_t)a.rank[(size_t)f * S + p];
                if (joint) out[(size_t)p * 2 + f] = r;
                else out[(size_t)f * S + p] = r;
            }
        if (stats) *stats = local;
    }
    annealer_free(&a);
    return st;
}
