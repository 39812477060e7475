/* The neighbour prefilter (cpu_near.h) in AVX2: 16 candidates per vector, one dimension pair per
 * byte-pair lane: byte differences (wrapping mod 256 is the torus), |d| - 1 saturated at 0, and
 * maddubs sums the two squares of a pair into 16 bits (at most 2 * 127^2); pairs add with
 * unsigned saturation. Four vectors (64 candidates) per step keep four independent sums in
 * flight. Compiled with -mavx2 for this file only; the AVX2 and AVX-512 engines use it (the
 * lists do not change any bits, cpu_near.h). */
#include <immintrin.h>
#include <string.h>

#include "cpu/cpu_near.h"

#define SUMS 4

/* The pass bits of the 64 candidates from j (2 bits per candidate, 32 per vector), the padding
 * past m and the candidates before `from` cleared; whether any is set. */
static inline __attribute__((always_inline)) int chunk(const __m256i *q, const uint8_t *const *code, unsigned pairs,
                                                       uint32_t limit16, uint32_t j, uint32_t from, uint32_t m,
                                                       uint32_t pass[SUMS]) {
    const __m256i one = _mm256_set1_epi8(1), limit = _mm256_set1_epi16((short)limit16);
    __m256i acc[SUMS];
    for (unsigned v = 0; v < SUMS; v++) acc[v] = _mm256_setzero_si256();
    for (unsigned p = 0; p < pairs; p++) {
        const uint8_t *c = code[p] + 2 * (size_t)j;
        for (unsigned v = 0; v < SUMS; v++) {
            const __m256i x = _mm256_loadu_si256((const __m256i *)(c + 32 * v));
            const __m256i lb = _mm256_subs_epu8(_mm256_abs_epi8(_mm256_sub_epi8(x, q[p])), one);
            acc[v] = _mm256_adds_epu16(acc[v], _mm256_maddubs_epi16(lb, lb));
        }
    }
    uint32_t any = 0;
    for (unsigned v = 0; v < SUMS; v++) {
        pass[v] = (uint32_t)_mm256_movemask_epi8(_mm256_cmpeq_epi16(_mm256_min_epu16(acc[v], limit), acc[v]));
        const uint32_t at = j + 16 * v;
        const uint32_t left = m > at ? m - at : 0; /* the padding past m never passes */
        if (left < 16) pass[v] &= (1u << (2 * left)) - 1u;
        if (from > at) pass[v] &= from - at >= 16 ? 0u : ~((1u << (2 * (from - at))) - 1u);
        any |= pass[v];
    }
    return any != 0;
}

static inline void query_codes(const dpc_near_job *job, uint32_t query, __m256i *q, const uint8_t **code) {
    for (unsigned p = 0; p < job->pairs; p++) {
        uint16_t both;
        memcpy(&both, job->code[p] + 2 * (size_t)query, 2);
        q[p] = _mm256_set1_epi16((short)both);
        code[p] = job->code[p];
    }
}

/* The scan, inlined once per small pair count so that the compiler unrolls the dimension loop
 * and keeps the four sums in registers (a loop of unknown length copies them every step). */
static inline __attribute__((always_inline)) unsigned points(const dpc_near_job *job, uint32_t query, uint32_t from,
                                                             uint32_t *out, unsigned cap, unsigned pairs) {
    __m256i q[DPC_MAX_DIMS / 2];
    const uint8_t *code[DPC_MAX_DIMS / 2];
    query_codes(job, query, q, code);
    unsigned n = 0;
    for (uint32_t j = from / (16 * SUMS) * (16 * SUMS); j < job->m; j += 16 * SUMS) {
        uint32_t pass[SUMS];
        if (!chunk(q, code, pairs, job->limit, j, from, job->m, pass)) continue;
        for (unsigned v = 0; v < SUMS; v++)
            for (uint32_t bits = pass[v] & 0x55555555u; bits; bits &= bits - 1) {
                if (n == cap) return cap + 1;
                out[n++] = j + 16 * v + (uint32_t)__builtin_ctz(bits) / 2;
            }
    }
    return n;
}

unsigned dpc_near_points_avx2(const dpc_near_job *job, uint32_t query, uint32_t from, uint32_t *out, unsigned cap) {
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

unsigned dpc_near_avx2(const dpc_near_job *job, uint32_t query, uint32_t *ranges, unsigned cap) {
    const uint32_t m = job->m;
    __m256i q[DPC_MAX_DIMS / 2];
    const uint8_t *code[DPC_MAX_DIMS / 2];
    query_codes(job, query, q, code);
    unsigned n = 0;
    for (uint32_t j = 0; j < m; j += 16 * SUMS) {
        uint32_t pass[SUMS];
        if (!chunk(q, code, job->pairs, job->limit, j, 0, m, pass)) continue;
        for (unsigned v = 0; v < SUMS; v++) {
            const uint32_t b = j / 8 + 2 * v;
            if ((pass[v] & 0xFFFFu) && !dpc_near_add_block(ranges, &n, cap, b, m)) return cap + 1;
            if ((pass[v] >> 16) && !dpc_near_add_block(ranges, &n, cap, b + 1, m)) return cap + 1;
        }
    }
    return n;
}

/* Per candidate: its row's byte differences, |d| - 1 saturated, squares summed in pairs by
 * maddubs and in 32 bits by madd (exact: at most 64 * 127^2); two candidates per vector. */
unsigned dpc_near_list_avx2(const uint8_t *rows, unsigned row_bytes, uint32_t query, const uint32_t *cand, unsigned n,
                            uint32_t limit, uint32_t *out) {
    const uint8_t *qr = rows + (size_t)query * row_bytes;
    unsigned got = 0;
    for (unsigned c = 0; c < n; c += 2) {
        const uint32_t j0 = cand[c], j1 = cand[c + 1 < n ? c + 1 : c];
        const uint8_t *a = rows + (size_t)j0 * row_bytes, *b = rows + (size_t)j1 * row_bytes;
        __m256i acc = _mm256_setzero_si256();
        for (unsigned o = 0; o < row_bytes; o += 16) {
            const __m128i q128 = _mm_loadu_si128((const __m128i *)(qr + o));
            const __m256i q = _mm256_inserti128_si256(_mm256_castsi128_si256(q128), q128, 1);
            const __m256i x = _mm256_inserti128_si256(_mm256_castsi128_si256(_mm_loadu_si128((const __m128i *)(a + o))),
                                                      _mm_loadu_si128((const __m128i *)(b + o)), 1);
            const __m256i lb = _mm256_subs_epu8(_mm256_abs_epi8(_mm256_sub_epi8(x, q)), _mm256_set1_epi8(1));
            acc = _mm256_add_epi32(acc, _mm256_madd_epi16(_mm256_maddubs_epi16(lb, lb), _mm256_set1_epi16(1)));
        }
        /* the four 32-bit sums of each 128-bit half added: candidate 0 in lane 0, 1 in lane 4 */
        acc = _mm256_add_epi32(acc, _mm256_shuffle_epi32(acc, 0x4E));
        acc = _mm256_add_epi32(acc, _mm256_shuffle_epi32(acc, 0xB1));
        if ((uint32_t)_mm256_extract_epi32(acc, 0) <= limit) out[got++] = j0;
        if (c + 1 < n && (uint32_t)_mm256_extract_epi32(acc, 4) <= limit) out[got++] = j1;
    }
    return got;
}
