// SPDX-License-Identifier: MIT
#pragma once
/// @file Context.h
/// @brief Headless Vulkan: device choice, buffers addressed by device address, one-shot command
/// submission. No window, no surface; no Vulkan type appears in this header, so the layers above
/// include it without Vulkan headers.
///
/// Device choice: a discrete GPU, else an integrated or virtual GPU, else any other device, else
/// a CPU device (Mesa's lavapipe, "llvmpipe"). The environment variable `CSGV_VULKAN_DEVICE`
/// overrides by index (as listed by listDevices()) or by a case-insensitive part of the name.
/// Required: Vulkan 1.2, bufferDeviceAddress, shaderInt64, a compute queue; each missing one is
/// reported by name.

#include "csgv/base/Status.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace csgv::gpu {

struct DeviceInfo {
    uint32_t index = 0;
    std::string name;
    std::string type;            ///< "discrete", "integrated", "virtual", "cpu", "other"
    uint32_t apiVersion = 0;
    uint64_t maxAllocation = 0;  ///< largest single allocation in bytes
    uint64_t deviceLocalBytes = 0;   ///< size of the largest device-local heap
    /// What this process may use of that heap when the device opened: VK_EXT_memory_budget's
    /// heap budget where `memoryBudgetReported`, else the heap's size.
    uint64_t memoryBudgetBytes = 0;
    bool memoryBudgetReported = false;
    uint32_t subgroupSize = 0;
    uint32_t maxTexelBufferElements = 0; ///< the most elements a texel buffer view may hold
    std::string missing;         ///< required features it lacks ("" when usable)
};

/// The device-memory budget a renderer takes when none is given ("automatic"): three quarters of
/// what the device reports this process may use, leaving room for other applications and for
/// ParaView's own OpenGL memory on the same GPU.
inline uint64_t automaticDeviceMemoryBudget(const DeviceInfo& device) { return device.memoryBudgetBytes / 4 * 3; }

/// The brick cache a renderer asks for when none is given ("automatic"): 256 MiB on CPU devices
/// (host memory, which every other program shares; lavapipe reads a cache of up to 512 MiB through
/// texel views), elsewhere a quarter of what the device reports this process may use, shared by
/// `processes` (an MPI job's ranks, which may all use this device and each read the same budget
/// when it opened), at least 256 MiB and at most 2 GiB (an orbit of a 1024^3 volume at 1920x1080
/// used 560-820 MiB of 32-bit cache; 256 MiB thrashed on an H200). The renderer clamps it to what
/// its budget leaves.
inline uint64_t automaticCacheBytes(const DeviceInfo& device, uint32_t processes = 1)
{
    constexpr uint64_t least = 256ull << 20, most = 2048ull << 20;
    if (device.type == "cpu") return least;
    const uint64_t share = device.memoryBudgetBytes / 4 / (processes ? processes : 1);
    return share < least ? least : share > most ? most : share;
}

class Context;

/// @brief A buffer in device memory, addressed in shaders through its device address.
class Buffer {
public:
    Buffer() = default;
    ~Buffer();
    Buffer(Buffer&& other) noexcept;
    Buffer& operator=(Buffer&& other) noexcept;
    Buffer(const Buffer&) = delete;
    Buffer& operator=(const Buffer&) = delete;

    uint64_t size() const { return m_size; }
    uint64_t address() const { return m_address; }
    /// Unique in the process for each buffer made (0: none): what a view of it was made of,
    /// where a new buffer may take a freed one's address.
    uint64_t serial() const { return m_serial; }
    /// Host pointer for host-visible buffers (nullptr otherwise).
    void* mapped() const { return m_mapped; }
    bool valid() const { return m_buffer != 0; }

private:
    friend class Context;
    void release();
    Context* m_context = nullptr;
    uint64_t m_buffer = 0; ///< VkBuffer
    uint64_t m_memory = 0; ///< VkDeviceMemory
    uint64_t m_size = 0;
    uint64_t m_address = 0;
    void* m_mapped = nullptr;
    uint64_t m_serial = 0;
    void* m_host = nullptr;     ///< the process's own memory the device memory was imported from (CPU devices)
    uint64_t m_hostBytes = 0;   ///< its length, unmapped after the device memory is freed
};

/// @brief Buffers seen by a pipeline as uniform texel buffers (`usamplerBuffer`, one binding each,
/// set 0, in order), made by Context::createTexelSet. CPU devices (lavapipe) fetch texels for all
/// lanes with one gather instruction, where a read through a buffer address is a loop over the
/// lanes with a branch and a stall for each.
class TexelSet {
public:
    TexelSet() = default;
    ~TexelSet();
    TexelSet(TexelSet&& other) noexcept;
    TexelSet& operator=(TexelSet&& other) noexcept;
    TexelSet(const TexelSet&) = delete;
    TexelSet& operator=(const TexelSet&) = delete;

    bool valid() const { return m_set != 0; }
    uint32_t bindings() const { return uint32_t(m_views.size()); }

private:
    friend class Context;
    void release();
    Context* m_context = nullptr;
    uint64_t m_pool = 0; ///< VkDescriptorPool (of this set alone)
    uint64_t m_set = 0;  ///< VkDescriptorSet
    std::vector<uint64_t> m_views; ///< VkBufferView each
};

enum class MemoryKind {
    DeviceLocal, ///< fastest for the GPU; filled through upload()
    HostVisible, ///< mapped, coherent; for readback and small per-frame data
};

/// @brief One Vulkan instance and device with a compute queue.
class Context {
public:
    ~Context();
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;

