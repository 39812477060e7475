/* Deterministic double-precision functions for the host-side steps of a generator (the output
 * balance, the prefix relaxation): plain double operations in a fixed order, with no libm call
 * but floor (exact), so their bits are the same on every machine and compiler
 * (libm's sin and exp may differ in the last bit between libraries). The build keeps a * b + c
 * two roundings (-ffp-contract=off). */
#ifndef DPC_COMMON_DETMATH_H
#define DPC_COMMON_DETMATH_H

#include <math.h>
#include <stdint.h>
#include <string.h>

typedef struct dpc_cplx {
    double re, im;
} dpc_cplx;

static inline dpc_cplx dpc_cmul(dpc_cplx a, dpc_cplx b) {
    return (dpc_cplx){a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re};
}

/* exp(2 pi i t): sin and cos by Taylor series on [-pi/4, pi/4] (truncation below 1e-19). */
static inline dpc_cplx dpc_turn(double t) {
    static const double SIN_TAYLOR[9] = {1.0,
                                         -1.0 / 6.0,
                                         1.0 / 120.0,
                                         -1.0 / 5040.0,
                                         1.0 / 362880.0,
                                         -1.0 / 39916800.0,
                                         1.0 / 6227020800.0,
                                         -1.0 / 1307674368000.0,
                                         1.0 / 355687428096000.0};
    static const double COS_TAYLOR[10] = {1.0,
                                          -1.0 / 2.0,
                                          1.0 / 24.0,
                                          -1.0 / 720.0,
                                          1.0 / 40320.0,
                                          -1.0 / 3628800.0,
                                          1.0 / 479001600.0,
                                          -1.0 / 87178291200.0,
                                          1.0 / 20922789888000.0,
                                          -1.0 / 6402373705728000.0};
    t -= floor(t);
    const double quadrant = floor(t * 4.0 + 0.5); /* 0 .. 4 */
    const double r = (t - quadrant * 0.25) * 6.283185307179586;
    const double r2 = r * r;
    double s = SIN_TAYLOR[8], c = COS_TAYLOR[9];
    for (int i = 7; i >= 0; i--) s = s * r2 + SIN_TAYLOR[i];
    for (int i = 8; i >= 0; i--) c = c * r2 + COS_TAYLOR[i];
    s *= r;
    switch ((int)quadrant & 3) {
    case 0: return (dpc_cplx){c, s};
    case 1: return (dpc_cplx){-s, c};
    case 2: return (dpc_cplx){-c, -s};
    default: return (dpc_cplx){s, -c};
    }
}

/* exp(x) for x <= 0 (0 below -700): x = k ln 2 + r with ln 2 split in two (k ln2_hi is exact for
 * |k| < 2^11), |r| <= ln 2 / 2, exp(r) by its Taylor series to r^13 / 13! (truncation below
 * 1e-17 relative), times 2^k (exact: the result is a normal double). Within a few 1e-16 relative of the true value. */
static inline double dpc_exp_neg(double x) {
    static const double EXP_TAYLOR[14] = {1.0,
                                          1.0,
                                          1.0 / 2.0,
                                          1.0 / 6.0,
                                          1.0 / 24.0,
                                          1.0 / 120.0,
                                          1.0 / 720.0,
                                          1.0 / 5040.0,
                                          1.0 / 40320.0,
                                          1.0 / 362880.0,
                                          1.0 / 3628800.0,
                                          1.0 / 39916800.0,
                                          1.0 / 479001600.0,
                                          1.0 / 6227020800.0};
    if (!(x > -700.0)) return 0.0;
    const double k = floor(x * 1.4426950408889634 + 0.5);
    const double r = (x - k * 0.693147180369123816490) - k * 1.90821492927058770002e-10;
    double p = EXP_TAYLOR[13];
    for (int i = 12; i >= 0; i--) p = p * r + EXP_TAYLOR[i];
    const uint64_t bits = (uint64_t)((int64_t)k + 1023) << 52; /* 2^k, k >= -1010: a normal double */
    double scale;
    memcpy(&scale, &bits, sizeof scale);
    return p * scale;
}

#endif
