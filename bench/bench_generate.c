/* Times dpc_generate_n and prints one JSON line per point count:
 *   dpc_bench_generate MODEL ISA(scalar|avx2|avx512)[:THREADS] M [M ...]
 * on one thread unless ISA:THREADS says more. Each count runs once to warm up, then repeats
 * until 1.5 s or 25 runs (at least 3). */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "dpc/dpc.h"

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* CPU time of this thread: robust to time-slicing on a busy machine (reported beside wall time). */
static double cpu_now(void) {
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    if (argc < 4) {
        fprintf(stderr, "usage: %s MODEL scalar|avx2|avx512[:THREADS] M [M ...]\n", argv[0]);
        return 2;
    }
    dpc_load_options opt;
    dpc_load_options_init(&opt);
    opt.threads = 1;
    char *colon = strchr(argv[2], ':');
    if (colon) {
        *colon = '\0';
        opt.threads = (unsigned)strtoul(colon + 1, NULL, 10);
    }
    if (strcmp(argv[2], "scalar") == 0) opt.isa = DPC_ISA_SCALAR;
    else if (strcmp(argv[2], "avx2") == 0) opt.isa = DPC_ISA_AVX2;
    else if (strcmp(argv[2], "avx512") == 0) opt.isa = DPC_ISA_AVX512;
    else {
        fprintf(stderr, "unknown ISA '%s': scalar, avx2 or avx512\n", argv[2]);
        return 2;
    }
    dpc_model *model;
    if (dpc_model_load_file(argv[1], &opt, &model) != DPC_OK) {
        fprintf(stderr, "load failed: %s\n", dpc_last_error());
        return 1;
    }
    dpc_model_info info;
    dpc_model_get_info(model, &info);
    for (int a = 3; a < argc; a++) {
        size_t m = (size_t)strtoull(argv[a], NULL, 10);
        float *out = (float *)malloc(dpc_output_size(model, 1, m) * sizeof(float));
        double times[25], cpu[25];
        int runs = 0;
        double start = now(), total = 0.0;
        if (!out || dpc_generate_n(model, 0, m, out) != DPC_OK) {
            fprintf(stderr, "generate failed: %s\n", dpc_last_error());
            return 1;
        }
        while (runs < 25 && (runs < 3 || total < 1.5)) {
            double t0 = now(), c0 = cpu_now();
            dpc_generate_n(model, (uint64_t)runs + 1, m, out);
            cpu[runs] = cpu_now() - c0;
            times[runs++] = now() - t0;
            total = now() - start;
        }
        qsort(times, (size_t)runs, sizeof(double), cmp);
        qsort(cpu, (size_t)runs, sizeof(double), cmp);
        printf("{\"model\": \"%s\", \"isa\": \"%s\", \"threads\": %u, \"m\": %zu, \"layers\": %u, \"runs\": %d, "
               "\"median_s\": %.9f, \"min_s\": %.9f, \"cpu_median_s\": %.9f}\n",
               argv[1], argv[2], opt.threads, m, info.layers, runs, times[runs / 2], times[0], cpu[runs / 2]);
        fflush(stdout);
        free(out);
    }
    dpc_model_free(model);
    return 0;
}
