/* The output balance of docs/model-format.md §5.1: after the cascade, the generator of a model
 * with metadata "dpc.balance" = K cancels the set's Fourier coefficients at the torus-scale
 * frequencies (integer q, 0 < |q| <= K), which a cascade of local filters leaves at about 1e-4
 * of white noise's power and which smooth integrands see most. Plain double arithmetic in a
 * fixed order (its own sin/cos), so the points are the same bits on every machine. */
#ifndef DPC_MODEL_BALANCE_H
#define DPC_MODEL_BALANCE_H

#include <stddef.h>
#include <stdint.h>

#include "dpc/dpc.h"

#define DPC_BALANCE_MAX_K 32u
#define DPC_BALANCE_MAX_FREQS 4096u    /* frequencies of one half-space */
#define DPC_BALANCE_ITERATIONS 3       /* Newton steps when every point moves */
#define DPC_BALANCE_LEVEL_ITERATIONS 8 /* when only a progressive level's points move: the cross terms are larger */

/* The frequency radius used for a set of m points in n dimensions: min(k, the largest j with
 * (4 j)^n <= m), so the balanced frequencies stay below nu = 1/4 (0: none). */
uint32_t dpc_balance_radius(uint32_t k, size_t m, size_t n);

/* How many frequencies (of a half-space) radius k holds in n dimensions; 0 when k is 0, above
 * DPC_BALANCE_MAX_K or the count above DPC_BALANCE_MAX_FREQS. */
size_t dpc_balance_frequencies(uint32_t k, size_t n);

/* Balance m points in n dimensions (each coordinate in [0, 1)) in place at radius k (already
 * reduced by dpc_balance_radius): the coefficients are those of all m points, and the points
 * from index first on are the ones that move (0: all; a progressive level's new points). DPC_ERROR_LIMIT when the radius holds more than
 * DPC_BALANCE_MAX_FREQS frequencies, DPC_ERROR_OUT_OF_MEMORY; the points are unchanged then. */
dpc_status dpc_balance_points(float *x, size_t m, size_t n, uint32_t k, size_t first);

#endif
