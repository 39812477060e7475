/* The neighbour prefilter (cpu_near.h), portable: one candidate at a time, stopping at the first
 * dimension pair that passes the limit. The lists are the AVX2 path's (the sums are exact in
 * both: each pair's term is at most 2 * 127^2, and a sum past the limit fails either way). The
 * engine does not use it (cpu_dispatch.c: it is about as slow as the scan it would spare); it is
 * the tests' reference for the AVX2 filter. */
#include "cpu/cpu_near.h"

static int passes(const dpc_near_job *job, uint32_t query, uint32_t j) {
    uint32_t sum = 0;
    for (unsigned p = 0; p < job->pairs && sum <= job->limit; p++)
        for (unsigned e = 0; e < 2; e++) {
            const int8_t d = (int8_t)(uint8_t)(job->code[p][2 * j + e] - job->code[p][2 * query + e]);
            const int a = d < 0 ? -d : d; /* 128 for -128 */
            const uint32_t lb = a > 0 ? (uint32_t)a - 1 : 0;
            sum += lb * lb;
        }
    return sum <= job->limit;
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
