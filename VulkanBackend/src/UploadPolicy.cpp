// SPDX-License-Identifier: MIT
#include "csgv/gpu/UploadPolicy.h"

#include <algorithm>

namespace csgv::gpu {

UploadPlan planUpload(const DeviceInfo& device, const CompressedVolume& volume, const UploadRequest& request) {
    UploadPlan plan;
    plan.volume.cachePaletting = GpuVolume::paletteBits(volume) < 32 &&
                                 (request.cachePaletting == 1 || (request.cachePaletting == 2 && request.cachePressure));
    plan.volume.deviceMemoryBytes = request.deviceMemoryBytes ? request.deviceMemoryBytes : automaticDeviceMemoryBudget(device);
    // Host decoding (CPU devices) uploads no encoding; with GPU decoding, a budget that wants the
    // finest level in host memory, or no more, wants another upload.
    plan.volume.hostDecoding = decodesOnHost(request.decode, device, volume, plan.volume.deviceMemoryBytes);
    plan.volume.tiers = request.tiers;
    plan.separated = !plan.volume.hostDecoding &&
                     (request.tiers || GpuVolume::separates(volume, plan.volume.deviceMemoryBytes, DetailSeparation::Auto));
    plan.kind = uint32_t(plan.volume.cachePaletting) + 2 * uint32_t(plan.volume.hostDecoding);
    plan.cacheBytes = request.cacheBytes ? request.cacheBytes : automaticCacheBytes(device, request.processes);
    return plan;
}

bool UploadPlan::serves(const GpuVolume& upload) const {
    return (upload.cacheBits() < 32) == volume.cachePaletting && upload.hostDecoding() == volume.hostDecoding &&
           upload.separated() == separated && upload.tiers() == volume.tiers.get();
}

RendererOptions UploadPlan::share(uint64_t encodingBytes, uint32_t renderers, RendererOptions::Decode decode) const {
    const uint64_t n = std::max<uint32_t>(1, renderers), budget = volume.deviceMemoryBytes;
    RendererOptions options;
    options.cacheBytes = std::max<uint64_t>(cacheBytes / n, std::min<uint64_t>(cacheBytes, 16ull << 20));
    options.deviceMemoryBytes = encodingBytes + (budget - std::min(budget, encodingBytes)) / n;
    options.decode = decode;
    return options;
}

} // namespace csgv::gpu
