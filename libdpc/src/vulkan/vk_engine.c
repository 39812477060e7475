/* Vulkan backend: runs a cascade on the device (docs/model-format.md §3), many sets per dispatch.
 *
 * One call records every layer of the cascade into one command buffer. Per layer and moving
 * subspace, neighbours come from a cell grid built on the device (cells.comp: cell of each
 * point and counts; scan_*.comp: cell starts; scatter.comp + cellsort.comp: points by cell, in
 * point-index order within a cell; grid_sum.comp: the filter sum over the cells around each
 * point), or from tiled all pairs in shared memory (pairs.comp, split over partner ranges
 * and summed by pairs_sum.comp when a set has too few points to fill a GPU) where the grid does
 * not pay; apply.comp ends the layer. Every point's sum is computed in a fixed order, so the bits
 * depend on the device and driver but not on timing. Radii, cutoffs, bin scales, c_k and the
 * grid-or-all-pairs choice come from the subspace plan the CPU engine uses (model/plan.h,
 * float32). The input points are made on the host (model/input.h, as for the CPU backend) and
 * uploaded. */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/error.h"
#include "model/plan.h"
#include "vulkan/vk_backend.h"
#include "vulkan/vk_loader.h"
#include "vulkan/vk_spirv.h"

/* Pipelines. */
enum {
    P_CELLS,
    P_SCAN_REDUCE,
    P_SCAN_PARTIALS,
    P_SCAN_DOWN,
    P_SCATTER,
    P_CELLSORT,
    P_GRID_SUM,
    P_APPLY,
    P_PAIRS_SUM,
    P_PAIRS, /* + ceil(k / 4) - 1: one all-pairs variant per vec4 count, 1 .. 16 */
    P_COUNT = P_PAIRS + DPC_MAX_DIMS / 4
};
/* Storage buffer bindings (shaders/common.glsl). */
enum { B_X, B_DELTA, B_CELL_OF, B_COUNTS, B_STARTS, B_SORTED, B_COORDS, B_TABLES, B_PARTIALS, B_SPLIT, B_COUNT };

#define SCAN_BLOCK 1024u           /* cells per scan block (common.glsl SCAN_BLOCK) */
#define MAX_GROUPS 65535u          /* workgroups per dispatch dimension that every device allows */
#define WORK_BUDGET (256ull << 20) /* device bytes a batch aims to stay within (more for one big set) */
#define PAIR_UNITS 2048u           /* all-pairs workgroups per set that the partner split aims for */
#define PAIR_CHUNK_MIN 256u        /* fewest partners per split range */

/* The push constants: mirrors `Params` in shaders/common.glsl, 4-byte fields in order. */
typedef struct vk_params {
    uint32_t m, n, k, cells, G, R, cstride, nblocks, w_off, dw_off;
    int32_t qmax;
    uint32_t c_off;
    float h, radius, cutoff, scale, umax;
    uint32_t mask_lo, mask_hi, dims, splits;
} vk_params;
_Static_assert(sizeof(vk_params) == 84, "push constants must match shaders/common.glsl");

typedef struct vk_buffer {
    VkBuffer buf;
    VkDeviceMemory mem;
    VkDeviceSize size;
    void *map; /* host-visible buffers: mapped for their lifetime */
} vk_buffer;

struct dpc_vk_engine {
    dpc_vk_fns fn;
    VkInstance instance; /* shared_instance(): not the engine's to destroy */
    VkPhysicalDevice phys;
    VkDevice device;
    VkQueue queue;
    uint32_t family;
    char name[VK_MAX_PHYSICAL_DEVICE_NAME_SIZE];
    VkDeviceSize max_range; /* maxStorageBufferRange */
    uint32_t max_groups_x, max_groups_y;
    VkPhysicalDeviceMemoryProperties mem;
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout;
    VkDescriptorPool pool;
    VkDescriptorSet set;
    VkPipeline pipe[P_COUNT];
    VkCommandPool cmd_pool;
    VkCommandBuffer cmd;
    VkFence fence;
    vk_buffer tables;        /* per layer: c_k (n floats), then per subspace w (b) and dw (b) */
    uint32_t *layer_off;     /* start of each layer's block in tables */
    vk_buffer work[B_COUNT]; /* B_TABLES unused here (tables above) */
    vk_buffer staging;       /* host-visible: input points up, results down */
    pthread_mutex_t lock;    /* one call at a time: the buffers and the command buffer are shared */
};

/* ---- small helpers ------------------------------------------------------------------------- */

#define VK_TRY(call, what)                                  \
    do {                                                    \
        VkResult r_ = (call);                               \
        if (r_ != VK_SUCCESS) return dpc_vk_fail(r_, what); \
    } while (0)

static int is_gpu(VkPhysicalDeviceType t) {
    return t == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU || t == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU ||
           t == VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU;
}

static int type_rank(VkPhysicalDeviceType t) {
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
    }
}

static const char *type_name(VkPhysicalDeviceType t) {
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "CPU (software) device";
    default: return "other device";
    }
}

static size_t div_up(size_t a, size_t b) { return (a + b - 1) / b; }

