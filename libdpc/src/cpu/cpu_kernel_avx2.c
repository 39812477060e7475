/* AVX2 + FMA path: the canonical kernel (cpu_kernel_body.h), one 8-lane register per vector;
 * tables of up to 32 bins looked up by permutes (the same values as a gather, about 20% faster
 * per layer on AMD Zen 5). Compiled with -mavx2 -mfma for this file only; called only when cpuid
 * reports both (cpu_dispatch.c). */
#include "cpu/cpu_kernels.h"
#include "cpu/cpu_tables_avx2.h"

#define FMA(a, b, c) ((vf)_mm256_fmadd_ps((__m256)(a), (__m256)(b), (__m256)(c)))

#define KERNEL dpc_block_avx2
#define LIST_KERNEL dpc_list_avx2
#define LOAD_TABLE(T, src, n) load_table(T, src, n)
#define LOOKUP(T, b) lookup8(T, b)
#define VANY(m) (!_mm256_testz_si256((__m256i)(m), (__m256i)(m)))
#define VRINT(t) ((vf)_mm256_round_ps((__m256)(t), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC))
#define VMIN(a, b) ((vf)_mm256_min_ps((__m256)(a), (__m256)(b))) /* b when a is NaN: never here */
#define VIMIN(a, b) ((vi)_mm256_min_epi32((__m256i)(a), (__m256i)(b)))
#define PIPE_MAX_K 3 /* 16 registers: the pipelined 4-D loop spills (x1.2 the plain loop's time) */
#include "cpu/cpu_kernel_body.h"
