// SPDX-License-Identifier: MIT
/// @file UploadPolicy.h
/// @brief Which upload of a volume a renderer draws from, and its share of the budgets: the one
/// policy of `csgv render` (one renderer) and of the representation's views (several renderers of
/// one volume, each drawing from one of its uploads).
///
/// An upload is of a kind: its cache holds 32-bit labels or palette indices (cache paletting),
/// and bricks are decoded on the GPU or on the host (no encoding on the device). Views of one
/// volume share one upload per kind, one cache budget and one device-memory budget: each counts
/// the shared encoding and gets its equal part of the rest.
#ifndef CSGV_GPU_UPLOAD_POLICY_H
#define CSGV_GPU_UPLOAD_POLICY_H

#include "csgv/gpu/GpuVolume.h"
#include "csgv/gpu/Renderer.h"

#include <cstdint>

namespace csgv::gpu {

/// @brief What a renderer of a volume asks for.
struct UploadRequest {
    uint64_t deviceMemoryBytes = 0; ///< the volume's device-memory budget (0: automaticDeviceMemoryBudget)
    uint64_t cacheBytes = 0;        ///< the volume's cache budget (0: automaticCacheBytes for `processes`)
    uint32_t processes = 1;         ///< ranks of an MPI job, which may share the device
    RendererOptions::Decode decode = RendererOptions::Decode::Auto;
    /// Cache paletting: 0 off, 1 on, 2 automatic: on once a render found the cache of labels full
    /// (`cachePressure`). Never where the palettes are too large for two indices to share a word.
    int cachePaletting = 2;
    bool cachePressure = false;
    /// The volume is tiers->coarse(): its finest level stays in the file (TieredVolume.h).
    std::shared_ptr<const TieredVolume> tiers;
};

/// The kinds of upload of one volume: [paletted + 2 * hostDecoding].
constexpr uint32_t kUploadKinds = 4;

/// @brief The upload a request draws from, and how a renderer's share of the budgets is made.
struct UploadPlan {
    GpuVolumeOptions volume; ///< the upload to make (its `owned` is the caller's to set)
    bool separated = false;  ///< ... which keeps the finest level in host memory (detail separation)
    uint32_t kind = 0;       ///< its index, 0 .. kUploadKinds - 1
    uint64_t cacheBytes = 0; ///< the cache budget the volume's renderers share (resolved)

    /// Whether an upload made before (for another request) is the one this plan wants.
    bool serves(const GpuVolume& upload) const;
    /// The options of one of `renderers` renderers drawing from an upload whose encoding takes
    /// `encodingBytes` of device memory: an equal share of the cache budget (at least 16 MiB, or the whole budget when smaller), and
    /// the encoding plus an equal share of what the budget leaves beside it.
    RendererOptions share(uint64_t encodingBytes, uint32_t renderers, RendererOptions::Decode decode) const;
};

/// The plan for a request on this device.
UploadPlan planUpload(const DeviceInfo& device, const CompressedVolume& volume, const UploadRequest& request);

} // namespace csgv::gpu

#endif
