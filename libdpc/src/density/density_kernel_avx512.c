/* AVX-512F path of the density kernel (density_kernel_body.h): 16-lane registers; the window's
 * candidates packed by vcompressps; kernel tables of up to 32 bins looked up in registers
 * (vpermt2ps), a gather beyond. Compiled with -mavx512f for this file only (no FMA: the same
 * separate multiplies and adds as the reference); run only where the model's ISA path is AVX-512
 * (cpu_dispatch.c checked the CPU). */
#include "cpu/cpu_tables_avx512.h"

#define KERNEL dpc_density_kernel_avx512
#define VLOAD(p) ((vf)_mm512_loadu_ps(p))
#define VSQRT(x) ((vf)_mm512_sqrt_ps((__m512)(x)))
#define VMIN(a, b) ((vf)_mm512_min_ps((__m512)(a), (__m512)(b))) /* b where a is NaN: never here */
#define VIMIN(a, b) ((vi)_mm512_min_epi32((__m512i)(a), (__m512i)(b)))
#define LOAD_TABLE(T, src, n) load_table(T, src, n)
#define LOOKUP(T, b) lookup16(T, b)
typedef __mmask16 mask_t;
#define WINDOW(v, lo, hi)                                                                                         \
    _mm512_mask_cmp_ps_mask(_mm512_cmp_ps_mask((__m512)(v), (__m512)(lo), _CMP_GT_OQ), (__m512)(v), (__m512)(hi), \
                            _CMP_LT_OQ)
static inline uint32_t pack3(__mmask16 m, vf tx, vf ty, vf a, float *px, float *py, float *pa) {
    _mm512_storeu_ps(px, _mm512_maskz_compress_ps(m, (__m512)tx));
    _mm512_storeu_ps(py, _mm512_maskz_compress_ps(m, (__m512)ty));
    _mm512_storeu_ps(pa, _mm512_maskz_compress_ps(m, (__m512)a));
    return (uint32_t)__builtin_popcount(m);
}
#define PACK3(m, tx, ty, a, px, py, pa) pack3(m, tx, ty, a, px, py, pa)
#include "density/density_kernel_body.h"
