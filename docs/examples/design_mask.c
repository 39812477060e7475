/* Design dpc's annealed blue-noise threshold mask in C (docs/masks.md, "Annealed masks"), e.g.
 * once at load time or in an asset build, and keep it.
 *   cc docs/examples/design_mask.c -Ilibdpc/include -Lbuild/libdpc -ldpc -o design_mask
 *   ./design_mask 64 0 > mask.txt          # 64 x 64, seed 0: the bundled design, about 11 s
 *   ./design_mask 64 0 16 > st.txt         # 64 x 64 x 16 spatiotemporal (frames 16)
 *   ./design_mask 64 0 1 2 > rg.txt        # 64 x 64 with 2 values per pixel (channels 2)
 *
 * dpc_mask_design returns ranks: out[((f * N + y) * N + x) * C + c], each frame and channel holding
 * every rank 0 ... N*N - 1 once; the threshold value of rank r is (r + 0.5) / (N*N) (in a 16-bit
 * texture: r * 65536 / (N*N) for N up to 256). The same ranks on every machine for a seed. This
 * prints, per frame and channel, the ranks row by row. */
#include <stdio.h>
#include <stdlib.h>

#include "dpc/dpc.h"

static int show_progress(void *user, uint64_t done, uint64_t total) {
    (void)user;
    fprintf(stderr, "\r%3.0f %%", 100.0 * (double)done / (double)total);
    return 0; /* nonzero would cancel */
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: %s SIZE [SEED] [FRAMES] [CHANNELS]\n", argv[0]);
        return 2;
    }
    dpc_mask_options o;
    dpc_mask_options_init(&o);
    o.size = (uint32_t)strtoul(argv[1], NULL, 10);
    unsigned long long seed = argc > 2 ? strtoull(argv[2], NULL, 10) : 0;
    if (argc > 3) o.frames = (uint32_t)strtoul(argv[3], NULL, 10);
    if (argc > 4) o.channels = (uint32_t)strtoul(argv[4], NULL, 10);
    o.progress = show_progress;
    size_t count = 0;
    uint32_t *ranks = NULL;
    if (dpc_mask_count(&o, &count) != DPC_OK || !(ranks = malloc(count * sizeof *ranks)) ||
        dpc_mask_design(&o, seed, ranks, NULL) != DPC_OK) {
        fprintf(stderr, "\ndpc: %s\n", ranks || count == 0 ? dpc_last_error() : "out of memory");
        free(ranks);
        return 1;
    }
    fprintf(stderr, "\n");
    const size_t n = o.size, c = o.channels;
    for (size_t f = 0; f < o.frames; f++)
        for (size_t k = 0; k < c; k++) {
            printf("# frame %zu channel %zu: %zu x %zu ranks\n", f, k, n, n);
            for (size_t p = 0; p < n * n; p++)
                printf("%u%c", ranks[(f * n * n + p) * c + k], (p + 1) % n ? ' ' : '\n');
        }
    free(ranks);
    return 0;
}
