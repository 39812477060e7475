/* Times generation on one backend and prints one JSON line per point count:
 *   dpc_bench_vulkan MODEL cpu|vulkan SETS M [M ...]
 * SETS = 1 times dpc_generate_n; SETS > 1 times dpc_generate_batch of SETS sets (one submission
 * on Vulkan). The CPU backend runs on one thread with the best ISA path (as bench_generate.c).
 * Each count runs once to warm up (Vulkan: buffer allocation, first dispatch), then repeats
 * until 1.5 s or 25 runs, at least 3. Wall time and the process's CPU time (a software Vulkan
 * driver computes on CPU threads of this process) are reported. On Vulkan, the warm-up's output
 * (seed 0) is also compared with the CPU backend's for the same seed (toroidal difference,
 * max_abs_diff_vs_cpu), so a timing on a new device is never reported for wrong points. Each line
 * also carries the model's load times (load_first_s, load_median_s; below). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "dpc/dpc.h"

static double clock_s(clockid_t id) {
    struct timespec t;
    clock_gettime(id, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    if (argc < 5) {
        fprintf(stderr, "usage: %s MODEL cpu|vulkan SETS M [M ...]\n", argv[0]);
        return 2;
    }
    dpc_load_options opt;
    dpc_load_options_init(&opt);
    opt.threads = 1;
    if (strcmp(argv[2], "cpu") == 0) opt.backend = DPC_BACKEND_CPU;
    else if (strcmp(argv[2], "vulkan") == 0) opt.backend = DPC_BACKEND_VULKAN;
    else {
        fprintf(stderr, "unknown backend '%s': cpu or vulkan\n", argv[2]);
        return 2;
    }
    const size_t sets = (size_t)strtoull(argv[3], NULL, 10);
    dpc_model *model;
    /* Load time: the process's first load (on Vulkan it also makes the process's instance), then
     * the median of 5 more loads of the same file (a device, pipelines and tables per model). */
    double t0 = clock_s(CLOCK_MONOTONIC);
    if (sets == 0 || dpc_model_load_file(argv[1], &opt, &model) != DPC_OK) {
        fprintf(stderr, "load failed: %s\n", sets ? dpc_last_error() : "SETS must be positive");
        return 1;
    }
    const double load_first = clock_s(CLOCK_MONOTONIC) - t0;
    double loads[5];
    for (int i = 0; i < 5; i++) {
        dpc_model *again = NULL;
        t0 = clock_s(CLOCK_MONOTONIC);
        if (dpc_model_load_file(argv[1], &opt, &again) != DPC_OK) {
            fprintf(stderr, "load failed: %s\n", dpc_last_error());
            return 1;
        }
        loads[i] = clock_s(CLOCK_MONOTONIC) - t0;
        dpc_model_free(again);
    }
    qsort(loads, 5, sizeof(double), cmp);
    dpc_model *reference = NULL; // Vulkan: the CPU backend on every core, for the parity check
    if (opt.backend == DPC_BACKEND_VULKAN) {
        dpc_load_options cpu_opt = opt;
        cpu_opt.backend = DPC_BACKEND_CPU;
        cpu_opt.threads = 0;
        if (dpc_model_load_file(argv[1], &cpu_opt, &reference) != DPC_OK) {
            fprintf(stderr, "load failed: %s\n", dpc_last_error());
            return 1;
        }
    }
    dpc_model_info info;
    dpc_model_get_info(model, &info);
    const char *isa[] = {"auto", "scalar", "avx2", "avx512"};
    for (int a = 4; a < argc; a++) {
        size_t m = (size_t)strtoull(argv[a], NULL, 10);
        float *out = (float *)malloc(dpc_output_size(model, sets, m) * sizeof(float));
        double times[25], cpu[25];
        int runs = 0;
        if (!out || dpc_generate_batch(model, 0, sets, m, out) != DPC_OK) {
            fprintf(stderr, "generate failed: %s\n", out ? dpc_last_error() : "out of memory");
            return 1;
        }
        double max_diff = -1.0; // no comparison (CPU backend)
        if (opt.backend == DPC_BACKEND_VULKAN) {
            const size_t count = dpc_output_size(model, sets, m);
            float *ref = (float *)malloc(count * sizeof(float));
            if (!ref || dpc_generate_batch(reference, 0, sets, m, ref) != DPC_OK) {
                fprintf(stderr, "CPU reference failed: %s\n", ref ? dpc_last_error() : "out of memory");
                return 1;
            }
            max_diff = 0.0;
            for (size_t e = 0; e < count; e++) {
                double d = fabs((double)out[e] - (double)ref[e]);
                d = d > 0.5 ? 1.0 - d : d;          // on the torus: 0.99999 and 0.00001 are neighbours
                if (!(d <= max_diff)) max_diff = d; // NaN propagates
            }
            free(ref);
        }
        double start = clock_s(CLOCK_MONOTONIC);
        while (runs < 25 && (runs < 3 || clock_s(CLOCK_MONOTONIC) - start < 1.5)) {
            double t0 = clock_s(CLOCK_MONOTONIC), c0 = clock_s(CLOCK_PROCESS_CPUTIME_ID);
            dpc_status st = sets == 1 ? dpc_generate_n(model, (uint64_t)runs + 1, m, out)
                                      : dpc_generate_batch(model, (uint64_t)runs + 1, sets, m, out);
            cpu[runs] = clock_s(CLOCK_PROCESS_CPUTIME_ID) - c0;
            times[runs++] = clock_s(CLOCK_MONOTONIC) - t0;
            if (st != DPC_OK) {
                fprintf(stderr, "generate failed: %s\n", dpc_last_error());
                return 1;
            }
        }
        qsort(times, (size_t)runs, sizeof(double), cmp);
        qsort(cpu, (size_t)runs, sizeof(double), cmp);
        printf("{\"model\": \"%s\", \"backend\": \"%s\", \"device\": \"%s\", \"isa\": \"%s\", \"sets\": %zu, "
               "\"m\": %zu, \"dims\": %u, \"layers\": %u, \"runs\": %d, \"median_s\": %.9f, \"min_s\": %.9f, "
               "\"process_cpu_median_s\": %.9f, \"max_abs_diff_vs_cpu\": %.3g, \"load_first_s\": %.9f, "
               "\"load_median_s\": %.9f}\n",
               argv[1], argv[2], dpc_model_device(model), isa[info.isa], sets, m, info.dims, info.layers, runs,
               times[runs / 2], times[0], cpu[runs / 2], max_diff, load_first, loads[2]);
        fflush(stdout);
        free(out);
    }
    dpc_model_free(model);
    dpc_model_free(reference);
    return 0;
}
