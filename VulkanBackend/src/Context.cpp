// SPDX-License-Identifier: MIT
#include "csgv/gpu/Context.h"
#include "VulkanFunctions.h"

#include <sys/mman.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <tuple>
#include <utility>
#include <vector>

namespace csgv::gpu {

namespace {

std::string vkError(const char* what, VkResult r) { return std::string(what) + " failed: " + vkResultName(r); }

/// A CPU device's memory is this process's own: the first write to each of its 4 KiB pages
/// faults, and a frame that writes new memory (a new cache's first bricks, a new image size's
/// G-buffer and output) pays that inside its work: about 14 us a page in this virtual machine,
/// 14 ms to clear a 640x360 G-buffer of 3.7 MB against 0.4 ms in 2 MiB pages. So where the
/// device can import host memory (VK_EXT_external_memory_host: lavapipe), a buffer of
/// kHugeImportBytes or more is memory of our own, mapped on a 2 MiB boundary and advised into
/// 2 MiB pages (transparent huge pages "madvise", Debian's default, or "always"); elsewhere the
/// 2 MiB-aligned interior of the driver's mapping is advised. A buffer is then resident in
/// 2 MiB steps (the cache fills from its start: at most one step more than it holds).
/// `CSGV_HUGE_PAGES=0` asks for none.
constexpr uint64_t kHugePage = uint64_t(2) << 20, kHugeImportBytes = uint64_t(1) << 20;

bool hugePagesWanted() {
    static const bool wanted = [] {
        const char* env = std::getenv("CSGV_HUGE_PAGES");
        return !(env && std::strcmp(env, "0") == 0);
    }();
    return wanted;
}

void adviseHugePages(void* mapped, uint64_t bytes) {
    if (!hugePagesWanted() || !mapped || bytes < kHugePage) return;
    const uintptr_t at = reinterpret_cast<uintptr_t>(mapped);
    const uintptr_t from = (at + kHugePage - 1) & ~uintptr_t(kHugePage - 1), to = (at + bytes) & ~uintptr_t(kHugePage - 1);
    if (to > from) (void)madvise(reinterpret_cast<void*>(from), to - from, MADV_HUGEPAGE); // advice: refused is fine
}

/// `bytes` (a multiple of kHugePage) of fresh memory on a 2 MiB boundary, advised into 2 MiB pages;
/// nullptr if the system has none to give.
void* hugePageMapping(uint64_t bytes) {
    void* raw = ::mmap(nullptr, bytes + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    if (raw == MAP_FAILED) return nullptr;
    const uintptr_t at = reinterpret_cast<uintptr_t>(raw);
    const uintptr_t aligned = (at + kHugePage - 1) & ~uintptr_t(kHugePage - 1);
    if (aligned > at) ::munmap(raw, aligned - at); // the head and tail beyond the aligned run
    if (at + kHugePage > aligned) ::munmap(reinterpret_cast<void*>(aligned + bytes), at + kHugePage - aligned);
    (void)madvise(reinterpret_cast<void*>(aligned), bytes, MADV_HUGEPAGE);
    return reinterpret_cast<void*>(aligned);
}

std::string lower(std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

const char* typeName(VkPhysicalDeviceType t) {
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
    }
}

/// Lower is better: discrete GPUs, then other GPUs, then anything, then CPU devices.
int preference(const std::string& type) {
    if (type == "discrete") return 0;
    if (type == "integrated" || type == "virtual") return 1;
    if (type == "cpu") return 3;
    return 2;
}

int computeQueueFamily(const VulkanFunctions& vk, VkPhysicalDevice pd) {
    uint32_t n = 0;
    vk.vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, nullptr);
    std::vector<VkQueueFamilyProperties> props(n);
    vk.vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, props.data());
    for (uint32_t i = 0; i < n; ++i)
        if (props[i].queueFlags & VK_QUEUE_COMPUTE_BIT) return int(i);
    return -1;
}

DeviceInfo describe(const VulkanFunctions& vk, VkPhysicalDevice pd, uint32_t index) {
    DeviceInfo info;
    info.index = index;
    VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceMaintenance3Properties m3{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES};
    subgroup.pNext = &m3;
    VkPhysicalDeviceProperties2 props{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    props.pNext = &subgroup;
    vk.vkGetPhysicalDeviceProperties2(pd, &props);
    info.name = props.properties.deviceName;
    info.type = typeName(props.properties.deviceType);
    info.apiVersion = props.properties.apiVersion;
    info.maxAllocation = m3.maxMemoryAllocationSize;
    info.maxTexelBufferElements = props.properties.limits.maxTexelBufferElements;
    info.subgroupSize = subgroup.subgroupSize;
    // What this process may use of the largest device-local heap: VK_EXT_memory_budget's heap
    // budget (it leaves out what other processes hold) where the device has the extension, else
    // the heap's size.
    uint32_t extensionCount = 0;
    vk.vkEnumerateDeviceExtensionProperties(pd, nullptr, &extensionCount, nullptr);
    std::vector<VkExtensionProperties> extensions(extensionCount);
    vk.vkEnumerateDeviceExtensionProperties(pd, nullptr, &extensionCount, extensions.data());
    extensions.resize(extensionCount);
    for (const VkExtensionProperties& e : extensions)
        if (std::strcmp(e.extensionName, VK_EXT_MEMORY_BUDGET_EXTENSION_NAME) == 0) info.memoryBudgetReported = true;
    VkPhysicalDeviceMemoryBudgetPropertiesEXT budget{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MEMORY_BUDGET_PROPERTIES_EXT};
    VkPhysicalDeviceMemoryProperties2 mem2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MEMORY_PROPERTIES_2};
    if (info.memoryBudgetReported) mem2.pNext = &budget;
    vk.vkGetPhysicalDeviceMemoryProperties2(pd, &mem2);
    const VkPhysicalDeviceMemoryProperties& mem = mem2.memoryProperties;
    for (uint32_t h = 0; h < mem.memoryHeapCount; ++h)
        if ((mem.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) && mem.memoryHeaps[h].size > info.deviceLocalBytes) {
            info.deviceLocalBytes = mem.memoryHeaps[h].size;
            info.memoryBudgetBytes = info.memoryBudgetReported && budget.heapBudget[h] > 0 ? budget.heapBudget[h]
                                                                                           : mem.memoryHeaps[h].size;
        }

    std::vector<std::string> missing;
    if (VK_API_VERSION_MAJOR(info.apiVersion) == 1 && VK_API_VERSION_MINOR(info.apiVersion) < 2)
        missing.push_back("Vulkan 1.2");
    else {
        VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
        VkPhysicalDeviceFeatures2 f{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
        f.pNext = &f12;
        vk.vkGetPhysicalDeviceFeatures2(pd, &f);
        if (!f12.bufferDeviceAddress) missing.push_back("bufferDeviceAddress");
        if (!f.features.shaderInt64) missing.push_back("shaderInt64");
    }
    if (computeQueueFamily(vk, pd) < 0) missing.push_back("a compute queue");
    for (size_t i = 0; i < missing.size(); ++i) info.missing += (i ? ", " : "") + missing[i];
    return info;
}

} // namespace

struct Context::Impl {
    VulkanFunctions vk;
    VkInstance instance = VK_NULL_HANDLE;
    VkPhysicalDevice physical = VK_NULL_HANDLE;
    VkDevice device = VK_NULL_HANDLE;
    VkQueue queue = VK_NULL_HANDLE;
    uint32_t queueFamily = 0;
    VkCommandPool pool = VK_NULL_HANDLE;
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    VkPhysicalDeviceMemoryProperties memory{};
    /// VK_EXT_external_memory_host's query, where buffers are imported from our own memory in
    /// 2 MiB pages (CPU devices, hugePagesWanted()); nullptr elsewhere.
    PFN_vkGetMemoryHostPointerPropertiesEXT hostPointerProperties = nullptr;
    struct Pipeline {
        VkPipeline pipeline;
        VkPipelineLayout layout;
        uint32_t texelBindings;
    };
    std::map<uint64_t, Pipeline> pipelines;
    /// The pipeline made from each SPIR-V, push-constant size and texel bindings (the whole words:
    /// a match is exact): a renderer made again for the same volume, or another view's, compiles
    /// nothing.
    std::map<std::tuple<uint32_t, uint32_t, std::vector<uint32_t>>, uint64_t> pipelineOf;
    /// The set layout of n uniform texel buffers (bindings 0..n-1), one per n: pipelines and sets
    /// of the same n are compatible.
    std::map<uint32_t, VkDescriptorSetLayout> texelLayouts;
    Result<VkDescriptorSetLayout> texelLayout(uint32_t n) { // under pipelineMutex
        if (auto it = texelLayouts.find(n); it != texelLayouts.end()) return it->second;
        std::vector<VkDescriptorSetLayoutBinding> b(n);
        for (uint32_t i = 0; i < n; ++i)
            b[i] = {i, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
        VkDescriptorSetLayoutCreateInfo ci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
        ci.bindingCount = n;
        ci.pBindings = b.data();
        VkDescriptorSetLayout layout = VK_NULL_HANDLE;
        const VkResult r = vk.vkCreateDescriptorSetLayout(device, &ci, nullptr, &layout);
        if (r != VK_SUCCESS) return Status::error(vkError("vkCreateDescriptorSetLayout", r));
        texelLayouts[n] = layout;
        return layout;
    }
    std::mutex pipelineMutex; // pipelines may be made on several threads at once (Renderer)
    /// One submission at a time: they share one command buffer and fence, and renderers may be
    /// made on a thread of their own (uploads) while others render.
    std::mutex submitMutex;
    /// Set after a timeout or device loss: the GPU may still use every object, so nothing is
    /// freed or waited on again (a leak, never a crash or a hang) and all work is refused.
    std::atomic<bool> lost{false};
    uint64_t timeoutNs = uint64_t(120) * 1000000000ull;
    Status lostError() const {
        return Status::error("the Vulkan device stopped responding earlier; create a new context");
    }

    Status createInstance() {
        Status s = vk.loadGlobal();
        if (!s) return s;
        VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
        app.pApplicationName = "csgv";
        app.apiVersion = VK_API_VERSION_1_2;
        VkInstanceCreateInfo ci{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
        ci.pApplicationInfo = &app;
        // Validation on request only (tests set it); never required.
        const char* validation = "VK_LAYER_KHRONOS_validation";
        const char* want = std::getenv("CSGV_VULKAN_VALIDATION");
        if (want && *want && std::strcmp(want, "0") != 0) {
            uint32_t n = 0;
            vk.vkEnumerateInstanceLayerProperties(&n, nullptr);
            std::vector<VkLayerProperties> layers(n);
            vk.vkEnumerateInstanceLayerProperties(&n, layers.data());
            for (const auto& l : layers)
                if (std::strcmp(l.layerName, validation) == 0) {
                    ci.enabledLayerCount = 1;
                    ci.ppEnabledLayerNames = &validation;
                }
        }
        const VkResult r = vk.vkCreateInstance(&ci, nullptr, &instance);
        if (r != VK_SUCCESS) return Status::error(vkError("vkCreateInstance", r));
        return vk.loadInstance(instance);
    }

    std::vector<VkPhysicalDevice> physicalDevices() {
        uint32_t n = 0;
        vk.vkEnumeratePhysicalDevices(instance, &n, nullptr);
        std::vector<VkPhysicalDevice> devices(n);
        vk.vkEnumeratePhysicalDevices(instance, &n, devices.data());
        devices.resize(n);
        return devices;
    }

    int memoryType(uint32_t bits, VkMemoryPropertyFlags want, VkMemoryPropertyFlags avoid = 0) const {
        for (uint32_t i = 0; i < memory.memoryTypeCount; ++i)
            if ((bits & (1u << i)) && (memory.memoryTypes[i].propertyFlags & want) == want &&
                !(memory.memoryTypes[i].propertyFlags & avoid))
                return int(i);
        return -1;
    }

    ~Impl() {
        if (lost) return;
        if (device) {
            vk.vkDeviceWaitIdle(device);
            for (auto& p : pipelines) {
                vk.vkDestroyPipeline(device, p.second.pipeline, nullptr);
                vk.vkDestroyPipelineLayout(device, p.second.layout, nullptr);
            }
            for (auto& l : texelLayouts) vk.vkDestroyDescriptorSetLayout(device, l.second, nullptr);
            if (fence) vk.vkDestroyFence(device, fence, nullptr);
            if (pool) vk.vkDestroyCommandPool(device, pool, nullptr);
            vk.vkDestroyDevice(device, nullptr);
        }
        if (instance) vk.vkDestroyInstance(instance, nullptr);
    }
};

Context::Context() : m_impl(std::make_unique<Impl>()) {}
Context::~Context() = default;

Result<std::vector<DeviceInfo>> Context::listDevices() {
    Impl impl;
    Status s = impl.createInstance();
    if (!s) return s;
    std::vector<DeviceInfo> out;
    const auto devices = impl.physicalDevices();
    for (uint32_t i = 0; i < devices.size(); ++i) out.push_back(describe(impl.vk, devices[i], i));
    return out;
}

Result<std::unique_ptr<Context>> Context::create() {
    std::unique_ptr<Context> ctx(new Context());
    Impl& im = *ctx->m_impl;
    Status s = im.createInstance();
    if (!s) return s;
    const auto devices = im.physicalDevices();
    if (devices.empty())
        return Status::error("no Vulkan device found (for a CPU device: apt-get install mesa-vulkan-drivers)");
    std::vector<DeviceInfo> infos;
    for (uint32_t i = 0; i < devices.size(); ++i) infos.push_back(describe(im.vk, devices[i], i));

    int chosen = -1;
    const char* env = std::getenv("CSGV_VULKAN_DEVICE");
    if (env && *env) {
        const std::string want = env;
        const bool numeric = want.find_first_not_of("0123456789") == std::string::npos;
        for (const DeviceInfo& d : infos)
            if ((numeric && std::to_string(d.index) == want) ||
                (!numeric && lower(d.name).find(lower(want)) != std::string::npos)) {
                chosen = int(d.index);
                break;
            }
        std::string names;
        for (const DeviceInfo& d : infos) names += (names.empty() ? "" : ", ") + std::to_string(d.index) + ": " + d.name;
        if (chosen < 0) return Status::error("CSGV_VULKAN_DEVICE='" + want + "' matches no device (" + names + ")");
        if (!infos[size_t(chosen)].missing.empty())
            return Status::error("Vulkan device '" + infos[size_t(chosen)].name + "' lacks " + infos[size_t(chosen)].missing);
    } else {
        for (const DeviceInfo& d : infos)
            if (d.missing.empty() &&
                (chosen < 0 || preference(d.type) < preference(infos[size_t(chosen)].type)))
                chosen = int(d.index);
        if (chosen < 0) {
            std::string why;
            for (const DeviceInfo& d : infos) why += (why.empty() ? "" : "; ") + d.name + " lacks " + d.missing;
            return Status::error("no usable Vulkan device: " + why);
        }
    }
    ctx->m_info = infos[size_t(chosen)];
    im.physical = devices[size_t(chosen)];
    im.queueFamily = uint32_t(computeQueueFamily(im.vk, im.physical));
    im.vk.vkGetPhysicalDeviceMemoryProperties(im.physical, &im.memory);

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo q{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    q.queueFamilyIndex = im.queueFamily;
    q.queueCount = 1;
    q.pQueuePriorities = &priority;
    VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
    f12.bufferDeviceAddress = VK_TRUE;
    VkPhysicalDeviceFeatures2 features{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
    features.pNext = &f12;
    features.features.shaderInt64 = VK_TRUE;
    VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
    dci.pNext = &features;
    dci.queueCreateInfoCount = 1;
    dci.pQueueCreateInfos = &q;
    const char* hostImport = VK_EXT_EXTERNAL_MEMORY_HOST_EXTENSION_NAME;
    bool importsHost = false;
    if (ctx->m_info.type == "cpu" && hugePagesWanted()) {
        uint32_t n = 0;
        im.vk.vkEnumerateDeviceExtensionProperties(im.physical, nullptr, &n, nullptr);
        std::vector<VkExtensionProperties> extensions(n);
        im.vk.vkEnumerateDeviceExtensionProperties(im.physical, nullptr, &n, extensions.data());
        extensions.resize(n);
        for (const VkExtensionProperties& e : extensions) importsHost = importsHost || std::strcmp(e.extensionName, hostImport) == 0;
    }
    if (importsHost) {
        dci.enabledExtensionCount = 1;
        dci.ppEnabledExtensionNames = &hostImport;
    }
    VkResult r = im.vk.vkCreateDevice(im.physical, &dci, nullptr, &im.device);
    if (r != VK_SUCCESS) return Status::error(vkError("vkCreateDevice", r) + " on " + ctx->m_info.name);
    s = im.vk.loadDevice(im.device);
    if (!s) return s;
    if (importsHost)
        im.hostPointerProperties = reinterpret_cast<PFN_vkGetMemoryHostPointerPropertiesEXT>(
            im.vk.vkGetDeviceProcAddr(im.device, "vkGetMemoryHostPointerPropertiesEXT"));
    im.vk.vkGetDeviceQueue(im.device, im.queueFamily, 0, &im.queue);
    VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pci.queueFamilyIndex = im.queueFamily;
    if ((r = im.vk.vkCreateCommandPool(im.device, &pci, nullptr, &im.pool)) != VK_SUCCESS)
        return Status::error(vkError("vkCreateCommandPool", r));
    VkCommandBufferAllocateInfo cai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    cai.commandPool = im.pool;
    cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cai.commandBufferCount = 1;
    if ((r = im.vk.vkAllocateCommandBuffers(im.device, &cai, &im.cmd)) != VK_SUCCESS)
        return Status::error(vkError("vkAllocateCommandBuffers", r));
    VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    if ((r = im.vk.vkCreateFence(im.device, &fci, nullptr, &im.fence)) != VK_SUCCESS)
        return Status::error(vkError("vkCreateFence", r));
    return ctx;
}

// ---- Buffers ----

Buffer::~Buffer() { release(); }

Buffer::Buffer(Buffer&& o) noexcept { *this = std::move(o); }

Buffer& Buffer::operator=(Buffer&& o) noexcept {
    if (this != &o) {
        release();
        m_context = o.m_context;
        m_buffer = o.m_buffer;
        m_memory = o.m_memory;
        m_size = o.m_size;
        m_address = o.m_address;
        m_mapped = o.m_mapped;
        m_serial = o.m_serial;
        m_host = o.m_host;
        m_hostBytes = o.m_hostBytes;
        o.m_context = nullptr;
        o.m_serial = 0;
        o.m_buffer = o.m_memory = 0;
        o.m_mapped = o.m_host = nullptr;
        o.m_hostBytes = 0;
    }
    return *this;
}

void Buffer::release() {
    if (!m_context) return;
    Context::Impl& im = *m_context->m_impl;
    if (im.lost) { // the GPU may still be using it
        m_context = nullptr;
        m_buffer = m_memory = 0;
        m_mapped = nullptr;
        return;
    }
    if (m_mapped) im.vk.vkUnmapMemory(im.device, reinterpret_cast<VkDeviceMemory>(m_memory));
    if (m_buffer) im.vk.vkDestroyBuffer(im.device, reinterpret_cast<VkBuffer>(m_buffer), nullptr);
    if (m_memory) im.vk.vkFreeMemory(im.device, reinterpret_cast<VkDeviceMemory>(m_memory), nullptr);
    if (m_host) ::munmap(m_host, m_hostBytes); // after the device memory made of it
    m_context = nullptr;
    m_buffer = m_memory = 0;
    m_mapped = m_host = nullptr;
    m_hostBytes = 0;
}

Result<Buffer> Context::createBuffer(uint64_t bytes, MemoryKind kind) {
    Impl& im = *m_impl;
    if (im.lost) return im.lostError();
    bytes = std::max<uint64_t>(bytes, 4);
    if (m_info.maxAllocation && bytes > m_info.maxAllocation)
        return Status::error("a GPU buffer of " + std::to_string(bytes) + " bytes exceeds the device's allocation limit of " +
                             std::to_string(m_info.maxAllocation) + " bytes");
    // Imported from our own memory in 2 MiB pages where the device takes it (hugePageMapping);
    // should that fail at any step, the buffer is made again the usual way.
    if (im.hostPointerProperties && bytes >= kHugeImportBytes) {
        Result<Buffer> imported = createBuffer(bytes, kind, true);
        if (imported) return imported;
    }
    return createBuffer(bytes, kind, false);
}

Result<Buffer> Context::createBuffer(uint64_t bytes, MemoryKind kind, bool import) {
    Impl& im = *m_impl;
    VkExternalMemoryBufferCreateInfo external{VK_STRUCTURE_TYPE_EXTERNAL_MEMORY_BUFFER_CREATE_INFO};
    external.handleTypes = VK_EXTERNAL_MEMORY_HANDLE_TYPE_HOST_ALLOCATION_BIT_EXT;
    VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    if (import) bci.pNext = &external;
    bci.size = bytes;
    bci.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT |
                VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
    bci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    VkBuffer buffer = VK_NULL_HANDLE;
    VkResult r = im.vk.vkCreateBuffer(im.device, &bci, nullptr, &buffer);
    if (r != VK_SUCCESS) return Status::error(vkError("vkCreateBuffer", r));
    Buffer out;
    out.m_context = this;
    out.m_buffer = reinterpret_cast<uint64_t>(buffer);
    out.m_size = bytes;
    VkMemoryRequirements req{};
    im.vk.vkGetBufferMemoryRequirements(im.device, buffer, &req);
    int type = -1;
    VkImportMemoryHostPointerInfoEXT host{VK_STRUCTURE_TYPE_IMPORT_MEMORY_HOST_POINTER_INFO_EXT};
    if (import) {
        out.m_hostBytes = (req.size + kHugePage - 1) / kHugePage * kHugePage;
        out.m_host = hugePageMapping(out.m_hostBytes);
        if (!out.m_host) return Status::error("no host memory to import");
        VkMemoryHostPointerPropertiesEXT props{VK_STRUCTURE_TYPE_MEMORY_HOST_POINTER_PROPERTIES_EXT};
        if (im.hostPointerProperties(im.device, VK_EXTERNAL_MEMORY_HANDLE_TYPE_HOST_ALLOCATION_BIT_EXT, out.m_host, &props) !=
            VK_SUCCESS)
            return Status::error("the device does not import this memory");
        type = im.memoryType(req.memoryTypeBits & props.memoryTypeBits,
                             VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
        if (type < 0) return Status::error("no memory type imports host memory");
        host.handleType = VK_EXTERNAL_MEMORY_HANDLE_TYPE_HOST_ALLOCATION_BIT_EXT;
        host.pHostPointer = out.m_host;
    } else if (kind == MemoryKind::DeviceLocal) {
        type = im.memoryType(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    } else {
        type = im.memoryType(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT |
                                                     VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
        if (type < 0)
            type = im.memoryType(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    }
    if (type < 0) type = im.memoryType(req.memoryTypeBits, 0);
    if (type < 0) return Status::error("no Vulkan memory type fits a buffer");
    VkMemoryAllocateFlagsInfo flags{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO};
    flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
    if (import) flags.pNext = &host;
    VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    mai.pNext = &flags;
    mai.allocationSize = import ? out.m_hostBytes : req.size;
    mai.memoryTypeIndex = uint32_t(type);
    VkDeviceMemory memory = VK_NULL_HANDLE;
    r = im.vk.vkAllocateMemory(im.device, &mai, nullptr, &memory);
    if (r != VK_SUCCESS)
        return Status::error(vkError("vkAllocateMemory", r) + " (" + std::to_string(bytes) + " bytes)");
    out.m_memory = reinterpret_cast<uint64_t>(memory);
    if ((r = im.vk.vkBindBufferMemory(im.device, buffer, memory, 0)) != VK_SUCCESS)
        return Status::error(vkError("vkBindBufferMemory", r));
    if (im.memory.memoryTypes[type].propertyFlags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) {
        if ((r = im.vk.vkMapMemory(im.device, memory, 0, VK_WHOLE_SIZE, 0, &out.m_mapped)) != VK_SUCCESS)
            return Status::error(vkError("vkMapMemory", r));
        if (m_info.type == "cpu" && !import) adviseHugePages(out.m_mapped, req.size);
    }
    VkBufferDeviceAddressInfo bai{VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO};
    bai.buffer = buffer;
    out.m_address = im.vk.vkGetBufferDeviceAddress(im.device, &bai);
    static std::atomic<uint64_t> serials{0};
    out.m_serial = ++serials;
    return out;
}

namespace {
/// Records, submits and waits for one command buffer.
template <typename Record>
Status submitAndWait(Context::Impl& im, Record record) {
    std::lock_guard<std::mutex> lock(im.submitMutex);
    if (im.lost) return im.lostError();
    im.vk.vkResetCommandBuffer(im.cmd, 0);
    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    VkResult r = im.vk.vkBeginCommandBuffer(im.cmd, &begin);
    if (r != VK_SUCCESS) return Status::error(vkError("vkBeginCommandBuffer", r));
    record(im.cmd);
    if ((r = im.vk.vkEndCommandBuffer(im.cmd)) != VK_SUCCESS) return Status::error(vkError("vkEndCommandBuffer", r));
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &im.cmd;
    im.vk.vkResetFences(im.device, 1, &im.fence);
    // Submission: the recorded work; the fence tells the host when all of it has finished.
    if ((r = im.vk.vkQueueSubmit(im.queue, 1, &si, im.fence)) != VK_SUCCESS) {
        im.lost = r == VK_ERROR_DEVICE_LOST;
        return Status::error(vkError("vkQueueSubmit", r));
    }
    r = im.vk.vkWaitForFences(im.device, 1, &im.fence, VK_TRUE, im.timeoutNs);
    if (r != VK_SUCCESS) {
        im.lost = true;
        return Status::error(r == VK_TIMEOUT ? "the GPU did not finish within " +
                                                   std::to_string(double(im.timeoutNs) / 1e9) + " s"
                                             : vkError("vkWaitForFences", r));
    }
    return Status::ok();
}

void transferBarrier(VulkanFunctions& vk, VkCommandBuffer cmd) {
    // Barrier: transfers before it complete before shaders or host reads after it.
    VkMemoryBarrier b{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    b.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    b.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_HOST_READ_BIT;
    vk.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                            VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &b, 0, nullptr, 0,
                            nullptr);
}
} // namespace

Status Context::upload(Buffer& dst, uint64_t offset, const void* data, uint64_t bytes) {
    if (offset + bytes > dst.size()) return Status::error("upload past the end of a GPU buffer");
    if (bytes == 0) return Status::ok();
    if (dst.mapped()) {
        std::memcpy(static_cast<uint8_t*>(dst.mapped()) + offset, data, size_t(bytes));
        return Status::ok();
    }
    Result<Buffer> staging = createBuffer(bytes, MemoryKind::HostVisible);
    if (!staging) return staging.status();
    std::memcpy(staging->mapped(), data, size_t(bytes));
    Impl& im = *m_impl;
    return submitAndWait(im, [&](VkCommandBuffer cmd) {
        VkBufferCopy region{0, offset, bytes};
        im.vk.vkCmdCopyBuffer(cmd, reinterpret_cast<VkBuffer>(staging->m_buffer), reinterpret_cast<VkBuffer>(dst.m_buffer),
                              1, &region);
        transferBarrier(im.vk, cmd);
    });
}

Status Context::uploadFilled(Buffer& dst, uint64_t bytes, uint64_t chunk,
                             const std::function<uint64_t(uint64_t offset, void* out, uint64_t room)>& fill) {
    if (bytes > dst.size()) return Status::error("upload past the end of a GPU buffer");
    if (bytes == 0) return Status::ok();
    if (dst.mapped()) { // the same pieces, written in place
        for (uint64_t at = 0; at < bytes;) {
            const uint64_t room = std::min(bytes - at, std::max<uint64_t>(chunk, 4));
            const uint64_t n = fill(at, static_cast<uint8_t*>(dst.mapped()) + at, room);
            if (n == 0 || n > room) return Status::error("an upload's source gave no data");
            at += n;
        }
        return Status::ok();
    }
    Result<Buffer> staging = createBuffer(std::min(bytes, std::max<uint64_t>(chunk, 4)), MemoryKind::HostVisible);
    if (!staging) return staging.status();
    for (uint64_t at = 0; at < bytes;) {
        const uint64_t room = std::min(bytes - at, staging->size());
        const uint64_t n = fill(at, staging->mapped(), room);
        if (n == 0 || n > room) return Status::error("an upload's source gave no data");
        if (Status s = copy(*staging, 0, dst, at, n); !s) return s;
        at += n;
    }
    return Status::ok();
}

Status Context::uploadRegions(Buffer& dst, const void* data, const std::vector<CopyRegion>& regions) {
    uint64_t end = 0;
    for (const CopyRegion& r : regions) {
        if (r.dstOffset + r.bytes > dst.size()) return Status::error("upload past the end of a GPU buffer");
        end = std::max(end, r.srcOffset + r.bytes);
    }
    if (regions.empty() || end == 0) return Status::ok();
    const uint8_t* src = static_cast<const uint8_t*>(data);
    if (dst.mapped()) {
        for (const CopyRegion& r : regions) std::memcpy(static_cast<uint8_t*>(dst.mapped()) + r.dstOffset, src + r.srcOffset, size_t(r.bytes));
        return Status::ok();
    }
    Result<Buffer> staging = createBuffer(end, MemoryKind::HostVisible);
    if (!staging) return staging.status();
    std::memcpy(staging->mapped(), data, size_t(end));
    std::vector<VkBufferCopy> copies;
    copies.reserve(regions.size());
    for (const CopyRegion& r : regions) copies.push_back(VkBufferCopy{r.srcOffset, r.dstOffset, r.bytes});
    Impl& im = *m_impl;
    return submitAndWait(im, [&](VkCommandBuffer cmd) {
        im.vk.vkCmdCopyBuffer(cmd, reinterpret_cast<VkBuffer>(staging->m_buffer), reinterpret_cast<VkBuffer>(dst.m_buffer),
                              uint32_t(copies.size()), copies.data());
        transferBarrier(im.vk, cmd);
    });
}

Status Context::download(const Buffer& src, uint64_t offset, void* data, uint64_t bytes) {
    if (offset + bytes > src.size()) return Status::error("download past the end of a GPU buffer");
    if (bytes == 0) return Status::ok();
    if (src.mapped()) {
        std::memcpy(data, static_cast<const uint8_t*>(src.mapped()) + offset, size_t(bytes));
        return Status::ok();
    }
    Result<Buffer> staging = createBuffer(bytes, MemoryKind::HostVisible);
    if (!staging) return staging.status();
    Impl& im = *m_impl;
    Status s = submitAndWait(im, [&](VkCommandBuffer cmd) {
        VkBufferCopy region{offset, 0, bytes};
        im.vk.vkCmdCopyBuffer(cmd, reinterpret_cast<VkBuffer>(src.m_buffer), reinterpret_cast<VkBuffer>(staging->m_buffer),
                              1, &region);
        transferBarrier(im.vk, cmd);
    });
    if (!s) return s;
    std::memcpy(data, staging->mapped(), size_t(bytes));
    return Status::ok();
}

Status Context::copy(const Buffer& src, uint64_t srcOffset, Buffer& dst, uint64_t dstOffset, uint64_t bytes) {
    if (bytes == 0) return Status::ok();
    const CopyRegion region{srcOffset, dstOffset, bytes};
    Dispatch d;
    d.copyFrom = &src;
    d.copyTo = &dst;
    d.copyRegions = &region;
    d.copyRegionCount = 1;
    return run(&d, 1); // run() refuses a region past either buffer's end
}

TexelSet::~TexelSet() { release(); }

TexelSet::TexelSet(TexelSet&& o) noexcept { *this = std::move(o); }

TexelSet& TexelSet::operator=(TexelSet&& o) noexcept {
    if (this != &o) {
        release();
        m_context = o.m_context;
        m_pool = o.m_pool;
        m_set = o.m_set;
        m_views = std::move(o.m_views);
        o.m_context = nullptr;
        o.m_pool = o.m_set = 0;
        o.m_views.clear();
    }
    return *this;
}

void TexelSet::release() {
    if (!m_context) return;
    Context::Impl& im = *m_context->m_impl;
    if (!im.lost) { // else the GPU may still be using them: left (a leak, never a crash)
        if (m_pool) im.vk.vkDestroyDescriptorPool(im.device, reinterpret_cast<VkDescriptorPool>(m_pool), nullptr);
        for (uint64_t v : m_views) im.vk.vkDestroyBufferView(im.device, reinterpret_cast<VkBufferView>(v), nullptr);
    }
    m_context = nullptr;
    m_pool = m_set = 0;
    m_views.clear();
}

Result<TexelSet> Context::createTexelSet(const std::vector<const Buffer*>& buffers, uint32_t wordsPerTexel) {
    return createTexelSet(buffers, std::vector<uint32_t>(buffers.size(), wordsPerTexel));
}

Result<TexelSet> Context::createTexelSet(const std::vector<const Buffer*>& buffers,
                                         const std::vector<uint32_t>& wordsPerTexel) {
    Impl& im = *m_impl;
    if (im.lost) return im.lostError();
    if (buffers.empty()) return Status::error("a texel set of no buffers");
    if (wordsPerTexel.size() != buffers.size())
        return Status::error("a texel set of " + std::to_string(buffers.size()) + " buffers given " +
                             std::to_string(wordsPerTexel.size()) + " texel widths");
    TexelSet out;
    out.m_context = this;
    for (size_t i = 0; i < buffers.size(); ++i) {
        const Buffer* b = buffers[i];
        const uint32_t words = wordsPerTexel[i];
        if (words != 1 && words != 2 && words != 4)
            return Status::error("texels of " + std::to_string(words) + " words (1, 2 or 4 are viewed)");
        const uint64_t texelBytes = 4ull * words;
        if (!b || !b->valid()) return Status::error("a texel view of no buffer");
        if (b->size() / texelBytes > m_info.maxTexelBufferElements)
            return Status::error("a texel view of " + std::to_string(b->size() / texelBytes) +
                                 " texels exceeds the device's limit of " + std::to_string(m_info.maxTexelBufferElements));
        if (b->size() < texelBytes) return Status::error("a texel view of a buffer smaller than one texel");
        VkBufferViewCreateInfo vci{VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO};
        vci.buffer = reinterpret_cast<VkBuffer>(b->m_buffer);
        vci.format = words == 4 ? VK_FORMAT_R32G32B32A32_UINT : (words == 2 ? VK_FORMAT_R32G32_UINT : VK_FORMAT_R32_UINT);
        vci.offset = 0;
        vci.range = b->size() / texelBytes * texelBytes;
        VkBufferView view = VK_NULL_HANDLE;
        const VkResult r = im.vk.vkCreateBufferView(im.device, &vci, nullptr, &view);
        if (r != VK_SUCCESS) return Status::error(vkError("vkCreateBufferView", r));
        out.m_views.push_back(reinterpret_cast<uint64_t>(view));
    }
    const uint32_t n = uint32_t(buffers.size());
    VkDescriptorSetLayout layout = VK_NULL_HANDLE;
    {
        std::lock_guard<std::mutex> lock(im.pipelineMutex);
        Result<VkDescriptorSetLayout> l = im.texelLayout(n);
        if (!l) return l.status();
        layout = *l;
    }
    VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, n};
    VkDescriptorPoolCreateInfo pci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    pci.maxSets = 1;
    pci.poolSizeCount = 1;
    pci.pPoolSizes = &size;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkResult r = im.vk.vkCreateDescriptorPool(im.device, &pci, nullptr, &pool);
    if (r != VK_SUCCESS) return Status::error(vkError("vkCreateDescriptorPool", r));
    out.m_pool = reinterpret_cast<uint64_t>(pool);
    VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    ai.descriptorPool = pool;
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &layout;
    VkDescriptorSet set = VK_NULL_HANDLE;
    r = im.vk.vkAllocateDescriptorSets(im.device, &ai, &set);
    if (r != VK_SUCCESS) return Status::error(vkError("vkAllocateDescriptorSets", r));
    out.m_set = reinterpret_cast<uint64_t>(set);
    std::vector<VkBufferView> views(n);
    std::vector<VkWriteDescriptorSet> writes(n);
    for (uint32_t i = 0; i < n; ++i) {
        views[i] = reinterpret_cast<VkBufferView>(out.m_views[i]);
        writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
        writes[i].dstSet = set;
        writes[i].dstBinding = i;
        writes[i].descriptorCount = 1;
        writes[i].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
        writes[i].pTexelBufferView = &views[i];
    }
    im.vk.vkUpdateDescriptorSets(im.device, n, writes.data(), 0, nullptr);
    return out;
}

Result<uint64_t> Context::createComputePipeline(const std::vector<uint32_t>& spirv, uint32_t pushConstantBytes,
                                                uint32_t texelBindings) {
    Impl& im = *m_impl;
    auto key = std::make_tuple(pushConstantBytes, texelBindings, spirv);
    VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
    {
        std::lock_guard<std::mutex> lock(im.pipelineMutex);
        if (auto it = im.pipelineOf.find(key); it != im.pipelineOf.end()) return it->second;
        if (texelBindings) {
            Result<VkDescriptorSetLayout> l = im.texelLayout(texelBindings);
            if (!l) return l.status();
            setLayout = *l;
        }
    }
    VkShaderModuleCreateInfo smci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    smci.codeSize = spirv.size() * 4;
    smci.pCode = spirv.data();
    VkShaderModule module = VK_NULL_HANDLE;
    VkResult r = im.vk.vkCreateShaderModule(im.device, &smci, nullptr, &module);
    if (r != VK_SUCCESS) return Status::error(vkError("vkCreateShaderModule", r));
    VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, pushConstantBytes};
    VkPipelineLayoutCreateInfo lci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    lci.pushConstantRangeCount = pushConstantBytes ? 1 : 0;
    lci.pPushConstantRanges = &range;
    lci.setLayoutCount = texelBindings ? 1 : 0;
    lci.pSetLayouts = &setLayout;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    r = im.vk.vkCreatePipelineLayout(im.device, &lci, nullptr, &layout);
    if (r != VK_SUCCESS) {
        im.vk.vkDestroyShaderModule(im.device, module, nullptr);
        return Status::error(vkError("vkCreatePipelineLayout", r));
    }
    VkComputePipelineCreateInfo cci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    cci.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    cci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    cci.stage.module = module;
    cci.stage.pName = "main";
    cci.layout = layout;
    VkPipeline pipeline = VK_NULL_HANDLE;
    r = im.vk.vkCreateComputePipelines(im.device, VK_NULL_HANDLE, 1, &cci, nullptr, &pipeline);
    im.vk.vkDestroyShaderModule(im.device, module, nullptr);
    if (r != VK_SUCCESS) {
        im.vk.vkDestroyPipelineLayout(im.device, layout, nullptr);
        return Status::error(vkError("vkCreateComputePipelines", r));
    }
    const uint64_t handle = reinterpret_cast<uint64_t>(pipeline);
    std::lock_guard<std::mutex> lock(im.pipelineMutex);
    if (auto it = im.pipelineOf.find(key); it != im.pipelineOf.end()) { // another thread made it meanwhile
        im.vk.vkDestroyPipeline(im.device, pipeline, nullptr);
        im.vk.vkDestroyPipelineLayout(im.device, layout, nullptr);
        return it->second;
    }
    im.pipelines[handle] = Impl::Pipeline{pipeline, layout, texelBindings};
    im.pipelineOf.emplace(std::move(key), handle);
    return handle;
}

void Context::setSubmitTimeout(double seconds) {
    m_impl->timeoutNs = seconds <= 0 ? 1 : uint64_t(seconds * 1e9);
}

bool Context::lost() const { return m_impl->lost; }

size_t Context::pipelineCount() const {
    std::lock_guard<std::mutex> lock(m_impl->pipelineMutex);
    return m_impl->pipelineOf.size();
}

Status Context::run(const Dispatch* first, size_t count) {
    Impl& im = *m_impl;
    const Dispatch* const last = first + count;
    // Each dispatch's pipeline, looked up under the lock that guards the table: another renderer
    // may be making pipelines on a thread of its own meanwhile (a new view preparing, a renderer
    // warming the other shading modes), and a map read during an insert is a data race.
    std::vector<Impl::Pipeline> resolved(count);
    std::unique_lock<std::mutex> tableLock(im.pipelineMutex);
    for (const Dispatch* d = first; d != last; ++d) {
        if (d->fill && !d->fill->valid()) return Status::error("a fill of a buffer that does not exist");
        if (d->fill && (d->fillBytes % 4 != 0 || d->fillOffset % 4 != 0))
            return Status::error("a fill of " + std::to_string(d->fillBytes) + " bytes at byte " +
                                 std::to_string(d->fillOffset) + ": not whole 32-bit words");
        if (d->fill && (d->fillOffset > d->fill->size() || d->fillBytes > d->fill->size() - d->fillOffset))
            return Status::error("a fill past its buffer's end (" + std::to_string(d->fillBytes) + " bytes at byte " +
                                 std::to_string(d->fillOffset) + " of " + std::to_string(d->fill->size()) + ")");
        if (d->copyFrom && (!d->copyFrom->valid() || !d->copyTo || !d->copyTo->valid() ||
                            d->copyBytes > d->copyFrom->size() || d->copyBytes > d->copyTo->size()))
            return Status::error("a copy between buffers that do not exist or hold fewer bytes");
        for (uint32_t i = 0; d->copyFrom && i < d->copyRegionCount; ++i) {
            const CopyRegion& r = d->copyRegions[i];
            const auto past = [&](uint64_t offset, const Buffer* b) { return offset > b->size() || r.bytes > b->size() - offset; };
            if (r.bytes == 0 || past(r.srcOffset, d->copyFrom) || past(r.dstOffset, d->copyTo))
                return Status::error("an empty copy region, or one past the end of its buffer (" + std::to_string(r.bytes) + " bytes from byte " +
                                     std::to_string(r.srcOffset) + " of " + std::to_string(d->copyFrom->size()) +
                                     " to byte " + std::to_string(r.dstOffset) + " of " + std::to_string(d->copyTo->size()) + ")");
        }
        if (d->fill || d->copyFrom) continue;
        auto p = im.pipelines.find(d->pipeline);
        if (p == im.pipelines.end()) return Status::error("dispatch of an unknown pipeline");
        if (p->second.texelBindings != (d->texels ? d->texels->bindings() : 0))
            return Status::error("a dispatch's texel buffers do not match its pipeline's bindings");
        resolved[size_t(d - first)] = p->second;
    }
    tableLock.unlock();
    return submitAndWait(im, [&](VkCommandBuffer cmd) {
        for (const Dispatch* it = first; it != last; ++it) {
            const Dispatch& d = *it;
            if (d.fill) {
                if (d.fillBytes == 0) continue;
                im.vk.vkCmdFillBuffer(cmd, reinterpret_cast<VkBuffer>(d.fill->m_buffer), d.fillOffset, d.fillBytes,
                                         d.fillValue);
                // Barrier: the fill is complete before later dispatches read or write the buffer.
                VkMemoryBarrier b{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
                b.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
                b.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_HOST_READ_BIT;
                im.vk.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                                           VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &b, 0,
                                           nullptr, 0, nullptr);
                continue;
            }
            if (d.copyFrom) {
                if (d.copyRegions ? d.copyRegionCount == 0 : d.copyBytes == 0) continue;
                // Barriers: what came before (dispatches, fills, copies) is written before the
                // copy reads; the copy is written before what follows reads or writes.
                VkMemoryBarrier before{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
                before.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
                before.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
                im.vk.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                                           VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &before, 0, nullptr, 0, nullptr);
                std::vector<VkBufferCopy> regions;
                if (d.copyRegions)
                    for (uint32_t i = 0; i < d.copyRegionCount; ++i)
                        regions.push_back({d.copyRegions[i].srcOffset, d.copyRegions[i].dstOffset, d.copyRegions[i].bytes});
                else
                    regions.push_back({0, 0, d.copyBytes});
                im.vk.vkCmdCopyBuffer(cmd, reinterpret_cast<VkBuffer>(d.copyFrom->m_buffer),
                                      reinterpret_cast<VkBuffer>(d.copyTo->m_buffer), uint32_t(regions.size()),
                                      regions.data());
                transferBarrier(im.vk, cmd);
                continue;
            }
            const Impl::Pipeline& p = resolved[size_t(it - first)];
            im.vk.vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.pipeline);
            if (d.texels) {
                const VkDescriptorSet set = reinterpret_cast<VkDescriptorSet>(d.texels->m_set);
                im.vk.vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 1, &set, 0, nullptr);
            }
            if (d.pushConstantBytes)
                im.vk.vkCmdPushConstants(cmd, p.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, d.pushConstantBytes,
                                         d.pushConstants);
            im.vk.vkCmdDispatch(cmd, d.groups[0], d.groups[1], d.groups[2]);
            if (d.overlapsNext && it + 1 != last) continue;
            // Barrier: each dispatch's writes are visible to the next dispatch and to the host.
            VkMemoryBarrier b{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
            b.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
            b.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_HOST_READ_BIT |
                              VK_ACCESS_TRANSFER_READ_BIT;
            im.vk.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                                       VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_HOST_BIT |
                                           VK_PIPELINE_STAGE_TRANSFER_BIT,
                                       0, 1, &b, 0, nullptr, 0, nullptr);
        }
    });
}

} // namespace csgv::gpu
