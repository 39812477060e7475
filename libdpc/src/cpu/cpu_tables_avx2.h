/* The AVX2 paths' 8-lane vectors and their kernel tables: up to 32 bins in four registers, looked
 * up by permutes (the same values as a gather, about 20% faster per layer on AMD Zen 5), a gather
 * beyond. Shared by the cascade's kernel (cpu_kernel_avx2.c) and the density kernel
 * (density/density_kernel_avx2.c); include only in files compiled with -mavx2. */
#ifndef DPC_CPU_CPU_TABLES_AVX2_H
#define DPC_CPU_CPU_TABLES_AVX2_H

#include <immintrin.h>
#include <stdint.h>

#define VW 8
typedef float vf __attribute__((vector_size(32)));
typedef int32_t vi __attribute__((vector_size(32)));

/* Bits 0-2 of the bin pick the entry within each group of 8, bits 3 and 4 (moved to the sign
 * bit) pick the group. */
typedef struct table_regs {
    __m256 t[4];
    const float *w;
    int small;
} table_regs;

static inline void load_table(table_regs *T, const float *src, int bins) {
    const __m256i lane8 = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    T->w = src;
    T->small = bins <= 32;
    for (int g = 0; g < 4; g++) {
        const __m256i keep = _mm256_cmpgt_epi32(_mm256_set1_epi32(T->small ? bins - 8 * g : 0), lane8);
        T->t[g] = _mm256_maskload_ps(src + 8 * g, keep);
    }
}

static inline vf lookup8(const table_regs *T, vi bv) {
    const __m256i b = (__m256i)bv;
    if (!T->small) return (vf)_mm256_i32gather_ps(T->w, b, 4);
    const __m256 bit3 = _mm256_castsi256_ps(_mm256_slli_epi32(b, 28));
    const __m256 bit4 = _mm256_castsi256_ps(_mm256_slli_epi32(b, 27));
    const __m256 lo =
        _mm256_blendv_ps(_mm256_permutevar8x32_ps(T->t[0], b), _mm256_permutevar8x32_ps(T->t[1], b), bit3);
    const __m256 hi =
        _mm256_blendv_ps(_mm256_permutevar8x32_ps(T->t[2], b), _mm256_permutevar8x32_ps(T->t[3], b), bit3);
    return (vf)_mm256_blendv_ps(lo, hi, bit4);
}

#endif