    /// Every device the loader reports, with what each lacks; an error when there is no loader.
    static Result<std::vector<DeviceInfo>> listDevices();
    /// Opens the preferred (or `CSGV_VULKAN_DEVICE`-selected) device.
    static Result<std::unique_ptr<Context>> create();

    const DeviceInfo& device() const { return m_info; }

    Result<Buffer> createBuffer(uint64_t bytes, MemoryKind kind);
    /// Copies host data into a buffer at an offset (through a staging buffer when not mapped).
    Status upload(Buffer& dst, uint64_t offset, const void* data, uint64_t bytes);
    /// Fills a buffer's first `bytes` in pieces written straight into a staging buffer of at most
    /// `chunk` bytes (or the buffer's own mapping): `fill(offset, out, room)` writes the bytes
    /// from `offset` on, at most `room` of them, and returns how many (more than 0, a multiple of
    /// 4, unless it fails: 0). Host memory stays one chunk whatever the size.
    Status uploadFilled(Buffer& dst, uint64_t bytes, uint64_t chunk,
                        const std::function<uint64_t(uint64_t offset, void* out, uint64_t room)>& fill);
    /// Copies ranges of `data` into a buffer, in one submission (one staging buffer).
    struct CopyRegion {
        uint64_t srcOffset = 0, dstOffset = 0, bytes = 0;
    };
    Status uploadRegions(Buffer& dst, const void* data, const std::vector<CopyRegion>& regions);
    /// Copies a buffer range back to the host.
    Status download(const Buffer& src, uint64_t offset, void* data, uint64_t bytes);
    /// Copies a range of one buffer into another on the device.
    Status copy(const Buffer& src, uint64_t srcOffset, Buffer& dst, uint64_t dstOffset, uint64_t bytes);

    /// A compute pipeline from SPIR-V whose interface is `pushConstantBytes` of push constants and
    /// `texelBindings` uniform texel buffers (set 0, bindings 0..n-1: a TexelSet of as many).
    /// The same SPIR-V, push size and bindings give the same pipeline, made once per context (it
    /// lives as long as the context). Several threads may make pipelines at once, and submit work
    /// (one submission runs at a time).
    Result<uint64_t> createComputePipeline(const std::vector<uint32_t>& spirv, uint32_t pushConstantBytes,
                                           uint32_t texelBindings = 0);
    /// Texel buffer views over whole buffers, bound together as one set: texels of
    /// `wordsPerTexel` 32-bit unsigned words (1: R32_UINT, 2: R32G32_UINT, 4: R32G32B32A32_UINT,
    /// one fetch for an 8- or 16-byte record), each view at most maxTexelBufferElements texels.
    Result<TexelSet> createTexelSet(const std::vector<const Buffer*>& buffers, uint32_t wordsPerTexel = 1);
    /// The same with each buffer's own texel width (`wordsPerTexel[i]` for buffers[i]).
    Result<TexelSet> createTexelSet(const std::vector<const Buffer*>& buffers, const std::vector<uint32_t>& wordsPerTexel);
    /// Records dispatches of one pipeline with push constants, submits, and waits.
    /// A compute dispatch, a copy (`copyFrom`), or (with `fill` set) a fill of `fillBytes` of a buffer from byte
    /// `fillOffset` with the 32-bit word `fillValue`: a clear that costs a memset even on CPU
    /// devices, where a compute pass pays for every store.
    struct Dispatch {
        uint64_t pipeline = 0;
        const void* pushConstants = nullptr;
        uint32_t pushConstantBytes = 0;
        uint32_t groups[3] = {1, 1, 1};
        const TexelSet* texels = nullptr; ///< for a pipeline with texel bindings
        const Buffer* fill = nullptr;
        uint32_t fillValue = 0;
        uint64_t fillBytes = 0; ///< a multiple of 4
        uint64_t fillOffset = 0; ///< a multiple of 4
        /// With `copyFrom` set: a copy of its first `copyBytes` into `copyTo`, ordered after what
        /// came before and before what follows (a device buffer's host-visible mirror, filled or read).
        const Buffer* copyFrom = nullptr;
        const Buffer* copyTo = nullptr;
        uint64_t copyBytes = 0;
        /// Ranges to copy instead of the first `copyBytes` (the array outlives the run).
        const CopyRegion* copyRegions = nullptr;
        uint32_t copyRegionCount = 0;
        /// A dispatch with no barrier after it: the next dispatch may run beside it (and must read
        /// nothing it writes); the barrier after that one covers both.
        bool overlapsNext = false;
    };
    Status run(const std::vector<Dispatch>& dispatches) { return run(dispatches.data(), dispatches.size()); }
    /// The same for `count` dispatches starting at `first` (a part of a frame's list, no copy).
    Status run(const Dispatch* first, size_t count);

    /// How long a submission may take (default 120 s). Past it the context counts as lost: it
    /// refuses all further work and frees nothing the GPU might still use (a leak, not a crash).
    void setSubmitTimeout(double seconds);
    bool lost() const;
    /// Pipelines this context has made (each once: createComputePipeline).
    size_t pipelineCount() const;

    struct Impl;

private:
    Context();
    /// `import`: device memory imported from the process's own memory in 2 MiB pages (Context.cpp).
    Result<Buffer> createBuffer(uint64_t bytes, MemoryKind kind, bool import);
    friend class Buffer;
    friend class TexelSet;
    std::unique_ptr<Impl> m_impl;
    DeviceInfo m_info;
};

} // namespace csgv::gpu
