// SPDX-License-Identifier: MIT
#include "VulkanFunctions.h"

#include <dlfcn.h>
#include <mutex>
#include <string>

namespace csgv::gpu {

namespace {
void* openLoader(std::string& why) {
    static std::once_flag once;
    static void* handle = nullptr;
    static std::string error;
    std::call_once(once, [] {
        for (const char* name : {"libvulkan.so.1", "libvulkan.so"}) {
            handle = dlopen(name, RTLD_NOW | RTLD_LOCAL);
            if (handle) return;
        }
        const char* e = dlerror();
        error = e ? e : "unknown error";
    });
    why = error;
    return handle;
}
} // namespace

Status VulkanFunctions::loadGlobal() {
    std::string why;
    void* lib = openLoader(why);
    if (!lib)
        return Status::error("no Vulkan loader (libvulkan.so.1) on this machine: " + why +
                             " (Debian: apt-get install libvulkan1 mesa-vulkan-drivers)");
    vkGetInstanceProcAddr = reinterpret_cast<PFN_vkGetInstanceProcAddr>(dlsym(lib, "vkGetInstanceProcAddr"));
    if (!vkGetInstanceProcAddr) return Status::error("the Vulkan loader lacks vkGetInstanceProcAddr");
#define CSGV_VK_LOAD(name)                                                                                             \
    name = reinterpret_cast<PFN_##name>(vkGetInstanceProcAddr(nullptr, #name));                                        \
    if (!name) return Status::error("the Vulkan loader lacks " #name);
    CSGV_VK_GLOBAL_FUNCTIONS(CSGV_VK_LOAD)
#undef CSGV_VK_LOAD
    return Status::ok();
}

Status VulkanFunctions::loadInstance(VkInstance instance) {
#define CSGV_VK_LOAD(name)                                                                                             \
    name = reinterpret_cast<PFN_##name>(vkGetInstanceProcAddr(instance, #name));                                       \
    if (!name) return Status::error("the Vulkan instance lacks " #name);
    CSGV_VK_INSTANCE_FUNCTIONS(CSGV_VK_LOAD)
#undef CSGV_VK_LOAD
    return Status::ok();
}

Status VulkanFunctions::loadDevice(VkDevice device) {
#define CSGV_VK_LOAD(name)                                                                                             \
    name = reinterpret_cast<PFN_##name>(vkGetDeviceProcAddr(device, #name));                                           \
    if (!name) return Status::error("the Vulkan device lacks " #name);
    CSGV_VK_DEVICE_FUNCTIONS(CSGV_VK_LOAD)
#undef CSGV_VK_LOAD
    return Status::ok();
}

const char* vkResultName(VkResult r) {
    switch (r) {
    case VK_SUCCESS: return "VK_SUCCESS";
    case VK_NOT_READY: return "VK_NOT_READY";
    case VK_TIMEOUT: return "VK_TIMEOUT";
    case VK_ERROR_OUT_OF_HOST_MEMORY: return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED: return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST: return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_MEMORY_MAP_FAILED: return "VK_ERROR_MEMORY_MAP_FAILED";
    case VK_ERROR_LAYER_NOT_PRESENT: return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT: return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_FEATURE_NOT_PRESENT: return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER: return "VK_ERROR_INCOMPATIBLE_DRIVER";
    case VK_ERROR_TOO_MANY_OBJECTS: return "VK_ERROR_TOO_MANY_OBJECTS";
    case VK_ERROR_FORMAT_NOT_SUPPORTED: return "VK_ERROR_FORMAT_NOT_SUPPORTED";
    case VK_ERROR_OUT_OF_POOL_MEMORY: return "VK_ERROR_OUT_OF_POOL_MEMORY";
    default: return "VkResult error";
    }
}

} // namespace csgv::gpu
