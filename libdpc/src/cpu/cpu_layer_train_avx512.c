/* AVX-512F pair loop of the training kernels: 8 doubles per vector, native lane masks and an
 * in-register compress of the surviving candidates. Compiled with -mavx512f for this file only;
 * chosen at run time when cpuid reports AVX-512F (cpu_layer_train.c). */
#include <immintrin.h>
#include <stdint.h>

#define W 8u
typedef __m512d vd;
typedef __m256i vx;
typedef __mmask8 vm;

#define V_SET1(x) _mm512_set1_pd(x)
#define V_ZERO() _mm512_setzero_pd()
#define V_STORE(p, v) _mm512_storeu_pd(p, v)
#define V_ADD(a, b) _mm512_add_pd(a, b)
#define V_SUB(a, b) _mm512_sub_pd(a, b)
#define V_MUL(a, b) _mm512_mul_pd(a, b)
#define V_DIV(a, b) _mm512_div_pd(a, b)
#define V_MIN(a, b) _mm512_min_pd(a, b)
#define V_FMA(a, b, c) _mm512_fmadd_pd(a, b, c)
#define V_SQRT(a) _mm512_sqrt_pd(a)
#define V_ROUND(a) _mm512_roundscale_pd(a, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC)
#define V_TRUNC(a) _mm512_roundscale_pd(a, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC)
#define V_CVTT(a) _mm512_cvttpd_epi32(a)
#define V_GATHER(base, idx) _mm512_i32gather_pd(idx, base, 8)
#define V_LT(a, b) _mm512_cmp_pd_mask(a, b, _CMP_LT_OQ)
#define V_GT(a, b) _mm512_cmp_pd_mask(a, b, _CMP_GT_OQ)
#define V_SEL(m, a, b) _mm512_mask_blend_pd(m, b, a)
#define M_AND(a, b) ((vm)((a) & (b)))
#define M_BITS(m) ((unsigned)(m))
#define I_LOADU(p) _mm256_loadu_si256((const __m256i *)(const void *)(p))
#define I_STORE(p, v) _mm256_storeu_si256((__m256i *)(void *)(p), v)

#define WF 16u
typedef __m512 vf;
#define F_SET1(x) _mm512_set1_ps(x)
#define F_ZERO() _mm512_setzero_ps()
#define F_LOADU(p) _mm512_loadu_ps(p)
#define F_SUB(a, b) _mm512_sub_ps(a, b)
#define F_FMA(a, b, c) _mm512_fmadd_ps(a, b, c)
#define F_ROUND(a) _mm512_roundscale_ps(a, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC)
#define F_BITS(d2, r2, e2) \
    ((unsigned)_mm512_mask_cmp_ps_mask(_mm512_cmp_ps_mask(d2, r2, _CMP_LT_OQ), d2, e2, _CMP_GT_OQ))

/* list[len ..] = j + (positions of the set bits), compressed in a register (a compress store to
 * memory is slow on several cores); one 16-wide store. */
static inline unsigned compress_append16(uint32_t *list, unsigned len, uint32_t j, unsigned bits) {
    const __m512i lanes = _mm512_add_epi32(_mm512_set1_epi32((int32_t)j),
                                           _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0));
    _mm512_storeu_si512((void *)(list + len), _mm512_maskz_compress_epi32((__mmask16)bits, lanes));
    return len + (unsigned)__builtin_popcount(bits);
}
#define COMPRESS_APPEND_F compress_append16

/* Lane sum in a fixed order: halves, then quarters, then pairs. */
static inline double hsum(vd v) {
    const __m256d h = _mm256_add_pd(_mm512_castpd512_pd256(v), _mm512_extractf64x4_pd(v, 1));
    const __m128d s = _mm_add_pd(_mm256_castpd256_pd128(h), _mm256_extractf128_pd(h, 1));
    return _mm_cvtsd_f64(_mm_add_sd(s, _mm_unpackhi_pd(s, s)));
}
#define V_HSUM hsum

/* A[q st + idx] -= v[q] in the lanes of m, q < K (distinct indices: no conflicts). */
#define SCATTER_SUB(A, st, idx, m, bits, v, K)                                               \
    for (unsigned q_ = 0; q_ < (K); q_++) {                                                  \
        double *col_ = (A) + q_ * (st);                                                      \
        const __m512d old_ = _mm512_mask_i32gather_pd(_mm512_setzero_pd(), m, idx, col_, 8); \
        _mm512_mask_i32scatter_pd(col_, m, idx, _mm512_sub_pd(old_, (v)[q_]), 8);            \
    }

#define TRAIN_CHUNK_FN dpc_train_chunk_avx512
#define TRAIN_SET_FN dpc_train_set_avx512
#include "cpu/cpu_layer_train_simd.h"
