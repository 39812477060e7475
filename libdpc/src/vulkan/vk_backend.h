/* The Vulkan backend as the rest of libdpc sees it: no Vulkan type appears here, so api.c
 * compiles without Vulkan headers. Only built with -DDPC_VULKAN=ON (DPC_HAVE_VULKAN). */
#ifndef DPC_VULKAN_VK_BACKEND_H
#define DPC_VULKAN_VK_BACKEND_H

#include <stddef.h>
#include <stdint.h>

#include "model/model.h"

typedef struct dpc_vk_engine dpc_vk_engine;

/* 1 when the machine has a hardware GPU (discrete, integrated or virtual) with a Vulkan driver
 * and a compute queue. Looked up once per process; never fails (no loader or driver: 0). */
int dpc_vk_gpu_present(void);

/* A device, its pipelines and the cascade's kernel tables. gpu_only: accept only hardware GPUs
 * (the DPC_BACKEND_AUTO policy), else the best device present, software drivers included.
 * Failures: DPC_ERROR_UNSUPPORTED (no loader, no usable device, a device limit), out of memory,
 * or a Vulkan call's failure, with the VkResult in the message. */
dpc_status dpc_vk_engine_create(const dpc_cascade *c, int gpu_only, dpc_vk_engine **out);
void dpc_vk_engine_destroy(dpc_vk_engine *e);

/* Name of the device the engine runs on (valid while the engine lives). */
const char *dpc_vk_engine_device(const dpc_vk_engine *e);

/* Writes the input points of set `set` of a run (m * dims floats) to x. */
typedef void (*dpc_vk_fill_fn)(void *ctx, size_t set, float *x);

/* Filter `count` sets of m points on the device: set s starts as fill(ctx, s, ...) and ends in
 * out + s * m * dims. Calls on one engine are serialised by its mutex (the engine owns one
 * queue, one command buffer and one set of work buffers); the bits of a set do not depend on
 * the other sets of the run or on timing. */
dpc_status dpc_vk_run(dpc_vk_engine *e, const dpc_cascade *c, size_t count, size_t m, dpc_vk_fill_fn fill, void *ctx,
                      float *out);

#endif
