/* Times the sampler (dpc_sampler_*) on one thread and prints one JSON line per case:
 *   dpc_bench_sampler MODEL SPP:DIMS [SPP:DIMS ...]
 * create: dpc_sampler_create of SPP samples per pixel and DIMS dimensions, median over repeats
 * (at least 3, until 1.5 s or 25); lookups: ns per get_2d / get_1d value over a renderer-style
 * loop (256 x 256 pixels, every sample index, 8 dimensions), median of 11 passes, with the
 * default options (from 32 spp every slot a net) and with net_dims = 1 (the sets' path in
 * dimensions 1-7); and get_2d of dimension 0 alone (a net slot where spp is a power of two >= 2). */
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

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n) {
    qsort(v, (size_t)n, sizeof *v, cmp);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* Sum every value so the loop cannot be optimised away. */
static volatile float g_sink;

static double lookup_ns(const dpc_sampler *s, unsigned spp, int two_d, unsigned dims) {
    const unsigned W = 256;
    double t[11];
    for (int pass = 0; pass < 11; pass++) {
        float acc = 0.0f, v[2];
        const double start = now();
        for (unsigned y = 0; y < W; y++)
            for (unsigned x = 0; x < W; x++)
                for (unsigned i = 0; i < spp; i++)
                    for (unsigned d = 0; d < dims; d++) {
                        if (two_d) {
                            dpc_sampler_get_2d(s, x, y, i, d, v);
                            acc += v[0] + v[1];
                        } else {
                            dpc_sampler_get_1d(s, x, y, i, d, v);
                            acc += v[0];
                        }
                    }
        t[pass] = (now() - start) * 1e9 / ((double)W * W * spp * dims);
        g_sink = acc;
    }
    return median(t, 11);
}

int main(int argc, char **argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s MODEL SPP:DIMS [SPP:DIMS ...]\n", argv[0]);
        return 2;
    }
    dpc_model *model;
    if (dpc_model_load_file(argv[1], NULL, &model) != DPC_OK) {
        fprintf(stderr, "load failed: %s\n", dpc_last_error());
        return 1;
    }
    for (int a = 2; a < argc; a++) {
        unsigned spp = 0, dims = 0;
        if (sscanf(argv[a], "%u:%u", &spp, &dims) != 2) {
            fprintf(stderr, "bad case '%s': SPP:DIMS\n", argv[a]);
            return 2;
        }
        dpc_sampler_options o;
        dpc_sampler_options_init(&o);
        const dpc_model *models[1] = {model};
        o.models = models;
        o.n_models = 1;
        o.samples_per_pixel = spp;
        o.dimensions = dims;
        double times[25];
        int runs = 0;
        const double start = now();
        dpc_sampler *s = NULL;
        while (runs < 25 && (runs < 3 || now() - start < 1.5)) {
            dpc_sampler_free(s);
            const double t0 = now();
            if (dpc_sampler_create(&o, &s) != DPC_OK) {
                fprintf(stderr, "create failed: %s\n", dpc_last_error());
                return 1;
            }
            times[runs++] = now() - t0;
        }
        const double create = median(times, runs);
        const unsigned k = spp < 64 ? spp : 64;
        const double ns2 = lookup_ns(s, k, 1, 8), ns1 = lookup_ns(s, k, 0, 8), ns0 = lookup_ns(s, k, 1, 1);
        dpc_sampler *sets = NULL; /* dimension 0 a net, the others sets: their lookup path */
        o.net_dims = 1;
        if (dpc_sampler_create(&o, &sets) != DPC_OK) {
            fprintf(stderr, "create failed: %s\n", dpc_last_error());
            return 1;
        }
        const double ns_sets = lookup_ns(sets, k, 1, 8);
        printf("{\"spp\": %u, \"dims\": %u, \"create_ms\": %.3f, \"runs\": %d, \"get_2d_ns\": %.2f, "
               "\"get_1d_ns\": %.2f, \"get_2d_dim0_ns\": %.2f, \"get_2d_sets_ns\": %.2f, \"table_bytes\": %zu}\n",
               spp, dims, create * 1e3, runs, ns2, ns1, ns0, ns_sets, (size_t)8 * spp * dims);
        dpc_sampler_free(sets);
        dpc_sampler_free(s);
    }
    dpc_model_free(model);
    return 0;
}
