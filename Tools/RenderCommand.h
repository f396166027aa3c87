// SPDX-License-Identifier: MIT
#pragma once
/// @file RenderCommand.h
/// @brief `csgv render` (built when VulkanBackend is).

#include <string>

namespace csgv {
/// argv[1] is "render"; returns the exit status.
int cmdRender(int argc, char** argv);
/// The shading modes' names for the usage text ("local|shadow|ao|pt"), from the mode table.
std::string shadingChoices();
} // namespace csgv