static uint32_t groups(size_t items, uint32_t per_group, uint32_t cap) {
    size_t g = div_up(items, per_group);
    if (g < 1) g = 1;
    return g > cap ? cap : (uint32_t)g;
}

/* ---- instance and device ------------------------------------------------------------------- */

static dpc_status create_instance(dpc_vk_fns *fn, VkInstance *out) {
    dpc_status st = dpc_vk_load_global(fn);
    if (st != DPC_OK) return st;
    VkApplicationInfo app = {VK_STRUCTURE_TYPE_APPLICATION_INFO,
                             NULL,
                             "libdpc",
                             DPC_VERSION_NUMBER,
                             "libdpc",
                             DPC_VERSION_NUMBER,
                             VK_API_VERSION_1_0};
    VkInstanceCreateInfo info = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO, NULL, 0, &app, 0, NULL, 0, NULL};
    VK_TRY(fn->vkCreateInstance(&info, NULL, out), "vkCreateInstance");
    st = dpc_vk_load_instance(fn, *out);
    if (st != DPC_OK) {
        PFN_vkDestroyInstance destroy = (PFN_vkDestroyInstance)fn->vkGetInstanceProcAddr(*out, "vkDestroyInstance");
        if (destroy) destroy(*out, NULL);
        *out = VK_NULL_HANDLE;
    }
    return st;
}

/* One instance per process, made by the first model that needs it and never destroyed (like the
 * loader's handle, vk_loader.c). Destroying the last instance lets the loader unload the driver,
 * and drivers do not all survive that: NVIDIA's (on an H200) failed vkCreateInstance with
 * VK_ERROR_INCOMPATIBLE_DRIVER after about 25 load / unload cycles in one process, and lavapipe
 * leaks on each. So the environment that chooses drivers (VK_DRIVER_FILES, ...) is read once, by
 * the first success; a failure is not kept, and the next model tries again. Devices stay per
 * model. vkEnumeratePhysicalDevices and vkCreateDevice need no external synchronisation of the
 * instance, so models use it from any thread. */
static pthread_mutex_t g_instance_lock = PTHREAD_MUTEX_INITIALIZER;
static dpc_vk_fns g_instance_fns;
static VkInstance g_instance;

static dpc_status shared_instance(dpc_vk_fns *fn, VkInstance *out) {
    dpc_status st = DPC_OK;
    pthread_mutex_lock(&g_instance_lock);
    if (!g_instance) st = create_instance(&g_instance_fns, &g_instance);
    if (st == DPC_OK) {
        *fn = g_instance_fns;
        *out = g_instance;
    }
    pthread_mutex_unlock(&g_instance_lock);
    return st;
}

/* The physical devices; *out is malloc'ed. */
static dpc_status list_devices(const dpc_vk_fns *fn, VkInstance instance, VkPhysicalDevice **out, uint32_t *count) {
    *out = NULL;
    *count = 0;
    VK_TRY(fn->vkEnumeratePhysicalDevices(instance, count, NULL), "vkEnumeratePhysicalDevices");
    if (*count == 0) return DPC_OK;
    *out = (VkPhysicalDevice *)calloc(*count, sizeof **out);
    if (!*out) return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory listing Vulkan devices");
    VkResult r = fn->vkEnumeratePhysicalDevices(instance, count, *out);
    if (r != VK_SUCCESS && r != VK_INCOMPLETE) {
        free(*out);
        *out = NULL;
        return dpc_vk_fail(r, "vkEnumeratePhysicalDevices");
    }
    return DPC_OK;
}

/* A queue family with compute, or UINT32_MAX. */
static uint32_t compute_family(const dpc_vk_fns *fn, VkPhysicalDevice dev) {
    uint32_t n = 0;
    fn->vkGetPhysicalDeviceQueueFamilyProperties(dev, &n, NULL);
    VkQueueFamilyProperties props[64];
    if (n > 64) n = 64;
    fn->vkGetPhysicalDeviceQueueFamilyProperties(dev, &n, props);
    for (uint32_t i = 0; i < n; i++)
        if (props[i].queueFlags & VK_QUEUE_COMPUTE_BIT && props[i].queueCount > 0) return i;
    return UINT32_MAX;
}

/* Why the device cannot run libdpc's shaders, or NULL if it can. */
static const char *unusable(const dpc_vk_fns *fn, VkPhysicalDevice dev, const VkPhysicalDeviceProperties *p) {
    const VkPhysicalDeviceLimits *l = &p->limits;
    if (compute_family(fn, dev) == UINT32_MAX) return "no compute queue";
    if (l->maxPerStageDescriptorStorageBuffers < B_COUNT || l->maxBoundDescriptorSets < 1)
        return "fewer than 10 storage buffers per shader stage";
    if (l->maxComputeWorkGroupInvocations < 256 || l->maxComputeWorkGroupSize[0] < 256)
        return "workgroups of fewer than 256 invocations";
    if (l->maxComputeSharedMemorySize < 9 * 1024) return "less than 9 KiB of shared memory";
    if (l->maxPushConstantsSize < sizeof(vk_params)) return "fewer than 84 bytes of push constants";
    return NULL;
}

static pthread_once_t g_probe_once = PTHREAD_ONCE_INIT;
static int g_gpu_present;

