/* The neighbour prefilter (cpu_near.h), portable: one candidate at a time, stopping at the first
 * dimension pair that passes the limit. The lists are the AVX2 path's (the sums are exact in
 * both: each pair's term is at most 2 * 127^2, and a sum past the limit fails either way). The
 * engine does not use it (cpu_dispatch.c: it is about as slow as the scan it would spare); it is
 * the tests' reference for the AVX2 filter. */
#include "cpu/cpu_near.h"

static uint32_t lower_bound(int d) {
    const int8_t w = (int8_t)(uint8_t)d;           /* the difference mod 256, in [-128, 127] */
    const uint32_t a = (uint32_t)(w < 0 ? -w : w); /* 128 for -128 */
    const uint32_t lb = a > 0 ? a - 1 : 0;
    return lb * lb;
}

static int passes(const dpc_near_job *job, uint32_t query, uint32_t j) {
    uint32_t sum = 0;
    for (unsigned p = 0; p < job->pairs && sum <= job->limit; p++)
        for (unsigned e = 0; e < 2; e++)
            sum += lower_bound(job->code[p][2 * (size_t)j + e] - job->code[p][2 * (size_t)query + e]);
    return sum <= job->limit;
}

unsigned dpc_near_list_scalar(const uint8_t *rows, unsigned row_bytes, uint32_t query, const uint32_t *cand, unsigned n,
                              uint32_t limit, uint32_t *out) {
    const uint8_t *q = rows + (size_t)query * row_bytes;
    unsigned got = 0;
    for (unsigned c = 0; c < n; c++) {
        const uint8_t *r = rows + (size_t)cand[c] * row_bytes;
        uint32_t sum = 0;
        for (unsigned b = 0; b < row_bytes; b++) sum += lower_bound(r[b] - q[b]);
        if (sum <= limit) out[got++] = cand[c];
    }
    return got;
}

unsigned dpc_near_points_scalar(const dpc_near_job *job, uint32_t query, uint32_t from, uint32_t *out, unsigned cap) {
    unsigned n = 0;
    for (uint32_t j = from; j < job->m; j++)
        if (passes(job, query, j)) {
            if (n == cap) return cap + 1;
            out[n++] = j;
        }
    return n;
}

unsigned dpc_near_scalar(const dpc_near_job *job, uint32_t query, uint32_t *ranges, unsigned cap) {
    const uint32_t m = job->m;
    unsigned n = 0;
    for (uint32_t b = 0; 8 * b < m; b++) {
        const uint32_t end = 8 * b + 8 < m ? 8 * b + 8 : m;
        for (uint32_t j = 8 * b; j < end; j++) {
            if (passes(job, query, j)) {
                if (!dpc_near_add_block(ranges, &n, cap, b, m)) return cap + 1;
                break;
            }
        }
    }
    return n;
}
