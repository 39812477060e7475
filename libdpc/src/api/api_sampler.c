/* The sampler's ABI boundary: checks every argument, builds the tables (docs/rendering.md). */
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "common/error.h"
#include "model/model_handle.h"
#include "sampler/sampler.h"

#define MAX_TABLE_POINTS (1ull << 24) /* D * spp: 128 MiB of tables */

void dpc_sampler_options_init(dpc_sampler_options *options) {
    if (!options) return;
    memset(options, 0, sizeof *options);
    options->struct_size = (uint32_t)sizeof *options;
    options->samples_per_pixel = 16;
    options->dimensions = 16;
    options->fold_from = DPC_SAMPLER_NO_FOLD;
    options->net_dims = DPC_SAMPLER_NET_DIMS_AUTO;
    options->net_layout = DPC_SAMPLER_NETS_AUTO;
    options->frames = 1;
}

/* The caller's options in the current layout: older callers pass the struct without `progress`
 * and `user` (struct_size = their offset), which default to none. */
static dpc_status read_options(const dpc_sampler_options *options, dpc_sampler_options *o) {
    dpc_sampler_options_init(o);
    const size_t before_progress = offsetof(dpc_sampler_options, progress);
    const size_t before_layout = offsetof(dpc_sampler_options, net_layout);
    if (options->struct_size == sizeof *o) {
        *o = *options;
    } else if (options->struct_size == before_progress || options->struct_size == before_layout) {
        memcpy(o, options, options->struct_size);
        o->struct_size = (uint32_t)sizeof *o;
    } else {
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                        "options.struct_size is %u, expected %u: initialise with dpc_sampler_options_init",
                        options->struct_size, (unsigned)sizeof *o);
    }
    if (o->frames == 0) o->frames = 1; /* an older caller's zeroed padding */
    return DPC_OK;
}

static dpc_status check_options(const dpc_sampler_options *o) {
    if (!o->models || o->n_models == 0)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "options.models is NULL or n_models is 0: give at least one model");
    for (uint32_t j = 0; j < o->n_models; j++) {
        const dpc_model *m = o->models[j];
        if (!m) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "options.models[%u] is NULL", j);
        if (m->cascade.dims < 2)
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                            "options.models[%u] (%.64s) has %u dimension: a sampler needs models of 2 or more", j,
                            dpc_model_name(m), m->cascade.dims);
        if (m->cascade.grid_dims)
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                            "options.models[%u] (%.64s) is gridded: a sampler needs point models", j,
                            dpc_model_name(m));
        if (!m->cascade.progressive_base != !o->models[0]->cascade.progressive_base)
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                            "options.models[%u] (%.64s) is %s and options.models[0] (%.64s) is not: give only "
                            "progressive models or only set models",
                            j, dpc_model_name(m), m->cascade.progressive_base ? "progressive" : "a set model",
                            dpc_model_name(o->models[0]));
    }
    if (o->net_layout != DPC_SAMPLER_NETS_PER_PIXEL && o->net_layout != DPC_SAMPLER_NETS_SCREEN &&
        o->net_layout != DPC_SAMPLER_NETS_AUTO)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                        "options.net_layout is %u: DPC_SAMPLER_NETS_PER_PIXEL (0), DPC_SAMPLER_NETS_SCREEN (1) or "
                        "DPC_SAMPLER_NETS_AUTO",
                        o->net_layout);
    if (o->samples_per_pixel < 1 || o->samples_per_pixel > DPC_SAMPLER_MAX_SPP)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "options.samples_per_pixel is %u, must be 1 .. %u",
                        o->samples_per_pixel, DPC_SAMPLER_MAX_SPP);
    if (o->dimensions < 1 || o->dimensions > DPC_SAMPLER_MAX_DIMENSIONS)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "options.dimensions is %u, must be 1 .. %u", o->dimensions,
                        DPC_SAMPLER_MAX_DIMENSIONS);
    const uint32_t frames = o->frames; /* at least 1 (read_options) */
    if ((uint64_t)o->samples_per_pixel * frames > DPC_SAMPLER_MAX_SPP)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                        "options.frames is %u: %u samples per pixel x %u frames exceeds DPC_SAMPLER_MAX_SPP (%u)",
                        o->frames, o->samples_per_pixel, o->frames, DPC_SAMPLER_MAX_SPP);
    if (frames > 1 && o->net_dims != 0 && o->net_dims != DPC_SAMPLER_NET_DIMS_AUTO)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                        "options.net_dims is %u with options.frames %u: frames hold no net slots (give 0 or "
                        "DPC_SAMPLER_NET_DIMS_AUTO)",
                        o->net_dims, o->frames);
    if ((uint64_t)o->samples_per_pixel * frames * o->dimensions > MAX_TABLE_POINTS)
        return dpc_fail(DPC_ERROR_LIMIT, "%u samples per pixel x %u frames x %u dimensions exceeds 2^24 table points",
                        o->samples_per_pixel, frames, o->dimensions);
    return DPC_OK;
}