static void probe(void) {
    dpc_vk_fns fn;
    VkInstance instance = VK_NULL_HANDLE;
    if (shared_instance(&fn, &instance) != DPC_OK) return;
    VkPhysicalDevice *devs = NULL;
    uint32_t count = 0;
    if (list_devices(&fn, instance, &devs, &count) == DPC_OK) {
        for (uint32_t i = 0; i < count; i++) {
            VkPhysicalDeviceProperties p;
            fn.vkGetPhysicalDeviceProperties(devs[i], &p);
            if (is_gpu(p.deviceType) && !unusable(&fn, devs[i], &p)) g_gpu_present = 1;
        }
    }
    free(devs);
}

int dpc_vk_gpu_present(void) {
    pthread_once(&g_probe_once, probe);
    dpc_clear_error(); /* a failed probe only means "no GPU" */
    return g_gpu_present;
}

static dpc_status pick_device(dpc_vk_engine *e, int gpu_only) {
    VkPhysicalDevice *devs = NULL;
    uint32_t count = 0;
    dpc_status st = list_devices(&e->fn, e->instance, &devs, &count);
    if (st != DPC_OK) return st;
    char seen[768] = "";
    size_t used = 0;
    int best = -1;
    VkPhysicalDeviceProperties best_p;
    for (uint32_t i = 0; i < count; i++) {
        VkPhysicalDeviceProperties p;
        e->fn.vkGetPhysicalDeviceProperties(devs[i], &p);
        const char *why = unusable(&e->fn, devs[i], &p);
        if (!why && gpu_only && !is_gpu(p.deviceType)) why = "not a GPU (backend auto uses GPUs only)";
        if (why) {
            int w = snprintf(seen + used, sizeof seen - used, "%s%.100s (%s): %s", used ? "; " : "", p.deviceName,
                             type_name(p.deviceType), why);
            if (w > 0 && (size_t)w < sizeof seen - used) used += (size_t)w;
            continue;
        }
        if (best < 0 || type_rank(p.deviceType) > type_rank(best_p.deviceType)) {
            best = (int)i;
            best_p = p;
        }
    }
    if (best < 0) {
        free(devs);
        if (count == 0)
            return dpc_fail(DPC_ERROR_UNSUPPORTED, "Vulkan backend: no Vulkan device (the loader found no driver)");
        return dpc_fail(DPC_ERROR_UNSUPPORTED, "Vulkan backend: no usable Vulkan device: %s", seen);
    }
    e->phys = devs[best];
    free(devs);
    e->family = compute_family(&e->fn, e->phys);
    snprintf(e->name, sizeof e->name, "%s", best_p.deviceName);
    e->max_range = best_p.limits.maxStorageBufferRange;
    e->max_groups_x =
        best_p.limits.maxComputeWorkGroupCount[0] < MAX_GROUPS ? best_p.limits.maxComputeWorkGroupCount[0] : MAX_GROUPS;
    e->max_groups_y =
        best_p.limits.maxComputeWorkGroupCount[1] < MAX_GROUPS ? best_p.limits.maxComputeWorkGroupCount[1] : MAX_GROUPS;
    e->fn.vkGetPhysicalDeviceMemoryProperties(e->phys, &e->mem);
    return DPC_OK;
}

static dpc_status create_device(dpc_vk_engine *e) {
    const float priority = 1.0f;
    VkDeviceQueueCreateInfo q = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO, NULL, 0, e->family, 1, &priority};
    VkDeviceCreateInfo info = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, NULL, 0, 1, &q, 0, NULL, 0, NULL, NULL};
    VK_TRY(e->fn.vkCreateDevice(e->phys, &info, NULL, &e->device), "vkCreateDevice");
    dpc_status st = dpc_vk_load_device(&e->fn, e->device);
    if (st != DPC_OK) return st;
    e->fn.vkGetDeviceQueue(e->device, e->family, 0, &e->queue);
    return DPC_OK;
}

/* ---- buffers ------------------------------------------------------------------------------- */

/* A memory type allowed by `bits` with all of `need`, preferring `want` too; UINT32_MAX if none. */
static uint32_t memory_type(const dpc_vk_engine *e, uint32_t bits, VkMemoryPropertyFlags need,
                            VkMemoryPropertyFlags want) {
    uint32_t fallback = UINT32_MAX;
    for (uint32_t i = 0; i < e->mem.memoryTypeCount; i++) {
        if (!(bits >> i & 1u)) continue;
        const VkMemoryPropertyFlags f = e->mem.memoryTypes[i].propertyFlags;
        if ((f & need) != need) continue;
        if ((f & want) == want) return i;
        if (fallback == UINT32_MAX) fallback = i;
    }
    return fallback;
}

static void buffer_free(dpc_vk_engine *e, vk_buffer *b) {
    if (b->map) e->fn.vkUnmapMemory(e->device, b->mem);
    if (b->buf) e->fn.vkDestroyBuffer(e->device, b->buf, NULL);
    if (b->mem) e->fn.vkFreeMemory(e->device, b->mem, NULL);
    memset(b, 0, sizeof *b);
}

