/* AVX2 + FMA pair loop of the training kernels: 4 doubles per vector. Compiled with -mavx2
 * -mfma for this file only; chosen at run time when cpuid reports both (cpu_layer_train.c). */
#include <immintrin.h>
#include <stdint.h>

#include "cpu/cpu_layer_train_impl.h"

#define W 4u
typedef __m256d vd;
typedef __m128i vx;
typedef __m256d vm;

#define V_SET1(x) _mm256_set1_pd(x)
#define V_ZERO() _mm256_setzero_pd()
#define V_STORE(p, v) _mm256_storeu_pd(p, v)
#define V_ADD(a, b) _mm256_add_pd(a, b)
#define V_SUB(a, b) _mm256_sub_pd(a, b)
#define V_MUL(a, b) _mm256_mul_pd(a, b)
#define V_DIV(a, b) _mm256_div_pd(a, b)
#define V_MIN(a, b) _mm256_min_pd(a, b)
#define V_FMA(a, b, c) _mm256_fmadd_pd(a, b, c)
#define V_SQRT(a) _mm256_sqrt_pd(a)
#define V_ROUND(a) _mm256_round_pd(a, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC)
#define V_TRUNC(a) _mm256_round_pd(a, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC)
#define V_CVTT(a) _mm256_cvttpd_epi32(a)
#define V_GATHER(base, idx) _mm256_i32gather_pd(base, idx, 8)
#define V_LT(a, b) _mm256_cmp_pd(a, b, _CMP_LT_OQ)
#define V_GT(a, b) _mm256_cmp_pd(a, b, _CMP_GT_OQ)
#define V_SEL(m, a, b) _mm256_blendv_pd(b, a, m)
#define M_AND(a, b) _mm256_and_pd(a, b)
#define M_BITS(m) ((unsigned)_mm256_movemask_pd(m))
#define I_LOADU(p) _mm_loadu_si128((const __m128i *)(const void *)(p))
#define I_STORE(p, v) _mm_storeu_si128((__m128i *)(void *)(p), v)

#define WF 8u
typedef __m256 vf;
#define F_SET1(x) _mm256_set1_ps(x)
#define F_ZERO() _mm256_setzero_ps()
#define F_LOADU(p) _mm256_loadu_ps(p)
#define F_SUB(a, b) _mm256_sub_ps(a, b)
#define F_FMA(a, b, c) _mm256_fmadd_ps(a, b, c)
#define F_ROUND(a) _mm256_round_ps(a, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC)
#define F_BITS(d2, r2, e2) \
    ((unsigned)_mm256_movemask_ps(_mm256_and_ps(_mm256_cmp_ps(d2, r2, _CMP_LT_OQ), _mm256_cmp_ps(d2, e2, _CMP_GT_OQ))))

/* Lane positions of the set bits of a 4-bit mask, packed to the front. */
static const int32_t packed_lanes[16][4] = {
    {0, 0, 0, 0}, {0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {2, 0, 0, 0}, {0, 2, 0, 0}, {1, 2, 0, 0}, {0, 1, 2, 0},
    {3, 0, 0, 0}, {0, 3, 0, 0}, {1, 3, 0, 0}, {0, 1, 3, 0}, {2, 3, 0, 0}, {0, 2, 3, 0}, {1, 2, 3, 0}, {0, 1, 2, 3}};

/* list[len ..] = j + (positions of the set bits); one 4-wide store, no branch. */
static inline unsigned compress_append(uint32_t *list, unsigned len, uint32_t j, unsigned bits) {
    const __m128i v = _mm_add_epi32(_mm_set1_epi32((int32_t)j), _mm_loadu_si128((const __m128i *)packed_lanes[bits]));
    _mm_storeu_si128((__m128i *)(void *)(list + len), v);
    return len + (unsigned)__builtin_popcount(bits);
}

static inline unsigned compress_append8(uint32_t *list, unsigned len, uint32_t j, unsigned bits) {
    len = compress_append(list, len, j, bits & 15u);
    return compress_append(list, len, j + 4, bits >> 4);
}
#define COMPRESS_APPEND_F compress_append8

/* Lane sum in a fixed order: (l0 + l2) + (l1 + l3). */
static inline double hsum(vd v) {
    const __m128d s = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
    return _mm_cvtsd_f64(_mm_add_sd(s, _mm_unpackhi_pd(s, s)));
}
#define V_HSUM hsum

/* A[q st + idx] -= v[q] in the lanes of bits, q < K: lane by lane (AVX2 has no scatter). */
static inline void scatter_sub(double *A, size_t st, vx idx, unsigned bits, const vd *v, unsigned K) {
    double t[DPC_MAX_DIMS * 4];
    int32_t j[4];
    for (unsigned q = 0; q < K; q++) _mm256_storeu_pd(t + 4 * q, v[q]);
    _mm_storeu_si128((__m128i *)(void *)j, idx);
    for (; bits; bits &= bits - 1) {
        const unsigned l = (unsigned)__builtin_ctz(bits);
        for (unsigned q = 0; q < K; q++) A[q * st + (size_t)j[l]] -= t[4 * q + l];
    }
}
#define SCATTER_SUB(A, st, idx, m, bits, v, K) scatter_sub(A, st, idx, bits, v, K)

#define TRAIN_CHUNK_FN dpc_train_chunk_avx2
#define TRAIN_SET_FN dpc_train_set_avx2
#include "cpu/cpu_layer_train_simd.h"