dpc_status dpc_sampler_create(const dpc_sampler_options *options, dpc_sampler **out_sampler) {
    dpc_clear_error();
    if (!out_sampler) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "out_sampler is NULL");
    *out_sampler = NULL;
    if (!options) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "options is NULL");
    dpc_sampler_options o;
    dpc_status st = read_options(options, &o);
    if (st != DPC_OK || (st = check_options(&o)) != DPC_OK) return st;
    dpc_sampler *s = (dpc_sampler *)calloc(1, sizeof *s);
    if (!s) return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory");
    if ((st = dpc_sampler_build(s, &o)) != DPC_OK) {
        dpc_sampler_free(s);
        return st;
    }
    *out_sampler = s;
    return DPC_OK;
}

void dpc_sampler_free(dpc_sampler *sampler) {
    if (!sampler) return;
    free(sampler->tables);
    free(sampler->keys);
    free(sampler->shifted);
    free(sampler->nets);
    free(sampler->net_index);
    free(sampler->sobol1);
    free(sampler);
}

dpc_status dpc_sampler_get_1d(const dpc_sampler *sampler, uint32_t x, uint32_t y, uint32_t index, uint32_t dimension,
                              float *out) {
    if (!sampler || !out) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "sampler or out is NULL");
    return dpc_sampler_lookup_1d(sampler, x, y, index, dimension, out);
}

dpc_status dpc_sampler_get_2d(const dpc_sampler *sampler, uint32_t x, uint32_t y, uint32_t index, uint32_t dimension,
                              float *out) {
    if (!sampler || !out) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "sampler or out is NULL");
    return dpc_sampler_lookup_2d(sampler, x, y, index, dimension, out);
}

dpc_status dpc_sampler_get_info(const dpc_sampler *sampler, dpc_sampler_info *out_info) {
    dpc_clear_error();
    if (!sampler || !out_info) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "sampler or out_info is NULL");
    const uint32_t size = out_info->struct_size, before_layout = (uint32_t)offsetof(dpc_sampler_info, net_layout);
    if (size != sizeof *out_info && size != before_layout)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                        "out_info->struct_size is %u, expected %u: set it to sizeof(dpc_sampler_info)",
                        out_info->struct_size, (unsigned)sizeof *out_info);
    dpc_sampler_info info;
    memset(&info, 0, sizeof info);
    info.struct_size = size;
    info.samples_per_pixel = sampler->spp / sampler->frames;
    info.frames = sampler->frames;
    info.dimensions = sampler->slots;
    info.fold_from = sampler->fold_from;
    info.net_slots = sampler->net_slots;
    info.progressive = sampler->rotate == 0;
    info.seed = sampler->seed;
    info.net_layout = sampler->net_layout;
    memcpy(out_info, &info, size); /* an older caller's struct ends before net_layout */
    return DPC_OK;
}

dpc_status dpc_sampler_table(const dpc_sampler *sampler, uint32_t t, const float **out_table) {
    dpc_clear_error();
    if (!sampler || !out_table) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "sampler or out_table is NULL");
    if (t >= sampler->slots)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "table %u out of range (the sampler has %u)", t, sampler->slots);
    *out_table = sampler->tables + (size_t)t * sampler->spp * 2;
    return DPC_OK;
}

const float *dpc_sampler_mask(void) { return dpc_sampler_mask_data; }
