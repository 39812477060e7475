/* Fork-join over a pool of worker threads kept for the life of the process (threads.h).
 *
 * Why a pool: a filter runs several parallel loops per layer (a 40-layer cascade: a few hundred
 * per set), each only a fraction of a millisecond long at the point counts where threads pay,
 * and creating and joining a thread for each costs more than many of them take (on the
 * virtual machines bench/bench_highdim.py ran on). Pool workers wait for their next slot
 * spinning for a while (the next loop usually follows within microseconds), then sleeping on
 * a condition variable.
 *
 * One caller dispatches to the pool at a time; a concurrent or nested caller (a pool worker
 * that forks again, or another thread's model) creates threads for its call as before. Each
 * worker has its own mailbox (job, generation), so no job is ever read while the next is
 * written. After fork() the child starts with an empty pool. */
#include "common/threads.h"

#include "common/error.h"

#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdint.h>
#include <string.h>
#include <unistd.h>

unsigned dpc_threads_resolve(unsigned threads) {
    if (threads == 0) {
        const long n = sysconf(_SC_NPROCESSORS_ONLN);
        threads = n > 0 ? (unsigned)n : 1u;
    }
    return threads > DPC_MAX_THREADS ? DPC_MAX_THREADS : threads;
}

#define SPIN_ROUNDS 2000 /* a waiting worker polls this often (up to about 0.1 ms) before it sleeps */

static inline void relax(void) {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
}

typedef struct mailbox {
    dpc_worker_fn fn; /* the job: written by the dispatcher before it publishes `go` */
    void *ctx;
    unsigned slot;
    _Atomic unsigned long go;   /* the generation to run (the dispatcher's release store) */
    _Atomic unsigned long done; /* the last generation run (the worker's release store) */
    _Atomic int sleeping;       /* the worker waits on `wake` (or is about to) */
    pthread_t id;
} mailbox;

static struct {
    pthread_mutex_t owner; /* held by the one dispatching caller (trylock) */
    pthread_mutex_t lock;  /* guards the sleeps and wake-ups */
    pthread_cond_t wake;
    unsigned n;               /* workers started: mailboxes 1 .. n */
    unsigned long generation; /* the dispatcher's job counter (under `owner`) */
    _Atomic int stop;
    mailbox box[DPC_MAX_THREADS];
} pool = {.owner = PTHREAD_MUTEX_INITIALIZER, .lock = PTHREAD_MUTEX_INITIALIZER, .wake = PTHREAD_COND_INITIALIZER};

static void *pool_main(void *arg) {
    mailbox *b = (mailbox *)arg;
    unsigned long seen = atomic_load(&b->done);
    for (;;) {
        unsigned long g = atomic_load_explicit(&b->go, memory_order_acquire);
        for (unsigned spin = 0; g == seen && spin < SPIN_ROUNDS; spin++) {
            relax();
            g = atomic_load_explicit(&b->go, memory_order_acquire);
        }
        if (g == seen) { /* sleep: announce it, then check once more under the lock (no lost wake-up) */
            pthread_mutex_lock(&pool.lock);
            atomic_store(&b->sleeping, 1);
            while ((g = atomic_load(&b->go)) == seen && !atomic_load(&pool.stop))
                pthread_cond_wait(&pool.wake, &pool.lock);
            atomic_store(&b->sleeping, 0);
            pthread_mutex_unlock(&pool.lock);
        }
        if (atomic_load(&pool.stop)) return NULL;
        b->fn(b->ctx, b->slot);
        seen = g;
        atomic_store_explicit(&b->done, g, memory_order_release);
    }
}

static void reset_in_child(void) { /* the workers do not exist in a forked child */
    pthread_mutex_init(&pool.owner, NULL);
    pthread_mutex_init(&pool.lock, NULL);
    pthread_cond_init(&pool.wake, NULL);
    pool.n = 0;
}

static pthread_once_t pool_once = PTHREAD_ONCE_INIT;
static void pool_init(void) { pthread_atfork(NULL, NULL, reset_in_child); }

/* Stop and join the workers when the library is unloaded (or the process exits). */
__attribute__((destructor)) static void pool_shutdown(void) {
    if (pthread_mutex_trylock(&pool.owner) != 0) return; /* a call in flight: leave it */
    pthread_mutex_lock(&pool.lock);
    atomic_store(&pool.stop, 1);
    pthread_cond_broadcast(&pool.wake);
    pthread_mutex_unlock(&pool.lock);
    for (unsigned t = 1; t <= pool.n; t++) pthread_join(pool.box[t].id, NULL);
    pool.n = 0;
    pthread_mutex_unlock(&pool.owner);
}

/* Run slots 1 .. T - 1 on pool workers (started as needed) and slot 0 here; 0 when the pool is
 * in use by another caller. */
static int run_on_pool(unsigned T, dpc_worker_fn fn, void *ctx) {
    pthread_once(&pool_once, pool_init);
    if (pthread_mutex_trylock(&pool.owner) != 0) return 0;
    while (pool.n < T - 1) { /* grow */
        mailbox *b = &pool.box[pool.n + 1];
        atomic_store(&b->go, 0);
        atomic_store(&b->done, 0);
        atomic_store(&b->sleeping, 0);
        if (pthread_create(&b->id, NULL, pool_main, b) != 0) break;
        pool.n++;
    }
    const unsigned long g = ++pool.generation;
    const unsigned workers = T - 1 < pool.n ? T - 1 : pool.n;
    for (unsigned t = 1; t <= workers; t++) {
        mailbox *b = &pool.box[t];
        b->fn = fn;
        b->ctx = ctx;
        b->slot = t;
        atomic_store(&b->go, g); /* seq_cst: against the worker's `sleeping`, one of the two sees the other */
        if (atomic_load(&b->sleeping)) {
            pthread_mutex_lock(&pool.lock);
            pthread_cond_broadcast(&pool.wake);
            pthread_mutex_unlock(&pool.lock);
        }
    }
    fn(ctx, 0);
    for (unsigned t = workers + 1; t < T; t++) fn(ctx, t); /* no worker to be had: here */
    for (unsigned t = 1; t <= workers; t++)
        for (unsigned spin = 0; atomic_load_explicit(&pool.box[t].done, memory_order_acquire) != g; spin++) {
            if (spin < SPIN_ROUNDS) relax();
            else sched_yield();
        }
    pthread_mutex_unlock(&pool.owner);
    return 1;
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
    if (run_on_pool(T, fn, ctx)) return;
    worker ws[DPC_MAX_THREADS]; /* the pool is busy: threads of our own */
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

dpc_status dpc_progress_begin(dpc_progress_state *p, dpc_progress_fn fn, void *user) {
    memset(p, 0, sizeof *p);
    p->fn = fn;
    p->user = user;
    if (pthread_mutex_init(&p->lock, NULL) != 0) return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "cannot create a mutex");
    return DPC_OK;
}

void dpc_progress_end(dpc_progress_state *p) { pthread_mutex_destroy(&p->lock); }

dpc_status dpc_progress_add(dpc_progress_state *p, uint64_t units) {
    if (!p || !p->fn) return DPC_OK;
    pthread_mutex_lock(&p->lock);
    if (!p->cancelled) {
        p->done += units;
        if (p->fn(p->user, p->done, p->total) != 0) p->cancelled = 1;
    }
    const int cancelled = p->cancelled;
    pthread_mutex_unlock(&p->lock);
    return cancelled ? DPC_ERROR_CANCELLED : DPC_OK;
}
