/* A downstream C program: finds a bundled model by name (dpc_model_load_named: DPC_MODEL_PATH,
 * then the installed share/dpc/models) and generates one set with it; built with
 * MODEL_FOLDER (e.g. the CMake package's DPC_MODEL_DIR), it loads NAME.onnx from that
 * folder with dpc_model_load_file instead. Built by tests/downstream/run.sh against an installed
 * libdpc, through find_package(dpc), pkg-config and add_subdirectory. */
#define _XOPEN_SOURCE 700 /* realpath */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <dpc/dpc.h>

int main(int argc, char **argv) {
    const char *name = argc > 1 ? argv[1] : "bnot-2d";
    dpc_model *model = NULL;
#ifdef MODEL_FOLDER
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.onnx", MODEL_FOLDER, name);
    if (dpc_model_load_file(path, NULL, &model) != DPC_OK) {
#else
    if (dpc_model_load_named(name, NULL, &model) != DPC_OK) {
#endif
        fprintf(stderr, "downstream: %s\n", dpc_last_error());
        return 1;
    }
    dpc_model_info info;
    dpc_model_get_info(model, &info);
    float *points = malloc(dpc_output_size(model, 1, 0) * sizeof(float));
    if (!points || dpc_generate(model, 7, points) != DPC_OK) {
        fprintf(stderr, "downstream: %s\n", points ? dpc_last_error() : "out of memory");
        return 1;
    }
    double sum = 0.0;
    for (size_t i = 0; i < (size_t)info.n_points * info.dims; i++) sum += points[i];
    printf("downstream: libdpc %s, %s: %u points in %u-D, mean coordinate %.3f, models in %s\n", dpc_version_string(),
           dpc_model_name(model), info.n_points, info.dims, sum / ((double)info.n_points * info.dims), dpc_model_dir());
#ifdef DPC_EXPECTED_MODEL_DIR
    /* the folder the CMake package says (DPC_MODEL_DIR) is the one libdpc searches */
    char *expected = realpath(DPC_EXPECTED_MODEL_DIR, NULL);
    const int same = expected && strcmp(expected, dpc_model_dir()) == 0;
    free(expected);
    if (!same) {
        fprintf(stderr, "downstream: DPC_MODEL_DIR is %s, dpc_model_dir() %s\n", DPC_EXPECTED_MODEL_DIR,
                dpc_model_dir());
        return 1;
    }
#endif
    free(points);
    dpc_model_free(model);
    return 0;
}
