/* The neighbour prefilter's point scan (cpu_near.h: the lists' builds and far points) in
 * AVX-512BW: the AVX2 form's integer test (cpu_near_avx2.c) on 32 candidates per vector,
 * compared straight into a mask register (one bit per candidate). Two vectors (64 candidates)
 * per step: the codes are readable 128 bytes past 2m, and that is the AVX2 form's step, so both
 * read the same bytes. Compiled with -mavx512f -mavx512bw for this file only; the engine takes it
 * where cpuid reports AVX-512BW (cpu_dispatch.c). The test and its sums are the AVX2 form's, so
 * are the lists. (The block ranges stay AVX2: with two sums in flight instead of four they took
 * x1.2 the time on bnot-5d, AMD Zen 4.) */
#include <immintrin.h>
#include <string.h>

#include "cpu/cpu_near.h"

#define SUMS 2

/* The pass bits of the 64 candidates from j (bit c: candidate j + c), the padding past m and the
 * candidates before `from` cleared. */
static inline __attribute__((always_inline)) uint64_t chunk(const __m512i *q, const uint8_t *const *code,
                                                            unsigned pairs, uint32_t limit16, uint32_t j, uint32_t from,
                                                            uint32_t m) {
    const __m512i one = _mm512_set1_epi8(1), limit = _mm512_set1_epi16((short)limit16);
    __m512i acc[SUMS];
    for (unsigned v = 0; v < SUMS; v++) acc[v] = _mm512_setzero_si512();
    for (unsigned p = 0; p < pairs; p++) {
        const uint8_t *c = code[p] + 2 * (size_t)j;
        for (unsigned v = 0; v < SUMS; v++) {
            const __m512i x = _mm512_loadu_si512((const void *)(c + 64 * v));
            const __m512i lb = _mm512_subs_epu8(_mm512_abs_epi8(_mm512_sub_epi8(x, q[p])), one);
            acc[v] = _mm512_adds_epu16(acc[v], _mm512_maddubs_epi16(lb, lb));
        }
    }
    uint64_t pass = 0;
    for (unsigned v = 0; v < SUMS; v++) pass |= (uint64_t)_mm512_cmple_epu16_mask(acc[v], limit) << (32 * v);
    const uint32_t left = m - j; /* j < m */
    if (left < 64) pass &= (UINT64_C(1) << left) - 1u;
    if (from > j) pass &= from - j >= 64 ? 0u : ~((UINT64_C(1) << (from - j)) - 1u);
    return pass;
}

static inline void query_codes(const dpc_near_job *job, uint32_t query, __m512i *q, const uint8_t **code) {
    for (unsigned p = 0; p < job->pairs; p++) {
        uint16_t both;
        memcpy(&both, job->code[p] + 2 * (size_t)query, 2);
        q[p] = _mm512_set1_epi16((short)both);
        code[p] = job->code[p];
    }
}

/* The scan, inlined once per small pair count (cpu_near_avx2.c). */
static inline __attribute__((always_inline)) unsigned points(const dpc_near_job *job, uint32_t query, uint32_t from,
                                                             uint32_t *out, unsigned cap, unsigned pairs) {
    __m512i q[DPC_MAX_DIMS / 2];
    const uint8_t *code[DPC_MAX_DIMS / 2];
    query_codes(job, query, q, code);
    unsigned n = 0;
    for (uint32_t j = from / 64 * 64; j < job->m; j += 64)
        for (uint64_t bits = chunk(q, code, pairs, job->limit, j, from, job->m); bits; bits &= bits - 1) {
            if (n == cap) return cap + 1;
            out[n++] = j + (uint32_t)__builtin_ctzll(bits);
        }
    return n;
}

unsigned dpc_near_points_avx512(const dpc_near_job *job, uint32_t query, uint32_t from, uint32_t *out, unsigned cap) {
    switch (job->pairs) {
    case 3: return points(job, query, from, out, cap, 3);
    case 4: return points(job, query, from, out, cap, 4);
    case 5: return points(job, query, from, out, cap, 5);
    case 6: return points(job, query, from, out, cap, 6);
    case 7: return points(job, query, from, out, cap, 7);
    case 8: return points(job, query, from, out, cap, 8);
    default: return points(job, query, from, out, cap, job->pairs);
    }
}
