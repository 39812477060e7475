/* Portable path: the canonical kernel (cpu_kernel_body.h) on 8-lane GCC vectors, which the
 * compiler lowers to whatever the target has (SSE2 on a generic x86-64 build); FMAs and table
 * lookups lane by lane. On x86-64 this file is compiled twice: generic (dpc_block_scalar), and
 * with -mfma as cpu_kernel_scalar_fma.c (dpc_block_scalar_fma), which the scalar path runs on
 * CPUs with FMA so that fmaf is one instruction instead of a library call. Same source, same
 * bits. */
#include <math.h>

#include "cpu/cpu_kernels.h"

#define VW 8
typedef float vf __attribute__((vector_size(32)));
typedef int32_t vi __attribute__((vector_size(32)));

/* 8-lane vectors passed between static inline functions: no ABI is involved. */
#pragma GCC diagnostic ignored "-Wpsabi"

/* fmaf rounds once everywhere (C99 7.12.13.1): the FMA instruction where the CPU has one (glibc
 * picks it at run time), an exact software version elsewhere. */
static inline vf fma8(vf a, vf b, vf c) {
    vf r;
    for (int l = 0; l < VW; l++) r[l] = fmaf(a[l], b[l], c[l]);
    return r;
}

typedef struct table_regs {
    const float *w;
} table_regs;

static inline vf lookup8(const table_regs *t, vi b) {
    vf r;
    for (int l = 0; l < VW; l++) r[l] = t->w[b[l]];
    return r;
}

#ifndef KERNEL
#define KERNEL dpc_block_scalar
#endif
#define FMA(a, b, c) fma8(a, b, c)
#define LOAD_TABLE(T, src, n) ((T)->w = (src), (void)(n))
#define LOOKUP(T, b) lookup8(T, b)
#include "cpu/cpu_kernel_body.h"
