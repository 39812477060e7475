/* Run-time ISA choice: the library is compiled for a generic CPU and only the per-ISA kernel
 * files get ISA flags, so one binary runs everywhere and uses AVX2 + FMA or AVX-512F where
 * cpuid reports them (the inference kernels and the training kernels alike). */
#include <stdlib.h>
#include <string.h>

#include "common/error.h"
#include "common/threads.h"
#include "cpu/cpu_cascade.h"

static int cpu_has_avx512(void) {
#if defined(DPC_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
    return 0;
#endif
}

static int cpu_has_avx512bw(void) {
#if defined(DPC_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
    __builtin_cpu_init();
    return cpu_has_avx512() && __builtin_cpu_supports("avx512bw");
#else
    return 0;
#endif
}

static int cpu_has_fma(void) {
#if defined(DPC_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
    __builtin_cpu_init();
    return __builtin_cpu_supports("fma");
#else
    return 0;
#endif
}

static int cpu_has_avx2_fma(void) {
#if defined(DPC_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
    return 0;
#endif
}

int dpc_cpu_isa_available(dpc_isa isa) {
    switch (isa) {
    case DPC_ISA_AUTO:
    case DPC_ISA_SCALAR: return 1;
    case DPC_ISA_AVX2: return cpu_has_avx2_fma();
    case DPC_ISA_AVX512: return cpu_has_avx512();
    }
    return 0;
}

dpc_status dpc_cpu_resolve_isa(dpc_isa isa, dpc_isa *out) {
    if (isa == DPC_ISA_AUTO) {
        const char *env = getenv("DPC_ISA");
        if (env && *env && strcmp(env, "auto") != 0) {
            if (strcmp(env, "scalar") == 0) isa = DPC_ISA_SCALAR;
            else if (strcmp(env, "avx2") == 0) isa = DPC_ISA_AVX2;
            else if (strcmp(env, "avx512") == 0) isa = DPC_ISA_AVX512;
            else
                return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                                "environment variable DPC_ISA='%.32s': use auto, scalar, avx2 or avx512", env);
        } else {
            isa = cpu_has_avx512() ? DPC_ISA_AVX512 : cpu_has_avx2_fma() ? DPC_ISA_AVX2 : DPC_ISA_SCALAR;
        }
    }
    switch (isa) {
    case DPC_ISA_SCALAR: break;
    case DPC_ISA_AVX2:
#if defined(DPC_HAVE_AVX2)
        if (!cpu_has_avx2_fma()) return dpc_fail(DPC_ERROR_UNSUPPORTED, "the AVX2 path needs a CPU with AVX2 and FMA");
        break;
#else
        return dpc_fail(DPC_ERROR_UNSUPPORTED, "this libdpc was built without the AVX2 path");
#endif
    case DPC_ISA_AVX512:
#if defined(DPC_HAVE_AVX2)
        if (!cpu_has_avx512()) return dpc_fail(DPC_ERROR_UNSUPPORTED, "the AVX-512 path needs a CPU with AVX-512F");
        break;
#else
        return dpc_fail(DPC_ERROR_UNSUPPORTED, "this libdpc was built without the AVX-512 path");
#endif
    default: return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "unknown ISA %d", (int)isa);
    }
    *out = isa;
    return DPC_OK;
}

dpc_status dpc_cpu_engine_init(dpc_cpu_engine *e, dpc_isa isa, unsigned threads) {
    const dpc_status st = dpc_cpu_resolve_isa(isa, &isa);
    if (st != DPC_OK) return st;
    e->block = dpc_block_scalar;
    e->list = dpc_list_scalar;
    /* The prefilter only where its AVX2 form runs: the portable one (the tests' reference) costs
     * about what the all-pairs scan it would spare does (bnot-10d, 2,048 points: 0.67 s against
     * 0.57 s on a Zen 3 core). The lists change no bits (cpu_near.h), so every ISA path of an
     * AVX2 CPU takes them. */
    e->near = dpc_near_scalar;
    e->near_points = dpc_near_points_scalar;
    e->near_list = dpc_near_list_scalar;
    e->prefilter = 0;
#if defined(DPC_HAVE_AVX2)
    /* the scalar path's source compiled with -mfma: fmaf is an instruction, the bits the same */
    if (isa == DPC_ISA_SCALAR && cpu_has_fma()) e->block = dpc_block_scalar_fma, e->list = dpc_list_scalar_fma;
    if (isa == DPC_ISA_AVX2) e->block = dpc_block_avx2, e->list = dpc_list_avx2;
    if (isa == DPC_ISA_AVX512) e->block = dpc_block_avx512, e->list = dpc_list_avx512;
    if (cpu_has_avx2_fma())
        e->near = dpc_near_avx2, e->near_points = dpc_near_points_avx2, e->near_list = dpc_near_list_avx2,
        e->prefilter = 1;
    if (cpu_has_avx512bw()) e->near_points = dpc_near_points_avx512; /* x0.9 bnot-10d's time (Zen 4) */
#endif
    e->isa = isa;
    e->threads = dpc_threads_resolve(threads);
    return DPC_OK;
}
