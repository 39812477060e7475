/* The canonical kernel (cpu_kernel_body.h) on VW-lane GCC vectors with portable primitives:
 * FMAs and table lookups lane by lane. The including file defines VW (lanes) and KERNEL (the
 * function's name): cpu_kernel_scalar.c (8 lanes, the scalar path) and the kernel tests'
 * tests/c/cpu_kernel_packed16.c (16 lanes, AVX-512's arrangement). */
#include <math.h>

#include "cpu/cpu_kernels.h"

typedef float vf __attribute__((vector_size(VW * 4)));
typedef int32_t vi __attribute__((vector_size(VW * 4)));

/* Vectors passed between static inline functions: no ABI is involved. */
#pragma GCC diagnostic ignored "-Wpsabi"

/* fmaf rounds once everywhere (C99 7.12.13.1): the FMA instruction where the CPU has one (glibc
 * picks it at run time), an exact software version elsewhere. */
static inline vf fma_lanes(vf a, vf b, vf c) {
    vf r;
    for (int l = 0; l < VW; l++) r[l] = fmaf(a[l], b[l], c[l]);
    return r;
}

#include "cpu/cpu_tables_portable.h"

#define FMA(a, b, c) fma_lanes(a, b, c)
#define LOAD_TABLE(T, src, n) ((T)->w = (src), (void)(n))
#define LOOKUP(T, b) lookup_lanes(T, b)
#include "cpu/cpu_kernel_body.h"
