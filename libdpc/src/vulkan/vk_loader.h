/* The Vulkan loader, opened at run time (dlopen of libvulkan.so.1) so that a libdpc built with
 * the Vulkan backend loads and runs on machines without Vulkan; and the entry points libdpc
 * uses, fetched through vkGetInstanceProcAddr / vkGetDeviceProcAddr. */
#ifndef DPC_VULKAN_VK_LOADER_H
#define DPC_VULKAN_VK_LOADER_H

#define VK_NO_PROTOTYPES
#include <vulkan/vulkan.h>

#include "dpc/dpc.h"

/* X-macro lists, laid out by hand: clang-format 14 makes a staircase of them, and another one
 * on each run. */
// clang-format off
#define DPC_VK_INSTANCE_FNS(X)                                                                              \
    X(vkDestroyInstance) X(vkEnumeratePhysicalDevices) X(vkGetPhysicalDeviceProperties)                    \
    X(vkGetPhysicalDeviceQueueFamilyProperties) X(vkGetPhysicalDeviceMemoryProperties) X(vkCreateDevice)    \
    X(vkGetDeviceProcAddr)

#define DPC_VK_DEVICE_FNS(X)                                                                                \
    X(vkDestroyDevice) X(vkGetDeviceQueue) X(vkCreateBuffer) X(vkDestroyBuffer)                             \
    X(vkGetBufferMemoryRequirements) X(vkAllocateMemory) X(vkFreeMemory) X(vkBindBufferMemory)              \
    X(vkMapMemory) X(vkUnmapMemory) X(vkCreateShaderModule) X(vkDestroyShaderModule)                       \
    X(vkCreateDescriptorSetLayout) X(vkDestroyDescriptorSetLayout) X(vkCreatePipelineLayout)               \
    X(vkDestroyPipelineLayout) X(vkCreateComputePipelines) X(vkDestroyPipeline) X(vkCreateDescriptorPool)   \
    X(vkDestroyDescriptorPool) X(vkAllocateDescriptorSets) X(vkUpdateDescriptorSets) X(vkCreateCommandPool) \
    X(vkDestroyCommandPool) X(vkAllocateCommandBuffers) X(vkBeginCommandBuffer) X(vkEndCommandBuffer)       \
    X(vkCmdBindPipeline) X(vkCmdBindDescriptorSets) X(vkCmdPushConstants) X(vkCmdDispatch)                 \
    X(vkCmdPipelineBarrier) X(vkCmdCopyBuffer) X(vkCmdFillBuffer) X(vkCreateFence) X(vkDestroyFence)       \
    X(vkResetFences) X(vkWaitForFences) X(vkQueueSubmit)
// clang-format on

#define DPC_VK_FIELD(name) PFN_##name name;
typedef struct dpc_vk_fns {
    PFN_vkGetInstanceProcAddr vkGetInstanceProcAddr;
    PFN_vkCreateInstance vkCreateInstance;
    DPC_VK_INSTANCE_FNS(DPC_VK_FIELD)
    DPC_VK_DEVICE_FNS(DPC_VK_FIELD)
} dpc_vk_fns;
#undef DPC_VK_FIELD

/* Open the loader (once per process; it stays loaded) and fill the global entry points of fn.
 * The environment variable DPC_VULKAN_LOADER, when set, names the library instead of
 * libvulkan.so.1 (an unusual install, or a test of a machine without Vulkan). */
dpc_status dpc_vk_load_global(dpc_vk_fns *fn);
dpc_status dpc_vk_load_instance(dpc_vk_fns *fn, VkInstance instance);
dpc_status dpc_vk_load_device(dpc_vk_fns *fn, VkDevice device);

/* "VK_ERROR_DEVICE_LOST" etc.; "VK_RESULT_<n>" style text for values it does not know. */
const char *dpc_vk_result_name(VkResult r);

/* Record the failure of Vulkan call `call` as a dpc status with the VkResult in the message:
 * memory errors -> DPC_ERROR_OUT_OF_MEMORY, a missing driver, feature or extension ->
 * DPC_ERROR_UNSUPPORTED, anything else (device lost, unknown) -> DPC_ERROR_INTERNAL. */
dpc_status dpc_vk_fail(VkResult r, const char *call);

#endif
