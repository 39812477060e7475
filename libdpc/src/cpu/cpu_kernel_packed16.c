/* The AVX-512 path's arrangement (16-lane vectors, two query points each; cpu_kernel_avx512.c)
 * with portable primitives, compiled for every CPU: not an ISA path anyone selects, but the
 * kernel tests compare it bit for bit with the scalar path, which checks the 16-lane code on
 * machines that cannot run AVX-512. */
#include <math.h>

#include "cpu/cpu_kernels.h"

#define VW 16
typedef float vf __attribute__((vector_size(64)));
typedef int32_t vi __attribute__((vector_size(64)));

#pragma GCC diagnostic ignored "-Wpsabi"

static inline vf fma16(vf a, vf b, vf c) {
    vf r;
    for (int l = 0; l < VW; l++) r[l] = fmaf(a[l], b[l], c[l]);
    return r;
}

typedef struct table_regs {
    const float *w;
} table_regs;

static inline vf lookup16(const table_regs *t, vi b) {
    vf r;
    for (int l = 0; l < VW; l++) r[l] = t->w[b[l]];
    return r;
}

#define KERNEL dpc_block_packed16
#define FMA(a, b, c) fma16(a, b, c)
#define LOAD_TABLE(T, src, n) ((T)->w = (src), (void)(n))
#define LOOKUP(T, b) lookup16(T, b)
#include "cpu/cpu_kernel_body.h"
