/* What a dpc_model handle holds, and the generation every caller above the backends shares (the
 * API, the sampler): the model layer's handle over the backends (cpu/, vulkan/). */
#ifndef DPC_MODEL_MODEL_HANDLE_H
#define DPC_MODEL_MODEL_HANDLE_H

#include "cpu/cpu_cascade.h"
#include "model/model.h"
#if defined(DPC_HAVE_VULKAN)
#include "vulkan/vk_backend.h"
#endif

/* The most floats one set may hold (n_points * dims): 1 GiB. */
#define DPC_MAX_FLOATS_PER_SET (1ull << 28)

struct dpc_model {
    dpc_cascade cascade;
    dpc_cpu_engine engine; /* CPU backend; also what info.isa / info.threads report */
    dpc_backend backend;   /* resolved: CPU or VULKAN */
    dpc_input input;       /* resolved: UNIFORM or STRATIFIED, the points generate filters */
    double neighbours;     /* max over layers and subspaces of V_k rho^k (dpc_model_neighbours) */
    double max_neighbours; /* dpc_load_options.max_neighbours: the bound dpc_model_check_count applies */
#if defined(DPC_HAVE_VULKAN)
    dpc_vk_engine *vk; /* the Vulkan backend, when backend == DPC_BACKEND_VULKAN */
#endif
};

/* Resolve a request's point count (0: the trained count) into *n_points and check it against
 * DPC_MAX_POINTS, DPC_MAX_FLOATS_PER_SET, a gridded model's count and the model's work bound
 * (max_neighbours); a failure is a status with its message. */
dpc_status dpc_model_check_count(const dpc_model *model, size_t *n_points);

/* dpc_generate_n of the model's cascade and input kind on the CPU backend with one thread,
 * whatever the handle's threads and backend: the points every machine gives (every CPU ISA path
 * gives the same bits; the Vulkan backend does not). hook (or NULL) is polled as in dpc_cpu_generate:
 * a status other than DPC_OK stops it with DPC_ERROR_CANCELLED. */
dpc_status dpc_model_generate_cpu(const dpc_model *model, uint64_t seed, size_t m, float *out, dpc_cpu_hook hook,
                                  void *ctx);

#endif
