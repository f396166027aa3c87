// SPDX-License-Identifier: MIT
/**
 * @file CSGVGpuContext.h
 * @brief The Vulkan context shared by every Segmentation Volume of the process.
 *
 * Owned by its users: every renderer and every uploaded volume holds the shared_ptr, and the
 * context is destroyed with the last of them. No static owns it, because a static would destroy
 * it at exit after the Vulkan driver may already have been unloaded; representations that
 * ParaView never destroys keep it until the process ends, and the driver reclaims it then.
 *
 * Not a wrapped header.
 */
#ifndef CSGVGpuContext_h
#define CSGVGpuContext_h

#include <memory>
#include <string>

namespace csgv
{
namespace gpu
{
class Context;
}
}

namespace csgvrep
{

/// The process's Vulkan context, created on first use (and again after its last user went);
/// null with the reason when there is no usable device (then the reason is the same on every
/// call and creation is not tried again).
std::shared_ptr<csgv::gpu::Context> sharedContext(std::string& error);

} // namespace csgvrep

#endif