/* host: host-visible and coherent, mapped; else device-local where the device has it. */
static dpc_status buffer_create(dpc_vk_engine *e, vk_buffer *b, VkDeviceSize size, VkBufferUsageFlags usage, int host) {
    memset(b, 0, sizeof *b);
    if (size < 16) size = 16;
    VkBufferCreateInfo info = {
        VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO, NULL, 0, size, usage, VK_SHARING_MODE_EXCLUSIVE, 0, NULL};
    VK_TRY(e->fn.vkCreateBuffer(e->device, &info, NULL, &b->buf), "vkCreateBuffer");
    VkMemoryRequirements req;
    e->fn.vkGetBufferMemoryRequirements(e->device, b->buf, &req);
    const VkMemoryPropertyFlags need =
        host ? VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT : 0;
    const VkMemoryPropertyFlags want = host ? VK_MEMORY_PROPERTY_HOST_CACHED_BIT : VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
    const uint32_t type = memory_type(e, req.memoryTypeBits, need, want);
    if (type == UINT32_MAX) {
        buffer_free(e, b);
        return dpc_fail(DPC_ERROR_UNSUPPORTED, "Vulkan backend: device %s has no %s memory for a buffer", e->name,
                        host ? "host-visible coherent" : "suitable");
    }
    VkMemoryAllocateInfo alloc = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, NULL, req.size, type};
    VkResult r = e->fn.vkAllocateMemory(e->device, &alloc, NULL, &b->mem);
    if (r == VK_SUCCESS) r = e->fn.vkBindBufferMemory(e->device, b->buf, b->mem, 0);
    if (r == VK_SUCCESS && host) r = e->fn.vkMapMemory(e->device, b->mem, 0, VK_WHOLE_SIZE, 0, &b->map);
    if (r != VK_SUCCESS) {
        buffer_free(e, b);
        char what[160];
        snprintf(what, sizeof what,
                 "allocating a buffer of %llu bytes (vkAllocateMemory/vkBindBufferMemory/vkMapMemory)",
                 (unsigned long long)size);
        return dpc_vk_fail(r, what);
    }
    b->size = size;
    return DPC_OK;
}

/* ---- pipelines ----------------------------------------------------------------------------- */

static dpc_status create_layout(dpc_vk_engine *e) {
    VkDescriptorSetLayoutBinding bind[B_COUNT];
    for (uint32_t i = 0; i < B_COUNT; i++)
        bind[i] =
            (VkDescriptorSetLayoutBinding){i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL};
    VkDescriptorSetLayoutCreateInfo sl = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO, NULL, 0, B_COUNT, bind};
    VK_TRY(e->fn.vkCreateDescriptorSetLayout(e->device, &sl, NULL, &e->set_layout), "vkCreateDescriptorSetLayout");
    VkPushConstantRange range = {VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(vk_params)};
    VkPipelineLayoutCreateInfo pl = {
        VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO, NULL, 0, 1, &e->set_layout, 1, &range};
    VK_TRY(e->fn.vkCreatePipelineLayout(e->device, &pl, NULL, &e->layout), "vkCreatePipelineLayout");
    VkDescriptorPoolSize size = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, B_COUNT};
    VkDescriptorPoolCreateInfo dp = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO, NULL, 0, 1, 1, &size};
    VK_TRY(e->fn.vkCreateDescriptorPool(e->device, &dp, NULL, &e->pool), "vkCreateDescriptorPool");
    VkDescriptorSetAllocateInfo da = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO, NULL, e->pool, 1, &e->set_layout};
    VK_TRY(e->fn.vkAllocateDescriptorSets(e->device, &da, &e->set), "vkAllocateDescriptorSets");
    return DPC_OK;
}

/* spec: the value of specialization constant 0 (all-pairs: vec4s per point), 0 for none. */
static dpc_status create_pipeline(dpc_vk_engine *e, const uint32_t *code, size_t bytes, uint32_t spec_value,
                                  VkPipeline *out) {
    VkShaderModuleCreateInfo mi = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO, NULL, 0, bytes, code};
    VkShaderModule module;
    VK_TRY(e->fn.vkCreateShaderModule(e->device, &mi, NULL, &module), "vkCreateShaderModule");
    VkSpecializationMapEntry entry = {0, 0, sizeof(uint32_t)};
    VkSpecializationInfo spec = {1, &entry, sizeof spec_value, &spec_value};
    VkPipelineShaderStageCreateInfo stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                                             NULL,
                                             0,
                                             VK_SHADER_STAGE_COMPUTE_BIT,
                                             module,
                                             "main",
                                             spec_value ? &spec : NULL};
    VkComputePipelineCreateInfo ci = {
        VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO, NULL, 0, stage, e->layout, VK_NULL_HANDLE, -1};
    VkResult r = e->fn.vkCreateComputePipelines(e->device, VK_NULL_HANDLE, 1, &ci, NULL, out);
    e->fn.vkDestroyShaderModule(e->device, module, NULL);
    if (r != VK_SUCCESS) {
        *out = VK_NULL_HANDLE;
        return dpc_vk_fail(r, "vkCreateComputePipelines");
    }
    return DPC_OK;
}

