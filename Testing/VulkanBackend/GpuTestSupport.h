// SPDX-License-Identifier: MIT
#pragma once
/// @file GpuTestSupport.h
/// @brief One Vulkan context for all GPU tests of a process; tests skip when there is no device.

#include "csgv/gpu/Context.h"

#include <gtest/gtest.h>

namespace csgvtest {

/// The shared context, or nullptr with the reason in `why`.
inline csgv::gpu::Context* gpuContext(std::string* why = nullptr) {
    static std::string reason;
    static std::unique_ptr<csgv::gpu::Context> ctx = [] {
        csgv::Result<std::unique_ptr<csgv::gpu::Context>> r = csgv::gpu::Context::create();
        if (!r) {
            reason = r.message();
            return std::unique_ptr<csgv::gpu::Context>();
        }
        return std::move(*r);
    }();
    if (why) *why = reason;
    return ctx.get();
}

} // namespace csgvtest

#define CSGV_REQUIRE_GPU(ctx)                                                                                          \
    std::string gpuWhy;                                                                                                \
    csgv::gpu::Context* ctx = csgvtest::gpuContext(&gpuWhy);                                                           \
    if (!ctx) GTEST_SKIP() << "no Vulkan device: " << gpuWhy
