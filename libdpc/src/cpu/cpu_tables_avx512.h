/* The AVX-512F paths' 16-lane vectors and their kernel tables: up to 32 bins in two registers,
 * looked up by vpermt2ps, a gather beyond. Shared by the cascade's kernel (cpu_kernel_avx512.c)
 * and the density kernel (density/density_kernel_avx512.c); include only in files compiled with
 * -mavx512f. */
#ifndef DPC_CPU_CPU_TABLES_AVX512_H
#define DPC_CPU_CPU_TABLES_AVX512_H

#include <immintrin.h>
#include <stdint.h>

#define VW 16
typedef float vf __attribute__((vector_size(64)));
typedef int32_t vi __attribute__((vector_size(64)));

typedef struct table_regs {
    __m512 lo, hi;
    const float *w;
    int small;
} table_regs;

static inline void load_table(table_regs *T, const float *src, int bins) {
    T->w = src;
    T->small = bins <= 32;
    const int n = T->small ? bins : 0; /* the tail beyond `bins` is never selected */
    const __mmask16 m_lo = (__mmask16)(n >= 16 ? 0xffff : (1u << n) - 1);
    const __mmask16 m_hi = (__mmask16)(n <= 16 ? 0 : n >= 32 ? 0xffff : (1u << (n - 16)) - 1);
    T->lo = _mm512_maskz_loadu_ps(m_lo, src);
    T->hi = _mm512_maskz_loadu_ps(m_hi, src + 16);
}

static inline vf lookup16(const table_regs *T, vi b) {
    const __m512i bi = (__m512i)b;
    return (vf)(T->small ? _mm512_permutex2var_ps(T->lo, bi, T->hi) : _mm512_i32gather_ps(bi, T->w, 4));
}

#endif