static dpc_status create_pipelines(dpc_vk_engine *e, const dpc_cascade *c) {
    static const struct {
        int id;
        const uint32_t *code;
        size_t bytes;
    } list[] = {
        {P_CELLS, dpc_spv_cells, sizeof dpc_spv_cells},
        {P_SCAN_REDUCE, dpc_spv_scan_reduce, sizeof dpc_spv_scan_reduce},
        {P_SCAN_PARTIALS, dpc_spv_scan_partials, sizeof dpc_spv_scan_partials},
        {P_SCAN_DOWN, dpc_spv_scan_down, sizeof dpc_spv_scan_down},
        {P_SCATTER, dpc_spv_scatter, sizeof dpc_spv_scatter},
        {P_CELLSORT, dpc_spv_cellsort, sizeof dpc_spv_cellsort},
        {P_GRID_SUM, dpc_spv_grid_sum, sizeof dpc_spv_grid_sum},
        {P_APPLY, dpc_spv_apply, sizeof dpc_spv_apply},
        {P_PAIRS_SUM, dpc_spv_pairs_sum, sizeof dpc_spv_pairs_sum},
    };
    for (size_t i = 0; i < sizeof list / sizeof list[0]; i++) {
        dpc_status st = create_pipeline(e, list[i].code, list[i].bytes, 0, &e->pipe[list[i].id]);
        if (st != DPC_OK) return st;
    }
    /* All-pairs variants for the subspace sizes the model has (any subspace may need all pairs:
     * few points, or a radius near the domain size). */
    for (uint32_t l = 0; l < c->n_layers; l++)
        for (uint32_t t = 0; t < c->layers[l].n_sub; t++) {
            const unsigned nv4 = ((unsigned)__builtin_popcountll(c->layers[l].masks[t]) + 3) / 4;
            if (e->pipe[P_PAIRS + nv4 - 1]) continue;
            dpc_status st = create_pipeline(e, dpc_spv_pairs, sizeof dpc_spv_pairs, nv4, &e->pipe[P_PAIRS + nv4 - 1]);
            if (st != DPC_OK) return st;
        }
    return DPC_OK;
}

/* ---- one-off commands ---------------------------------------------------------------------- */

