/* Its only job: prove dpc.h (with the product headers it includes) is C99 + -pedantic -Werror
 * clean and usable from C, in the forms the headers document (the sampler's models array and
 * info query, the model search's buffer). Each header alone: the alone_*.c files CMake writes. */
#include "dpc/dpc.h"

int dpc_header_c99_sampler(dpc_model *model, dpc_sampler **out);
int dpc_header_c99_sampler(dpc_model *model, dpc_sampler **out) {
    const dpc_model *models[] = {model}; /* what options.models points to */
    dpc_sampler_options o;
    char path[DPC_PATH_MAX];
    dpc_sampler_options_init(&o);
    o.models = models;
    o.n_models = 1;
    o.progress = NULL;
    o.user = NULL;
    if (dpc_model_find("bnot-2d", path, sizeof path) != DPC_OK) return -1;
    return (int)dpc_sampler_create(&o, out);
}

int dpc_header_c99_sampler_info(const dpc_sampler *sampler);
int dpc_header_c99_sampler_info(const dpc_sampler *sampler) {
    dpc_sampler_info info;
    info.struct_size = sizeof info; /* the caller's size, as the header asks */
    if (dpc_sampler_get_info(sampler, &info) != DPC_OK) return -1;
    return (int)info.net_slots;
}

int dpc_header_c99_check(void);
int dpc_header_c99_check(void) {
    dpc_load_options options;
    dpc_model_info info;
    dpc_status status = DPC_OK;
    (void)options;
    (void)info;
    return (int)status + DPC_VERSION_NUMBER * 0 + DPC_FORMAT_VERSION * 0;
}
