/* libFuzzer target for the libdpc model reader (public API only).
 *
 * Every input is loaded with dpc_model_load_memory. A failure must come with a message and leave
 * *out_model NULL. A model that loads must answer dpc_model_get_info sensibly, list its metadata,
 * and generate a small point set (at most 64 points, fewer while its work, relaxation included,
 * is beyond MAX_WORK; the grid's count for small grids) whose coordinates all lie in [0, 1).
 * Any violation traps, which libFuzzer reports as a crash; ASan/UBSan catch memory errors and
 * undefined behaviour on the way. */
#include <dpc/dpc.h>

#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define CHECK(cond)                    \
    do {                               \
        if (!(cond)) __builtin_trap(); \
    } while (0)

/* Work bound for the generate step, in pair visits (keeps each input well under a second). */
#define MAX_WORK (1u << 22)
/* A relaxation step's fixed cost (its phases, frequencies and neighbour grid), in pair visits. */
#define RELAX_STEP_WORK 256u

/* The work of generating n points, bounded the way the library bounds it: the cascade visits
 * about n^2 pairs per layer at these sizes, once per progressive level (each level filters the
 * points so far again), and a model with dpc.relax = S (the reader accepts 1 .. 100,000, the
 * library's bound: at most that many steps) relaxes the whole set S times afterwards, each step
 * visiting the pairs of every prefix (at most 2 n^2) plus its fixed cost. */
static uint64_t generate_work(const dpc_model *model, const dpc_model_info *info, size_t n) {
    const char *base_s = dpc_model_metadata(model, "dpc.progressive_base");
    const char *relax_s = dpc_model_metadata(model, "dpc.relax");
    const uint64_t base = base_s ? strtoull(base_s, NULL, 10) : 0;
    const uint64_t relax = relax_s ? strtoull(relax_s, NULL, 10) : 0; /* checked by the reader */
    uint64_t levels = 1;
    for (uint64_t m = base; base && m < n; m *= 2) levels++;
    return (uint64_t)n * n * info->layers * levels + relax * (2ull * n * n + RELAX_STEP_WORK);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    dpc_load_options opts;
    dpc_load_options_init(&opts);
    /* Alternate the code paths: odd sizes run the scalar path, even sizes the best one. */
    opts.isa = (size & 1) ? DPC_ISA_SCALAR : DPC_ISA_AUTO;
    opts.threads = 1;

    dpc_model *model = (dpc_model *)(uintptr_t)1;
    dpc_status st = dpc_model_load_memory(data, size, &opts, &model);
    if (st != DPC_OK) {
        const char *msg = dpc_last_error();
        CHECK(model == NULL);
        CHECK(msg != NULL && msg[0] != '\0');
        CHECK(st != DPC_ERROR_INTERNAL);
        return 0;
    }
    CHECK(model != NULL);

    dpc_model_info info;
    CHECK(dpc_model_get_info(model, &info) == DPC_OK);
    CHECK(info.dims >= 1 && info.dims <= DPC_MAX_DIMS);
    CHECK(info.n_points >= 1 && info.n_points <= DPC_MAX_POINTS);
    CHECK(info.layers >= 1 && info.layers <= 4096);
    CHECK(info.grid_dims < info.dims);
    CHECK(info.isa != DPC_ISA_AUTO);
    uint64_t cells = 1;
    for (uint32_t g = 0; g < info.grid_dims; g++) {
        CHECK(info.grid_axis[g] < info.dims);
        CHECK(g == 0 || info.grid_axis[g] > info.grid_axis[g - 1]);
        cells *= info.grid_shape[g];
    }
    CHECK(!info.grid_dims || cells == info.n_points);

    CHECK(dpc_model_name(model) != NULL);
    size_t n_meta = dpc_model_metadata_count(model);
    for (size_t i = 0; i < n_meta; i++) {
        const char *k = NULL, *v = NULL;
        CHECK(dpc_model_metadata_at(model, i, &k, &v) == DPC_OK);
        CHECK(k != NULL && v != NULL);
        CHECK(dpc_model_metadata(model, k) != NULL);
    }

    /* at most 64 points (a grid: its count), fewer while the work is beyond the bound */
    size_t n = info.grid_dims ? info.n_points : (info.n_points < 64 ? info.n_points : 64);
    while (!info.grid_dims && n > 2 && generate_work(model, &info, n) > MAX_WORK) n /= 2;
    if (generate_work(model, &info, n) <= MAX_WORK) {
        size_t floats = n * info.dims;
        float *out = (float *)malloc(floats * sizeof(float));
        CHECK(out != NULL);
        uint64_t seed = size;
        st = dpc_generate_n(model, seed, info.grid_dims ? 0 : n, out);
        if (st == DPC_OK) {
            for (size_t i = 0; i < floats; i++) CHECK(out[i] >= 0.0f && out[i] < 1.0f);
        } else {
            const char *msg = dpc_last_error();
            CHECK(msg != NULL && msg[0] != '\0');
            CHECK(st != DPC_ERROR_INTERNAL);
        }
        free(out);
    }
    dpc_model_free(model);
    return 0;
}
