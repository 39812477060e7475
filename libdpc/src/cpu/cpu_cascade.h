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

/* Whether this build and CPU run isa's path (AUTO and SCALAR: always). */
int dpc_cpu_isa_available(dpc_isa isa);

/* Pick the kernel for isa (AUTO: DPC_ISA environment variable, else the best the CPU has). */
dpc_status dpc_cpu_engine_init(dpc_cpu_engine *e, dpc_isa isa, unsigned threads);

/* Filter m points (row-major, c->dims per point, all in [0,1)) through every layer, in place. */
dpc_status dpc_cpu_filter(const dpc_cascade *c, const dpc_cpu_engine *e, size_t m, float *x);

/* A hook of dpc_cpu_filter_hooked: called after each layer (layer_done = 1) and between chunks
 * of DPC_CPU_POLL_POINTS points inside a layer (layer_done = 0), possibly from worker threads
 * (the caller serialises); anything but DPC_OK stops the filter, which frees its workspace and
 * returns that status, x then unspecified. The bits of a run that is not stopped are those of
 * dpc_cpu_filter. */
typedef dpc_status (*dpc_cpu_hook)(void *ctx, int layer_done);
#define DPC_CPU_HAS_LAYER_HOOK 1
#define DPC_CPU_POLL_POINTS 16384u
dpc_status dpc_cpu_filter_hooked(const dpc_cascade *c, const dpc_cpu_engine *e, size_t m, float *x,
                                 dpc_cpu_hook hook, void *ctx);

#endif
