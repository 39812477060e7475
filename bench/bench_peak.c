/* The peak float32 vector operation rate of one core, per ISA, for the cascade's arithmetic
 * limit (bench_generate.py): independent chains of FMAs alone, and FMAs beside additions (CPUs
 * whose adders are separate pipes run both at once), each chain long enough that only
 * throughput counts. Prints one JSON line per ISA the CPU has:
 *   {"isa": "avx2", "lanes": 8, "fma_ops_per_s": ..., "mixed_ops_per_s": ...}
 * ops are vector operations; times lanes they are lane operations. Thread CPU time, best of 5. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <time.h>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>

#define ITERS 20000000L

static double cpu_now(void) {
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Chains of a = a * m + c (FMA) and s = s + c (add): CHAINS of each, ITERS steps. The result is
 * summed into a volatile so that nothing is dropped. */
#define PEAK_FN(NAME, TARGET, VT, SET1, FMA, ADD, STORE, LANES, CHAINS, MIXED)               \
    __attribute__((target(TARGET))) static double NAME(void) {                               \
        VT a[CHAINS], s[CHAINS];                                                             \
        const VT m = SET1(0.999999f), c = SET1(1e-7f);                                       \
        for (int i = 0; i < CHAINS; i++) a[i] = s[i] = SET1((float)i);                       \
        double best = 0.0;                                                                   \
        for (int round = 0; round < 5; round++) {                                            \
            const double t0 = cpu_now();                                                     \
            for (long it = 0; it < ITERS; it++) {                                            \
                for (int i = 0; i < CHAINS; i++) a[i] = FMA(a[i], m, c);                     \
                if (MIXED)                                                                   \
                    for (int i = 0; i < CHAINS; i++) s[i] = ADD(s[i], c);                    \
            }                                                                                \
            const double rate = (double)ITERS * CHAINS * (MIXED ? 2 : 1) / (cpu_now() - t0); \
            if (rate > best) best = rate;                                                    \
        }                                                                                    \
        float out[LANES], sum = 0.0f;                                                        \
        for (int i = 0; i < CHAINS; i++) {                                                   \
            STORE(out, ADD(a[i], s[i]));                                                     \
            sum += out[0];                                                                   \
        }                                                                                    \
        volatile float keep = sum;                                                           \
        (void)keep;                                                                          \
        return best;                                                                         \
    }

PEAK_FN(avx2_fma, "avx2,fma", __m256, _mm256_set1_ps, _mm256_fmadd_ps, _mm256_add_ps, _mm256_storeu_ps, 8, 10, 0)
PEAK_FN(avx2_mixed, "avx2,fma", __m256, _mm256_set1_ps, _mm256_fmadd_ps, _mm256_add_ps, _mm256_storeu_ps, 8, 6, 1)
PEAK_FN(avx512_fma, "avx512f", __m512, _mm512_set1_ps, _mm512_fmadd_ps, _mm512_add_ps, _mm512_storeu_ps, 16, 12, 0)
PEAK_FN(avx512_mixed, "avx512f", __m512, _mm512_set1_ps, _mm512_fmadd_ps, _mm512_add_ps, _mm512_storeu_ps, 16, 12, 1)

int main(void) {
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
        printf("{\"isa\": \"avx2\", \"lanes\": 8, \"fma_ops_per_s\": %.6e, \"mixed_ops_per_s\": %.6e}\n", avx2_fma(),
               avx2_mixed());
    if (__builtin_cpu_supports("avx512f"))
        printf("{\"isa\": \"avx512\", \"lanes\": 16, \"fma_ops_per_s\": %.6e, \"mixed_ops_per_s\": %.6e}\n",
               avx512_fma(), avx512_mixed());
    return 0;
}
#else
int main(void) { return 0; } /* no vector paths to measure */
#endif
