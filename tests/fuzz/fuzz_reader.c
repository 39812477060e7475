/* libFuzzer target for the libdpc model reader (public API only).
 *
 * Every input is loaded with dpc_model_load_memory. A failure must come with a message and leave
 * *out_model NULL. A model that loads must answer dpc_model_get_info sensibly, list its metadata,
 * and generate a small point set (at most 64 points, or the grid's count for small grids) whose
 * coordinates all lie in [0, 1). Any violation traps, which libFuzzer reports as a crash;
 * ASan/UBSan catch memory errors and undefined behaviour on the way. */
#include <dpc/dpc.h>

#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define CHECK(cond)                    \
    do {                               \
        if (!(cond)) __builtin_trap(); \
    } while (0)

/* Work bound for the generate step: points^2 * layers (keeps each input well under a second). */
#define MAX_PAIR_LAYERS (1u << 22)

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

    size_t n = info.grid_dims ? info.n_points : (info.n_points < 64 ? info.n_points : 64);
    if ((uint64_t)n * n * info.layers <= MAX_PAIR_LAYERS) {
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
