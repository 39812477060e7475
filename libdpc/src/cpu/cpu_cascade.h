/* CPU backend entry points. */
#ifndef DPC_CPU_CASCADE_H
#define DPC_CPU_CASCADE_H

#include "cpu/cpu_kernels.h"
#include "model/model.h"

typedef struct dpc_cpu_engine {
    dpc_isa isa;        /* resolved: never DPC_ISA_AUTO */
    dpc_block_fn block; /* that ISA's kernel */
    unsigned threads;   /* >= 1 */
} dpc_cpu_engine;

/* Pick the kernel for isa (AUTO: DPC_ISA environment variable, else the best the CPU has). */
dpc_status dpc_cpu_engine_init(dpc_cpu_engine *e, dpc_isa isa, unsigned threads);

/* Filter m points (row-major, c->dims per point, all in [0,1)) through every layer, in place. */
dpc_status dpc_cpu_filter(const dpc_cascade *c, const dpc_cpu_engine *e, size_t m, float *x);

#endif
