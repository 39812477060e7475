/* CPU backend entry points. */
#ifndef DPC_CPU_CASCADE_H
#define DPC_CPU_CASCADE_H

#include "cpu/cpu_kernels.h"
#include "cpu/cpu_near.h"
#include "model/model.h"

typedef struct dpc_cpu_engine {
    dpc_isa isa;        /* resolved: never DPC_ISA_AUTO */
    dpc_block_fn block; /* that ISA's kernel */
    dpc_list_fn list;   /* its form for explicit candidate lists (the neighbour lists) */
    dpc_near_fn near;   /* the neighbour prefilter (AVX2 where the CPU has it) */
    dpc_near_points_fn near_points;
    dpc_near_list_fn near_list;
    int prefilter;    /* 1 on CPUs with AVX2: prefilter large all-pairs subspaces; 0: scan every pair (the same bits) */
    unsigned threads; /* 1 .. DPC_MAX_THREADS */
} dpc_cpu_engine;

/* Whether this build and CPU run isa's path (AUTO and SCALAR: always). */
int dpc_cpu_isa_available(dpc_isa isa);

/* Resolve isa: AUTO is the DPC_ISA environment variable ("scalar", "avx2", "avx512"; unset, ""
 * or "auto": ignored), else the best the CPU has. A path this build or CPU lacks is
 * DPC_ERROR_UNSUPPORTED, a bad DPC_ISA DPC_ERROR_INVALID_ARGUMENT. Shared by the inference
 * engine and the training kernels. */
dpc_status dpc_cpu_resolve_isa(dpc_isa isa, dpc_isa *out);

/* Pick the kernel for isa (dpc_cpu_resolve_isa) and the thread count (0: one per online CPU). */
dpc_status dpc_cpu_engine_init(dpc_cpu_engine *e, dpc_isa isa, unsigned threads);

/* Filter m points (row-major, c->dims per point, all in [0,1)) through every layer, in place. */
dpc_status dpc_cpu_filter(const dpc_cascade *c, const dpc_cpu_engine *e, size_t m, float *x);

/* A hook of dpc_cpu_filter_hooked: called after each layer (layer_done = 1) and between chunks
 * of DPC_CPU_POLL_POINTS points inside a layer (layer_done = 0), possibly from worker threads
 * (the caller serialises); anything but DPC_OK stops the filter, which frees its workspace and
 * returns that status, x then unspecified. The bits of a run that is not stopped are those of
 * dpc_cpu_filter. */
typedef dpc_status (*dpc_cpu_hook)(void *ctx, int layer_done);
#define DPC_CPU_POLL_POINTS 16384u
dpc_status dpc_cpu_filter_hooked(const dpc_cascade *c, const dpc_cpu_engine *e, size_t m, float *x, dpc_cpu_hook hook,
                                 void *ctx);

/* dpc_cpu_filter_hooked with the first `frozen` points held in place: they are neighbours of
 * the others but never move (the levels of a progressive model, format §6). */
dpc_status dpc_cpu_filter_frozen(const dpc_cascade *c, const dpc_cpu_engine *e, size_t m, size_t frozen, float *x,
                                 dpc_cpu_hook hook, void *ctx);

/* count sets of m points (m already checked): set s is the input points of seed + s (kind
 * `input`, model/input.h) filtered through the cascade, at out + s * m * dims. With several
 * threads and sets below 65,536 points, whole sets go to workers (one single-threaded engine
 * each); otherwise sets run in order, each using the engine's threads. The bits are the same
 * either way. hook (or NULL) is also called (layer_done = 0) before each set; when it stops the
 * run the result is DPC_ERROR_CANCELLED with a message. A progressive cascade's sets are made
 * level by level (format §6): dpc_cpu_filter_runs filter runs of each set. */
dpc_status dpc_cpu_generate(const dpc_cascade *c, dpc_input input, const dpc_cpu_engine *e, uint64_t seed, size_t count,
                            size_t m, float *out, dpc_cpu_hook hook, void *ctx);

/* The cascade runs (filter passes over all layers) one set of m points takes: 1, or for a
 * progressive cascade its number of levels. */
size_t dpc_cpu_filter_runs(const dpc_cascade *c, size_t m);

#endif
