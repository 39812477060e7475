/* The one fork-join helper of libdpc (over a pool of workers kept for the process, threads.c):
 * the CPU engine's parallel loops, the batch fan-out and the training kernels all run their
 * workers through it. Every user gives each worker a fixed share of the work (a slot), so no
 * result depends on how many threads ran or which ran first. */
#ifndef DPC_COMMON_THREADS_H
#define DPC_COMMON_THREADS_H

#include "dpc/dpc.h"

#include <pthread.h>
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

/* The progress of one long call (dpc_progress_fn), shared by its worker threads: the callback
 * runs under the lock, so calls never overlap, and once it asked to stop it is not called again.
 * Set total before the first dpc_progress_add. */
typedef struct dpc_progress_state {
    dpc_progress_fn fn;
    void *user;
    uint64_t done, total;
    int cancelled;
    pthread_mutex_t lock;
} dpc_progress_state;

/* Starts *p with fn (not NULL) and user, done = total = 0; DPC_ERROR_OUT_OF_MEMORY (message set)
 * when its lock cannot be made. dpc_progress_end releases it. */
dpc_status dpc_progress_begin(dpc_progress_state *p, dpc_progress_fn fn, void *user);
void dpc_progress_end(dpc_progress_state *p);
/* Count `units` more as done (0: a poll inside long work) and tell the callback;
 * DPC_ERROR_CANCELLED once it asked to stop. NULL: DPC_OK. */
dpc_status dpc_progress_add(dpc_progress_state *p, uint64_t units);

#endif
