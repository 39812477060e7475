/* Bake a blue-noise threshold mask from a gridded dpc mask model at load time (docs/masks.md).
 *   cc docs/examples/bake_mask.c -Ilibdpc/include -Lbuild/libdpc -ldpc -o bake_mask
 *   ./bake_mask models/mask-64.onnx 7 > mask.txt      # seed 7: one rank per pixel, row by row
 *
 * dpc_generate gives one point per grid cell: point i sits in cell (i mod G0, (i / G0) mod G1, ...)
 * (docs/model-format.md section 5) and its free coordinates are the mask values of that pixel
 * (and frame). A mask is used by rank: value (rank + 0.5) / S, each rank once per threshold map
 * (S pixels), so every grey level is reached by exactly its share of pixels. Ties (equal floats)
 * are broken by pixel index, as dpc.mask does. This prints, for each value channel, the ranks in
 * pixel order; an engine would store (rank + 0.5) / S, or rank * 65536 / S in a 16-bit texture. */
#include <stdio.h>
#include <stdlib.h>

#include "dpc/dpc.h"

static const float *g_vals;
static size_t g_stride;

static int by_value(const void *a, const void *b) {
    size_t i = *(const size_t *)a, j = *(const size_t *)b;
    float x = g_vals[i * g_stride], y = g_vals[j * g_stride];
    if (x < y) return -1;
    if (x > y) return 1;
    return (i > j) - (i < j);
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: %s MODEL.onnx [SEED]\n", argv[0]);
        return 2;
    }
    unsigned long long seed = argc > 2 ? strtoull(argv[2], NULL, 10) : 0;
    dpc_model *model = NULL;
    if (dpc_model_load_file(argv[1], NULL, &model) != DPC_OK) {
        fprintf(stderr, "dpc: %s\n", dpc_last_error());
        return 1;
    }
    dpc_model_info info;
    dpc_model_get_info(model, &info);
    if (info.grid_dims < 2) {
        fprintf(stderr, "dpc: %s is not a gridded mask model\n", argv[1]);
        dpc_model_free(model);
        return 1;
    }
    size_t m = info.n_points, n = info.dims;
    /* pixels of one threshold map: the first two grid axes; a third grid axis is time */
    size_t per_map = (size_t)info.grid_shape[0] * info.grid_shape[1];
    float *pts = malloc(dpc_output_size(model, 1, 0) * sizeof(float));
    size_t *order = malloc(per_map * sizeof(size_t));
    unsigned *rank = malloc(m * sizeof(unsigned));
    if (!pts || !order || !rank || dpc_generate(model, seed, pts) != DPC_OK) {
        fprintf(stderr, "dpc: %s\n", pts && order && rank ? dpc_last_error() : "out of memory");
        return 1;
    }
    for (size_t d = 0; d < n; d++) {
        int gridded = 0;
        for (uint32_t g = 0; g < info.grid_dims; g++) gridded |= info.grid_axis[g] == d;
        if (gridded) continue;                         /* a pixel or frame coordinate */
        for (size_t map = 0; map < m / per_map; map++) {  /* one threshold map per frame */
            g_vals = pts + map * per_map * n + d;
            g_stride = n;
            for (size_t i = 0; i < per_map; i++) order[i] = i;
            qsort(order, per_map, sizeof(size_t), by_value);
            for (size_t r = 0; r < per_map; r++) rank[map * per_map + order[r]] = (unsigned)r;
        }
        printf("# value axis %zu: %zu pixels x %zu maps, ranks 0..%zu\n", d, per_map, m / per_map, per_map - 1);
        for (size_t i = 0; i < m; i++) printf("%u%c", rank[i], (i + 1) % info.grid_shape[0] ? ' ' : '\n');
    }
    free(rank);
    free(order);
    free(pts);
    dpc_model_free(model);
    return 0;
}
