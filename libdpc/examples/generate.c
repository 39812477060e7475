/* Minimal libdpc user: load a model, generate one point set, print the first points.
 * From the repository root, after `cmake -S . -B build && cmake --build build`:
 *   cc libdpc/examples/generate.c -Ilibdpc/include -Lbuild/libdpc -Wl,-rpath,"$PWD/build/libdpc" -ldpc -o generate && ./generate models/repulsion-2d.onnx
 * Against an installed libdpc: cc generate.c $(pkg-config --cflags --libs dpc) -o generate */
#include <stdio.h>
#include <stdlib.h>

#include "dpc/dpc.h"

int main(int argc, char **argv) {
    const char *path = argc > 1 ? argv[1] : "models/repulsion-2d.onnx";
    dpc_model *model = NULL;
    if (dpc_model_load_file(path, NULL, &model) != DPC_OK) { /* NULL: default options */
        fprintf(stderr, "dpc: %s\n", dpc_last_error());
        return 1;
    }
    dpc_model_info info;
    dpc_model_get_info(model, &info);
    float *points = malloc(dpc_output_size(model, 1, 0) * sizeof(float));
    if (!points || dpc_generate(model, 42, points) != DPC_OK) { /* seed 42, trained count */
        fprintf(stderr, "dpc: %s\n", points ? dpc_last_error() : "out of memory");
        return 1;
    }
    printf("%s: %u points in %u-D, %u layers\n", dpc_model_name(model), info.n_points, info.dims, info.layers);
    for (unsigned i = 0; i < 3; i++) printf("  (%.6f, %.6f)\n", points[i * info.dims], points[i * info.dims + 1]);
    free(points);
    dpc_model_free(model);
    return 0;
}
