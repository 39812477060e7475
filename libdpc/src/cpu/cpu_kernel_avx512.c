/* AVX-512F path: the canonical kernel (cpu_kernel_body.h) on 16-lane registers, each holding two
 * query points over the same 8 candidates; tables of up to 32 bins looked up in registers
 * (vpermt2ps), gathers beyond. Compiled with -mavx512f for this file only; called only when
 * cpuid reports AVX-512F (cpu_dispatch.c). The same code with generic primitives is compiled
 * for every CPU as dpc_block_packed16 (tests/c/cpu_kernel_packed16.c, in the kernel tests
 * only), which they compare with the scalar path on machines without AVX-512. */
#include "cpu/cpu_kernels.h"
#include "cpu/cpu_tables_avx512.h"

#define FMA(a, b, c) ((vf)_mm512_fmadd_ps((__m512)(a), (__m512)(b), (__m512)(c)))

#define KERNEL dpc_block_avx512
#define LIST_KERNEL dpc_list_avx512
#define LOAD_TABLE(T, src, n) load_table(T, src, n)
#define LOOKUP(T, b) lookup16(T, b)
/* vbroadcastf64x4: the 8 floats at p into both halves (AVX-512F; the f32x8 form needs DQ). */
#define VLOAD8(p) ((vf)_mm512_castpd_ps(_mm512_broadcast_f64x4(_mm256_loadu_pd((const double *)(p)))))
#define VPAIR(a, b) ((vf)_mm512_mask_blend_ps(0xff00, _mm512_set1_ps(a), _mm512_set1_ps(b)))
/* Lane masks in mask registers (cpu_kernel_body.h): lanes l with l mod 8 < left load. */
typedef __mmask16 vmask;
#define VMASK_ALL ((__mmask16)0xffff)
#define VMASK_BELOW(left) ((__mmask16)(((1u << ((left) < 8 ? (left) : 8)) - 1u) * 0x0101u))
#define VMASK_ANY(m) ((m) != 0)
#define VWINDOW(load, d2)                                                                                        \
    _mm512_mask_cmp_ps_mask(_mm512_mask_cmp_ps_mask(load, (__m512)(d2), (__m512)cut2, _CMP_GT_OQ), (__m512)(d2), \
                            (__m512)rad2, _CMP_LT_OQ)
#define VCOEF(in, g, y) ((vf)_mm512_maskz_mul_ps(in, (__m512)(g), (__m512)(y)))
#define VRINT(t) ((vf)_mm512_roundscale_ps((__m512)(t), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC))
#define VMIN(a, b) ((vf)_mm512_min_ps((__m512)(a), (__m512)(b))) /* b when a is NaN: never here */
#define VIMIN(a, b) ((vi)_mm512_min_epi32((__m512i)(a), (__m512i)(b)))
#include "cpu/cpu_kernel_body.h"
