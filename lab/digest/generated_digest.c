/* Digest of what libdpc generates: every bundled model's sets (two seeds at its trained count,
 * one at 3,000 points), twelve samplers' values (three models, 1-64 spp), a 16 x 16 mask design.
 * Run by lab/digest/compare_generated.sh, which compares two builds. */
#include "dpc/dpc.h"
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
static uint64_t hsh = 1469598103934665603ull;
static void mix(const void *p, size_t n) {
    const unsigned char *c = p;
    for (size_t i = 0; i < n; i++) {
        hsh ^= c[i];
        hsh *= 1099511628211ull;
    }
}
static int cmp(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }
int main(int argc, char **argv) {
    const char *dir = argv[1];
    DIR *d = opendir(dir);
    struct dirent *e;
    char *names[256];
    int nn = 0;
    while ((e = readdir(d)))
        if (strstr(e->d_name, ".onnx")) names[nn++] = strdup(e->d_name);
    closedir(d);
    qsort(names, nn, sizeof *names, cmp);
    for (int i = 0; i < nn; i++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        dpc_model *m = NULL;
        if (dpc_model_load_file(path, NULL, &m) != DPC_OK) {
            printf("%s: load failed\n", names[i]);
            continue;
        }
        dpc_model_info info;
        dpc_model_get_info(m, &info);
        size_t cnt = info.n_points > 70000 ? 0 : 1;
        uint64_t h0 = hsh;
        for (uint64_t seed = 0; seed < 2 && cnt; seed++) {
            size_t nf = dpc_output_size(m, 1, 0);
            float *out = malloc(nf * sizeof(float));
            dpc_status st = dpc_generate(m, seed, out);
            mix(&st, sizeof st);
            if (st == DPC_OK) mix(out, nf * sizeof(float));
            free(out);
        }
        size_t nf2 = dpc_output_size(m, 1, 3000);
        float *o2 = malloc((nf2 ? nf2 : 1) * sizeof(float));
        dpc_status st2 = dpc_generate_n(m, 5, 3000, o2);
        mix(&st2, sizeof st2);
        if (st2 == DPC_OK) mix(o2, nf2 * sizeof(float));
        free(o2);
        printf("%-32s %016llx\n", names[i], (unsigned long long)(hsh ^ h0));
        dpc_model_free(m);
    }
    const char *smodels[] = {"bnot-2d-stratified.onnx", "progressive-2d.onnx", "bnot-2d.onnx"};
    for (int k = 0; k < 3; k++)
        for (uint32_t spp = 1; spp <= 64; spp *= 4) {
            char path[4096];
            snprintf(path, sizeof path, "%s/%s", dir, smodels[k]);
            dpc_model *m = NULL;
            dpc_model_load_file(path, NULL, &m);
            const dpc_model *ms[1] = {m};
            dpc_sampler_options o;
            dpc_sampler_options_init(&o);
            o.models = ms;
            o.n_models = 1;
            o.samples_per_pixel = spp;
            o.dimensions = 8;
            o.seed = 11;
            dpc_sampler *s = NULL;
            dpc_status st = dpc_sampler_create(&o, &s);
            mix(&st, sizeof st);
            if (st == DPC_OK) {
                for (uint32_t y = 0; y < 16; y++)
                    for (uint32_t x = 0; x < 16; x++)
                        for (uint32_t i = 0; i < 2 * spp; i++)
                            for (uint32_t dd = 0; dd < 10; dd++) {
                                float v[2];
                                dpc_sampler_get_2d(s, x, y, i, dd, v);
                                mix(v, 8);
                                dpc_sampler_get_1d(s, x + 100, y, i, dd, v);
                                mix(v, 4);
                            }
                dpc_sampler_free(s);
            }
            dpc_model_free(m);
        }
    printf("after samplers %016llx\n", (unsigned long long)hsh);
    dpc_mask_options mo;
    dpc_mask_options_init(&mo);
    mo.size = 16;
    size_t mc = 0;
    dpc_mask_count(&mo, &mc);
    uint32_t *ranks = malloc(mc * 4);
    dpc_status sm = dpc_mask_design(&mo, 3, ranks, NULL);
    mix(&sm, sizeof sm);
    if (sm == DPC_OK) mix(ranks, mc * 4);
    printf("all %016llx\n", (unsigned long long)hsh);
    return 0;
}
