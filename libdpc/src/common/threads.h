/* The one fork-join helper of libdpc (over a pool of workers kept for the process, threads.c):
 * the CPU engine's parallel loops, the batch fan-out and the training kernels all run their
 * workers through it. Every user gives each worker a fixed share of the work (a slot), so no
 * result depends on how many threads ran or which ran first. */
#ifndef DPC_COMMON_THREADS_H
#define DPC_COMMON_THREADS_H

#include <stddef.h>

/* Most worker threads one call uses. */
#define DPC_MAX_THREADS 64u

/* A thread count as callers give it: 0 means one per online CPU; at most DPC_MAX_THREADS. */
unsigned dpc_threads_resolve(unsigned threads);

/* fn(ctx, slot) for slot = 0 .. T - 1 (T capped at DPC_MAX_THREADS), slot 0 on the calling
 * thread, the others on pool workers (or, while another caller holds the pool, on new threads);
 * returns when all are done. A thread that cannot be created
 * has its slot run on the calling thread afterwards (slots are independent, so results do not
 * change; only the speed does). */
typedef void (*dpc_worker_fn)(void *ctx, unsigned slot);
void dpc_run_workers(unsigned T, dpc_worker_fn fn, void *ctx);

/* fn(ctx, slot, lo, hi) over [0, n) cut into T consecutive ranges, range t = [n t / T,
 * n (t + 1) / T) on slot t (T capped at DPC_MAX_THREADS; T <= 1: one call for the whole range). */
typedef void (*dpc_range_fn)(void *ctx, unsigned slot, size_t lo, size_t hi);
void dpc_parallel_ranges(unsigned T, size_t n, dpc_range_fn fn, void *ctx);

#endif
