/* The masks' ABI boundary: checks every option, then designs (docs/masks.md). */
#include <string.h>

#include "common/error.h"
#include "mask/mask_design.h"

void dpc_mask_options_init(dpc_mask_options *options) {
    if (!options) return;
    memset(options, 0, sizeof *options);
    options->struct_size = (uint32_t)sizeof *options;
    options->size = 64;
    options->frames = 1;
    options->channels = 1;
    options->steps_per_pixel = 600;
}

static dpc_status check_options(const dpc_mask_options *o) {
    if (!o) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "options is NULL");
    if (o->struct_size != sizeof *o)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                        "options.struct_size is %u, expected %u: initialise with dpc_mask_options_init", o->struct_size,
                        (unsigned)sizeof *o);
    if (o->size < 8 || o->size > DPC_MASK_MAX_SIZE)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "options.size is %u, must be 8 .. %u", o->size, DPC_MASK_MAX_SIZE);
    if (o->frames < 1 || o->frames > DPC_MASK_MAX_FRAMES)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "options.frames is %u, must be 1 .. %u", o->frames,
                        DPC_MASK_MAX_FRAMES);
    if (o->channels != 1 && o->channels != 2)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "options.channels is %u, must be 1 or 2", o->channels);
    if (o->channels == 2 && o->frames != 1)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                        "options.channels is 2 and options.frames is %u: give channels or frames, not both", o->frames);
    const uint64_t state = dpc_mask_state_bytes(o->size, o->frames, o->channels);
    if (state > DPC_MASK_MAX_STATE)
        return dpc_fail(DPC_ERROR_LIMIT,
                        "a %u x %u x %u design needs %.1f GiB of spectra (limit %.0f GiB): use fewer frames or a "
                        "smaller size",
                        o->size, o->size, o->frames * o->channels, (double)state / (1ull << 30),
                        (double)DPC_MASK_MAX_STATE / (1ull << 30));
    return DPC_OK;
}

dpc_status dpc_mask_count(const dpc_mask_options *options, size_t *out_count) {
    dpc_clear_error();
    if (!out_count) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "out_count is NULL");
    *out_count = 0;
    dpc_status st = check_options(options);
    if (st != DPC_OK) return st;
    *out_count = (size_t)options->frames * options->size * options->size * options->channels;
    return DPC_OK;
}

dpc_status dpc_mask_design(const dpc_mask_options *options, uint64_t seed, uint32_t *out_ranks,
                           dpc_mask_stats *out_stats) {
    dpc_clear_error();
    dpc_status st = check_options(options);
    if (st != DPC_OK) return st;
    if (!out_ranks) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "out_ranks is NULL");
    return dpc_mask_design_run(options, seed, out_ranks, out_stats);
}