static dpc_status submit_and_wait(dpc_vk_engine *e) {
    VK_TRY(e->fn.vkEndCommandBuffer(e->cmd), "vkEndCommandBuffer");
    VK_TRY(e->fn.vkResetFences(e->device, 1, &e->fence), "vkResetFences");
    VkSubmitInfo si = {VK_STRUCTURE_TYPE_SUBMIT_INFO, NULL, 0, NULL, NULL, 1, &e->cmd, 0, NULL};
    VK_TRY(e->fn.vkQueueSubmit(e->queue, 1, &si, e->fence), "vkQueueSubmit");
    VK_TRY(e->fn.vkWaitForFences(e->device, 1, &e->fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    return DPC_OK;
}

static dpc_status begin(dpc_vk_engine *e) {
    VkCommandBufferBeginInfo bi = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO, NULL,
                                   VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT, NULL};
    VK_TRY(e->fn.vkBeginCommandBuffer(e->cmd, &bi), "vkBeginCommandBuffer");
    return DPC_OK;
}

static void barrier(dpc_vk_engine *e, VkPipelineStageFlags src, VkAccessFlags src_access, VkPipelineStageFlags dst,
                    VkAccessFlags dst_access) {
    VkMemoryBarrier b = {VK_STRUCTURE_TYPE_MEMORY_BARRIER, NULL, src_access, dst_access};
    e->fn.vkCmdPipelineBarrier(e->cmd, src, dst, 0, 1, &b, 0, NULL, 0, NULL);
}

/* The model's constant tables: per layer c_k, then w and dw of each subspace. */
static dpc_status upload_tables(dpc_vk_engine *e, const dpc_cascade *c) {
    const size_t n = c->dims;
    size_t total = 0;
    e->layer_off = (uint32_t *)calloc(c->n_layers ? c->n_layers : 1, sizeof(uint32_t));
    if (!e->layer_off) return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for the Vulkan kernel tables");
    for (uint32_t l = 0; l < c->n_layers; l++) {
        e->layer_off[l] = (uint32_t)total;
        total += n + 2 * (size_t)c->layers[l].n_sub * c->layers[l].bins;
    }
    if (total * sizeof(float) > e->max_range)
        return dpc_fail(DPC_ERROR_LIMIT,
                        "Vulkan backend: the model's kernel tables need %zu bytes, device %s binds at most %llu",
                        total * sizeof(float), e->name, (unsigned long long)e->max_range);
    vk_buffer host;
    dpc_status st = buffer_create(e, &host, total * sizeof(float), VK_BUFFER_USAGE_TRANSFER_SRC_BIT, 1);
    if (st != DPC_OK) return st;
    float *dst = (float *)host.map;
    for (uint32_t l = 0; l < c->n_layers; l++) {
        const dpc_layer *L = &c->layers[l];
        float *block = dst + e->layer_off[l];
        unsigned count[DPC_MAX_DIMS];
        dpc_plan_counts((unsigned)n, L->n_sub, L->masks, L->fixed, count);
        for (size_t d = 0; d < n; d++) block[d] = (float)count[d];
        for (uint32_t t = 0; t < L->n_sub; t++) {
            memcpy(block + n + 2 * (size_t)t * L->bins, L->kernels + (size_t)t * L->bins, L->bins * sizeof(float));
            memcpy(block + n + (2 * (size_t)t + 1) * L->bins, L->slopes + (size_t)t * L->bins, L->bins * sizeof(float));
        }
    }
    st = buffer_create(e, &e->tables, total * sizeof(float),
                       VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0);
    if (st == DPC_OK) st = begin(e);
    if (st == DPC_OK) {
        VkBufferCopy region = {0, 0, total * sizeof(float)};
        e->fn.vkCmdCopyBuffer(e->cmd, host.buf, e->tables.buf, 1, &region);
        st = submit_and_wait(e);
    }
    buffer_free(e, &host);
    return st;
}

/* ---- engine lifetime ----------------------------------------------------------------------- */

void dpc_vk_engine_destroy(dpc_vk_engine *e) {
    if (!e) return;
    if (e->device) {
        for (int i = 0; i < B_COUNT; i++) buffer_free(e, &e->work[i]);
        buffer_free(e, &e->staging);
        buffer_free(e, &e->tables);
        for (int i = 0; i < P_COUNT; i++)
            if (e->pipe[i]) e->fn.vkDestroyPipeline(e->device, e->pipe[i], NULL);
        if (e->fence) e->fn.vkDestroyFence(e->device, e->fence, NULL);
        if (e->cmd_pool) e->fn.vkDestroyCommandPool(e->device, e->cmd_pool, NULL);
        if (e->pool) e->fn.vkDestroyDescriptorPool(e->device, e->pool, NULL);
        if (e->layout) e->fn.vkDestroyPipelineLayout(e->device, e->layout, NULL);
        if (e->set_layout) e->fn.vkDestroyDescriptorSetLayout(e->device, e->set_layout, NULL);
        e->fn.vkDestroyDevice(e->device, NULL);
    }
    pthread_mutex_destroy(&e->lock);
    free(e->layer_off);
    free(e);
}

dpc_status dpc_vk_engine_create(const dpc_cascade *c, int gpu_only, dpc_vk_engine **out) {
    *out = NULL;
    dpc_vk_engine *e = (dpc_vk_engine *)calloc(1, sizeof *e);
    if (!e) return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for the Vulkan backend");
    if (pthread_mutex_init(&e->lock, NULL) != 0) {
        free(e);
        return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "cannot create the Vulkan backend's mutex");
    }
    dpc_status st = shared_instance(&e->fn, &e->instance);
    if (st == DPC_OK) st = pick_device(e, gpu_only);
    if (st == DPC_OK) st = create_device(e);
    if (st == DPC_OK) st = create_layout(e);
    if (st == DPC_OK) st = create_pipelines(e, c);
    if (st == DPC_OK) {
        VkCommandPoolCreateInfo pi = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO, NULL,
                                      VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT, e->family};
        VkResult r = e->fn.vkCreateCommandPool(e->device, &pi, NULL, &e->cmd_pool);
        if (r == VK_SUCCESS) {
            VkCommandBufferAllocateInfo ai = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO, NULL, e->cmd_pool,
                                              VK_COMMAND_BUFFER_LEVEL_PRIMARY, 1};
            r = e->fn.vkAllocateCommandBuffers(e->device, &ai, &e->cmd);
        }
        if (r == VK_SUCCESS) {
            VkFenceCreateInfo fi = {VK_STRUCTURE_TYPE_FENCE_CREATE_INFO, NULL, 0};
            r = e->fn.vkCreateFence(e->device, &fi, NULL, &e->fence);
        }
        if (r != VK_SUCCESS) st = dpc_vk_fail(r, "creating the command buffer and fence");
    }
    if (st == DPC_OK) st = upload_tables(e, c);
    if (st != DPC_OK) {
        dpc_vk_engine_destroy(e);
        return st;
    }
    *out = e;
    return DPC_OK;
}

const char *dpc_vk_engine_device(const dpc_vk_engine *e) { return e ? e->name : ""; }

/* ---- work buffers -------------------------------------------------------------------------- */

/* Partner ranges per point of an all-pairs pass: a few thousand points make only m / 64
 * workgroups, too few to fill a large GPU, so each point's sum is split over up to PAIR_UNITS /
 * (m / 64) ranges of at least PAIR_CHUNK_MIN partners. A function of m alone, so every set of a
 * batch gets the bits of a single call. */
static uint32_t pair_splits(size_t m) {
    const size_t blocks = div_up(m, 64);
    uint32_t s = 1;
    while (blocks * s * 2 <= PAIR_UNITS && m / ((size_t)s * 2) >= PAIR_CHUNK_MIN) s *= 2;
    return s;
}

typedef struct sizes {
    size_t cstride, nblocks_max;
    VkDeviceSize per_set[B_COUNT]; /* bytes per set of each work buffer (B_TABLES: 0) */
    VkDeviceSize staging_per_set;
} sizes;

