/* The cascade description every backend runs: what docs/model-format.md says a file means. */
#ifndef DPC_MODEL_MODEL_H
#define DPC_MODEL_MODEL_H

#include <stddef.h>
#include <stdint.h>

#include "dpc/dpc.h"

/* Caps from docs/model-format.md; checked before anything is allocated. */
#define DPC_MAX_LAYERS 4096u
#define DPC_MAX_SUBSPACES 64u
#define DPC_MAX_BINS 65536u
#define DPC_MAX_KERNEL_VALUES (1u << 26)
#define DPC_MAX_META 1024u
#define DPC_MAX_META_KEY 4096u
#define DPC_MAX_META_VALUE (1u << 20)
#define DPC_MAX_FILE_BYTES (1ull << 30)

typedef struct dpc_layer {
    uint32_t n_sub; /* subspaces s */
    uint32_t bins;  /* b */
    float eps;      /* cutoff in units of mean spacing */
    uint64_t fixed; /* dimensions this layer never moves */
    uint64_t masks[DPC_MAX_SUBSPACES];
    float radius[DPC_MAX_SUBSPACES]; /* rho_t, in units of mean spacing */
    float *kernels;                  /* [n_sub * bins], row t = subspace t */
    float *slopes;                   /* [n_sub * bins], kernels[q+1] - kernels[q] (last entry 0) */
} dpc_layer;

typedef struct dpc_cascade {
    uint32_t dims;
    uint32_t n_points;
    uint32_t n_layers;
    dpc_layer *layers;
    uint32_t grid_dims;
    uint32_t grid_axis[DPC_MAX_DIMS];
    uint32_t grid_shape[DPC_MAX_DIMS];
    uint32_t progressive_base; /* 0: a set; else generated level by level from this count (format §6) */
    uint32_t balance;          /* 0: none; else the generator's output balance radius (format §5.1) */
    uint32_t relax;            /* 0: none; else the prefix relaxation's steps after the levels (format §6.1) */
    size_t n_meta;
    char **meta_keys;
    char **meta_values;
} dpc_cascade;

/* Parse and validate a model file image. On success *out is a fully owned cascade. */
dpc_status dpc_cascade_parse(const uint8_t *data, size_t size, dpc_cascade *out);
void dpc_cascade_release(dpc_cascade *cascade);
const char *dpc_cascade_meta(const dpc_cascade *cascade, const char *key);

#endif
