/* Kernel tables looked up lane by lane, for the portable kernels (cpu_kernel_portable.h, the
 * density's density_kernel.c). The including file defines VW and the VW-lane vectors vf and vi. */
#ifndef DPC_CPU_CPU_TABLES_PORTABLE_H
#define DPC_CPU_CPU_TABLES_PORTABLE_H

typedef struct table_regs {
    const float *w;
} table_regs;

static inline vf lookup_lanes(const table_regs *t, vi b) {
    vf r;
    for (int l = 0; l < VW; l++) r[l] = t->w[b[l]];
    return r;
}

#endif