static void work_sizes(size_t m, size_t n, sizes *s) {
    s->cstride = 2 * m + DPC_PLAN_CELL_SLACK + 1; /* a plan's grid has at most 2m + 64 cells, plus the end entry */
    s->nblocks_max = div_up(s->cstride, SCAN_BLOCK);
    memset(s->per_set, 0, sizeof s->per_set);
    s->per_set[B_X] = s->per_set[B_DELTA] = (VkDeviceSize)m * n * sizeof(float);
    s->per_set[B_CELL_OF] = s->per_set[B_SORTED] = (VkDeviceSize)m * sizeof(uint32_t);
    s->per_set[B_COUNTS] = s->per_set[B_STARTS] = (VkDeviceSize)s->cstride * sizeof(uint32_t);
    s->per_set[B_COORDS] = (VkDeviceSize)m * 4 * sizeof(float);
    s->per_set[B_PARTIALS] = (VkDeviceSize)s->nblocks_max * sizeof(uint32_t);
    /* split sums (k <= n floats per point and range); one word where there is no split, since
     * every binding needs a buffer */
    const uint32_t splits = pair_splits(m);
    s->per_set[B_SPLIT] = splits > 1 ? (VkDeviceSize)splits * m * n * sizeof(float) : sizeof(float);
    s->staging_per_set = s->per_set[B_X];
}

/* Sets per submission: every buffer within maxStorageBufferRange, all of them within
 * WORK_BUDGET when more than one set, at most max_groups_y. 0 if one set does not fit. */
static size_t sets_per_run(const dpc_vk_engine *e, const sizes *s, size_t count) {
    VkDeviceSize total = 0;
    size_t sets = count < e->max_groups_y ? count : e->max_groups_y;
    for (int b = 0; b < B_COUNT; b++) {
        if (!s->per_set[b]) continue;
        total += s->per_set[b];
        const VkDeviceSize fit = e->max_range / s->per_set[b];
        if (fit < sets) sets = (size_t)fit;
    }
    const VkDeviceSize budget = WORK_BUDGET / total;
    if (sets > 1 && budget < sets) sets = budget > 1 ? (size_t)budget : 1;
    return sets;
}

static dpc_status ensure_buffers(dpc_vk_engine *e, const sizes *s, size_t sets) {
    int changed = 0;
    for (int b = 0; b < B_COUNT; b++) {
        if (b == B_TABLES) continue;
        const VkDeviceSize need = s->per_set[b] * sets;
        if (e->work[b].buf && e->work[b].size >= need) continue;
        buffer_free(e, &e->work[b]);
        VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
        if (b == B_X) usage |= VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
        if (b == B_DELTA || b == B_COUNTS) usage |= VK_BUFFER_USAGE_TRANSFER_DST_BIT;
        dpc_status st = buffer_create(e, &e->work[b], need, usage, 0);
        if (st != DPC_OK) return st;
        changed = 1;
    }
    const VkDeviceSize need = s->staging_per_set * sets;
    if (!e->staging.buf || e->staging.size < need) {
        buffer_free(e, &e->staging);
        dpc_status st =
            buffer_create(e, &e->staging, need, VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 1);
        if (st != DPC_OK) return st;
    }
    if (changed) {
        VkDescriptorBufferInfo info[B_COUNT];
        VkWriteDescriptorSet w[B_COUNT];
        for (uint32_t b = 0; b < B_COUNT; b++) {
            const vk_buffer *buf = b == B_TABLES ? &e->tables : &e->work[b];
            info[b] = (VkDescriptorBufferInfo){buf->buf, 0, buf->size};
            w[b] = (VkWriteDescriptorSet){VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, e->set,   b,   0, 1,
                                          VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,      NULL, &info[b], NULL};
        }
        e->fn.vkUpdateDescriptorSets(e->device, B_COUNT, w, 0, NULL);
    }
    return DPC_OK;
}

/* ---- recording a run ----------------------------------------------------------------------- */

