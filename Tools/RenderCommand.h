// SPDX-License-Identifier: MIT
#pragma once
/// @file RenderCommand.h
/// @brief `csgv render` (built when VulkanBackend is).

namespace csgv {
/// argv[1] is "render"; returns the exit status.
int cmdRender(int argc, char** argv);
} // namespace csgv
