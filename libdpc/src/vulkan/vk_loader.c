/* Run-time loading of the Vulkan loader library (see vk_loader.h). */
#include "vulkan/vk_loader.h"

#include <dlfcn.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>

#include "common/error.h"

static pthread_once_t g_once = PTHREAD_ONCE_INIT;
static PFN_vkGetInstanceProcAddr g_gipa;
static char g_why[512];

/* The handle is never closed: drivers may keep threads and atexit handlers that must not
 * outlive their code, and the loader is small once its drivers are unloaded. */
static void open_loader(void) {
    const char *name = getenv("DPC_VULKAN_LOADER");
    if (!name || !*name) name = "libvulkan.so.1";
    void *lib = dlopen(name, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        const char *err = dlerror();
        snprintf(g_why, sizeof g_why, "cannot load the Vulkan loader %.200s: %.250s", name,
                 err ? err : "unknown error");
        return;
    }
    /* POSIX requires this round trip through void * for function pointers from dlsym. */
    void *sym = dlsym(lib, "vkGetInstanceProcAddr");
    if (!sym) {
        snprintf(g_why, sizeof g_why, "%.200s has no vkGetInstanceProcAddr", name);
        return;
    }
    *(void **)&g_gipa = sym;
}

dpc_status dpc_vk_load_global(dpc_vk_fns *fn) {
    pthread_once(&g_once, open_loader);
    if (!g_gipa) return dpc_fail(DPC_ERROR_UNSUPPORTED, "Vulkan backend: %s", g_why);
    fn->vkGetInstanceProcAddr = g_gipa;
    fn->vkCreateInstance = (PFN_vkCreateInstance)g_gipa(VK_NULL_HANDLE, "vkCreateInstance");
    if (!fn->vkCreateInstance)
        return dpc_fail(DPC_ERROR_UNSUPPORTED, "Vulkan backend: the loader has no vkCreateInstance");
    return DPC_OK;
}

dpc_status dpc_vk_load_instance(dpc_vk_fns *fn, VkInstance instance) {
#define LOAD(name)                                                            \
    if (!(fn->name = (PFN_##name)fn->vkGetInstanceProcAddr(instance, #name))) \
        return dpc_fail(DPC_ERROR_UNSUPPORTED, "Vulkan backend: the loader has no " #name);
    DPC_VK_INSTANCE_FNS(LOAD)
#undef LOAD
    return DPC_OK;
}

dpc_status dpc_vk_load_device(dpc_vk_fns *fn, VkDevice device) {
#define LOAD(name)                                                        \
    if (!(fn->name = (PFN_##name)fn->vkGetDeviceProcAddr(device, #name))) \
        return dpc_fail(DPC_ERROR_UNSUPPORTED, "Vulkan backend: the driver has no " #name);
    DPC_VK_DEVICE_FNS(LOAD)
#undef LOAD
    return DPC_OK;
}

const char *dpc_vk_result_name(VkResult r) {
    switch (r) {
        /* A list of macro calls, laid out by hand (clang-format 14 makes a staircase of it). */
        // clang-format off
#define NAME(v) case v: return #v;
        NAME(VK_SUCCESS) NAME(VK_NOT_READY) NAME(VK_TIMEOUT) NAME(VK_EVENT_SET) NAME(VK_EVENT_RESET)
        NAME(VK_INCOMPLETE) NAME(VK_ERROR_OUT_OF_HOST_MEMORY) NAME(VK_ERROR_OUT_OF_DEVICE_MEMORY)
        NAME(VK_ERROR_INITIALIZATION_FAILED) NAME(VK_ERROR_DEVICE_LOST) NAME(VK_ERROR_MEMORY_MAP_FAILED)
        NAME(VK_ERROR_LAYER_NOT_PRESENT) NAME(VK_ERROR_EXTENSION_NOT_PRESENT) NAME(VK_ERROR_FEATURE_NOT_PRESENT)
        NAME(VK_ERROR_INCOMPATIBLE_DRIVER) NAME(VK_ERROR_TOO_MANY_OBJECTS) NAME(VK_ERROR_FORMAT_NOT_SUPPORTED)
        NAME(VK_ERROR_FRAGMENTED_POOL) NAME(VK_ERROR_UNKNOWN) NAME(VK_ERROR_OUT_OF_POOL_MEMORY)
        NAME(VK_ERROR_INVALID_EXTERNAL_HANDLE) NAME(VK_ERROR_FRAGMENTATION)
        NAME(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
#undef NAME
            // clang-format on
            default : return "unknown VkResult";
    }
}

dpc_status dpc_vk_fail(VkResult r, const char *call) {
    dpc_status st = DPC_ERROR_INTERNAL;
    switch (r) {
    case VK_ERROR_OUT_OF_HOST_MEMORY:
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
    case VK_ERROR_OUT_OF_POOL_MEMORY:
    case VK_ERROR_FRAGMENTED_POOL:
    case VK_ERROR_FRAGMENTATION:
    case VK_ERROR_TOO_MANY_OBJECTS: st = DPC_ERROR_OUT_OF_MEMORY; break;
    case VK_ERROR_INITIALIZATION_FAILED:
    case VK_ERROR_INCOMPATIBLE_DRIVER:
    case VK_ERROR_LAYER_NOT_PRESENT:
    case VK_ERROR_EXTENSION_NOT_PRESENT:
    case VK_ERROR_FEATURE_NOT_PRESENT: st = DPC_ERROR_UNSUPPORTED; break;
    default: break;
    }
    return dpc_fail(st, "Vulkan backend: %s failed with %s (VkResult %d)", call, dpc_vk_result_name(r), (int)r);
}