static void dispatch(dpc_vk_engine *e, int pipe, const vk_params *p, uint32_t gx, uint32_t sets) {
    e->fn.vkCmdBindPipeline(e->cmd, VK_PIPELINE_BIND_POINT_COMPUTE, e->pipe[pipe]);
    e->fn.vkCmdPushConstants(e->cmd, e->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof *p, p);
    e->fn.vkCmdDispatch(e->cmd, gx, sets, 1);
    barrier(e, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
            VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
}

static void record_layer(dpc_vk_engine *e, const dpc_cascade *c, uint32_t l, size_t m, const sizes *s, uint32_t sets) {
    const dpc_layer *L = &c->layers[l];
    const uint32_t n = c->dims;
    const uint32_t gx_points = groups(m, 128, e->max_groups_x);
    int moved = 0;
    for (uint32_t t = 0; t < L->n_sub; t++) {
        const uint64_t mask = L->masks[t];
        dpc_sub_plan plan; /* the CPU engine's plan: the same float radius, cutoff, bin scale, search */
        dpc_plan_subspace(mask, L->fixed, L->radius[t], L->eps, L->bins, m, DPC_PLAN_F32, &plan);
        if (!plan.moves) continue; /* moves nothing (e.g. the grid's own axes) */
        const unsigned k = plan.k;
        vk_params p;
        memset(&p, 0, sizeof p);
        p.m = (uint32_t)m;
        p.n = n;
        p.k = k;
        p.h = (float)plan.h;
        p.radius = (float)plan.r;
        p.cutoff = (float)plan.e;
        p.scale = (float)plan.scale;
        p.umax = (float)plan.umax;
        p.qmax = plan.qmax;
        p.w_off = e->layer_off[l] + n + 2 * t * L->bins;
        p.dw_off = p.w_off + L->bins;
        p.c_off = e->layer_off[l];
        p.mask_lo = (uint32_t)mask;
        p.mask_hi = (uint32_t)(mask >> 32);
        p.cstride = (uint32_t)s->cstride;
        if (plan.grid) {
            const uint32_t G = plan.G, R = plan.R;
            unsigned q = 0;
            for (unsigned d = 0; d < n; d++)
                if (mask >> d & 1) p.dims |= d << (8 * q++);
            p.G = G;
            p.R = R;
            p.cells = 1;
            for (unsigned a = 0; a < k; a++) p.cells *= G;
            p.nblocks = (uint32_t)div_up((size_t)p.cells + 1, SCAN_BLOCK);
            const uint32_t gx_blocks = groups(p.nblocks, 1, e->max_groups_x);
            dispatch(e, P_CELLS, &p, gx_points, sets);
            dispatch(e, P_SCAN_REDUCE, &p, gx_blocks, sets);
            dispatch(e, P_SCAN_PARTIALS, &p, 1, sets);
            dispatch(e, P_SCAN_DOWN, &p, gx_blocks, sets);
            dispatch(e, P_SCATTER, &p, gx_points, sets);
            dispatch(e, P_CELLSORT, &p, groups(p.cells, 128, e->max_groups_x), sets);
            dispatch(e, P_GRID_SUM, &p, gx_points, sets);
        } else {
            p.splits = pair_splits(m);
            dispatch(e, P_PAIRS + (int)(k + 3) / 4 - 1, &p, groups(div_up(m, 64) * p.splits, 1, e->max_groups_x), sets);
            if (p.splits > 1) dispatch(e, P_PAIRS_SUM, &p, groups(m * k, 128, e->max_groups_x), sets);
        }
        moved = 1;
    }
    if (moved) {
        vk_params p;
        memset(&p, 0, sizeof p);
        p.m = (uint32_t)m;
        p.n = n;
        p.c_off = e->layer_off[l];
        dispatch(e, P_APPLY, &p, groups(m * n, 128, e->max_groups_x), sets);
    }
}

static dpc_status run_sets(dpc_vk_engine *e, const dpc_cascade *c, size_t m, const sizes *s, uint32_t sets) {
    dpc_status st = begin(e);
    if (st != DPC_OK) return st;
    const VkDeviceSize bytes = (VkDeviceSize)sets * s->staging_per_set;
    VkBufferCopy up = {0, 0, bytes};
    e->fn.vkCmdCopyBuffer(e->cmd, e->staging.buf, e->work[B_X].buf, 1, &up);
    e->fn.vkCmdFillBuffer(e->cmd, e->work[B_DELTA].buf, 0, VK_WHOLE_SIZE, 0);
    e->fn.vkCmdFillBuffer(e->cmd, e->work[B_COUNTS].buf, 0, VK_WHOLE_SIZE, 0);
    barrier(e, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
            VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
    e->fn.vkCmdBindDescriptorSets(e->cmd, VK_PIPELINE_BIND_POINT_COMPUTE, e->layout, 0, 1, &e->set, 0, NULL);
    for (uint32_t l = 0; l < c->n_layers; l++) record_layer(e, c, l, m, s, sets);
    barrier(e, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
            VK_ACCESS_TRANSFER_READ_BIT);
    e->fn.vkCmdCopyBuffer(e->cmd, e->work[B_X].buf, e->staging.buf, 1, &up);
    barrier(e, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
            VK_ACCESS_HOST_READ_BIT);
    return submit_and_wait(e);
}

dpc_status dpc_vk_run(dpc_vk_engine *e, const dpc_cascade *c, size_t count, size_t m, dpc_vk_fill_fn fill, void *ctx,
                      float *out) {
    sizes s;
    work_sizes(m, c->dims, &s);
    const size_t per = sets_per_run(e, &s, count);
    if (per == 0)
        return dpc_fail(DPC_ERROR_LIMIT,
                        "Vulkan backend: %zu points x %u dims need buffers larger than device %s binds (%llu bytes)", m,
                        c->dims, e->name, (unsigned long long)e->max_range);
    const size_t floats = m * c->dims;
    pthread_mutex_lock(&e->lock);
    dpc_status st = ensure_buffers(e, &s, per);
    for (size_t first = 0; st == DPC_OK && first < count; first += per) {
        const size_t sets = count - first < per ? count - first : per;
        float *stage = (float *)e->staging.map;
        for (size_t j = 0; j < sets; j++) fill(ctx, first + j, stage + j * floats);
        st = run_sets(e, c, m, &s, (uint32_t)sets);
        if (st == DPC_OK) memcpy(out + first * floats, stage, sets * floats * sizeof(float));
    }
    pthread_mutex_unlock(&e->lock);
    return st;
}
