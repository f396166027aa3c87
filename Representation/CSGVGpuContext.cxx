// SPDX-License-Identifier: MIT
#include "CSGVGpuContext.h"

#include "csgv/gpu/Context.h"

#include <mutex>

namespace csgvrep
{

std::shared_ptr<csgv::gpu::Context> sharedContext(std::string& error)
{
  // Function-local statics, never heap-leaked: the weak_ptr only observes the context.
  static std::mutex m;
  static std::weak_ptr<csgv::gpu::Context> current;
  static std::string failure;
  std::lock_guard<std::mutex> lock(m);
  error = failure;
  if (!failure.empty())
  {
    return nullptr;
  }
  std::shared_ptr<csgv::gpu::Context> context = current.lock();
  if (!context)
  {
    csgv::Result<std::unique_ptr<csgv::gpu::Context>> c = csgv::gpu::Context::create();
    if (!c)
    {
      failure = c.message();
      error = failure;
      return nullptr;
    }
    context = std::shared_ptr<csgv::gpu::Context>(std::move(*c));
    current = context;
  }
  return context;
}

} // namespace csgvrep
