/* What a dpc_model handle holds, shared by the API files (api.c, api_sampler.c). */
#ifndef DPC_API_MODEL_HANDLE_H
#define DPC_API_MODEL_HANDLE_H

#include "cpu/cpu_cascade.h"
#include "model/model.h"
#if defined(DPC_HAVE_VULKAN)
#include "vulkan/vk_backend.h"
#endif

struct dpc_model {
    dpc_cascade cascade;
    dpc_cpu_engine engine; /* CPU backend; also what info.isa / info.threads report */
    dpc_backend backend;   /* resolved: CPU or VULKAN */
    dpc_input input;       /* resolved: UNIFORM or STRATIFIED, the points generate filters */
    double neighbours;     /* max over layers and subspaces of V_k rho^k (dpc_model_neighbours) */
    double max_neighbours; /* dpc_load_options.max_neighbours: the bound check_count applies */
#if defined(DPC_HAVE_VULKAN)
    dpc_vk_engine *vk; /* the Vulkan backend, when backend == DPC_BACKEND_VULKAN */
#endif
};

/* dpc_generate_n of the model's cascade and input kind on the CPU backend with one thread,
 * whatever the handle's threads and backend: the points every machine gives (every CPU ISA path
 * gives the same bits; the Vulkan backend does not). hook (or NULL) is polled as in dpc_cpu_generate:
 * a status other than DPC_OK stops it with DPC_ERROR_CANCELLED. */
dpc_status dpc_model_generate_cpu(const dpc_model *model, uint64_t seed, size_t m, float *out, dpc_cpu_hook hook,
                                  void *ctx);

#endif
