#include "common/threads.h"

#include <pthread.h>
#include <unistd.h>

unsigned dpc_threads_resolve(unsigned threads) {
    if (threads == 0) {
        const long n = sysconf(_SC_NPROCESSORS_ONLN);
        threads = n > 0 ? (unsigned)n : 1u;
    }
    return threads > DPC_MAX_THREADS ? DPC_MAX_THREADS : threads;
}

typedef struct worker {
    dpc_worker_fn fn;
    void *ctx;
    unsigned slot;
} worker;

static void *worker_main(void *arg) {
    const worker *w = (const worker *)arg;
    w->fn(w->ctx, w->slot);
    return NULL;
}

void dpc_run_workers(unsigned T, dpc_worker_fn fn, void *ctx) {
    if (T > DPC_MAX_THREADS) T = DPC_MAX_THREADS;
    if (T <= 1) {
        fn(ctx, 0);
        return;
    }
    worker ws[DPC_MAX_THREADS];
    pthread_t ids[DPC_MAX_THREADS];
    int started[DPC_MAX_THREADS];
    for (unsigned t = 0; t < T; t++) ws[t] = (worker){fn, ctx, t};
    for (unsigned t = 1; t < T; t++) started[t] = pthread_create(&ids[t], NULL, worker_main, &ws[t]) == 0;
    fn(ctx, 0);
    for (unsigned t = 1; t < T; t++) {
        if (started[t]) pthread_join(ids[t], NULL);
        else fn(ctx, t); /* no thread to be had: do the work here */
    }
}

typedef struct ranges {
    dpc_range_fn fn;
    void *ctx;
    unsigned T;
    size_t n;
} ranges;

static void range_slot(void *arg, unsigned slot) {
    const ranges *r = (const ranges *)arg;
    r->fn(r->ctx, slot, r->n * slot / r->T, r->n * (slot + 1) / r->T);
}

void dpc_parallel_ranges(unsigned T, size_t n, dpc_range_fn fn, void *ctx) {
    if (T > DPC_MAX_THREADS) T = DPC_MAX_THREADS;
    if (T <= 1) {
        fn(ctx, 0, 0, n);
        return;
    }
    ranges r = {fn, ctx, T, n};
    dpc_run_workers(T, range_slot, &r);
}
