// SPDX-License-Identifier: MIT
#pragma once
/// @file ShaderCompiler.h
/// @brief GLSL to SPIR-V at run time with glslang. Sources come from `shaders/`, embedded into
/// the binary at build time; `#include "x.glsl"` resolves within that set. Each volume gets its
/// own specialisation through defines. Results are cached in memory by source name and defines,
/// and on disk (one SPIR-V file per source, defines and version of all embedded sources;
/// unreadable or foreign files are ignored) in `CSGV_SHADER_CACHE_DIR`, else
/// `$XDG_CACHE_HOME/csgv/shaders`, else `~/.cache/csgv/shaders`; `CSGV_SHADER_CACHE_DIR=` (empty)
/// turns the disk cache off. A later session's first frame then skips glslang. Every function is
/// inlined into the entry point by SPIRV-Tools before the module is kept (lavapipe's own inlining
/// cost most of a first frame's pipeline making); a module SPIRV-Tools cannot inline validly is
/// kept as glslang made it, with a line on stderr. `CSGV_SPIRV_OPT=0` keeps glslang's modules.

#include "csgv/base/Status.h"

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace csgv::gpu {

using Defines = std::vector<std::pair<std::string, std::string>>;

/// The embedded source of a shader file, or nullptr.
const char* embeddedShader(const std::string& name);
/// Names of all embedded shader files.
std::vector<std::string> embeddedShaderNames();

/// Compiles an embedded compute shader. Errors name the file and line of every problem.
Result<std::vector<uint32_t>> compileComputeShader(const std::string& name, const Defines& defines);
/// Compiles compute shader source given directly (tests), with includes from the embedded set.
Result<std::vector<uint32_t>> compileComputeSource(const std::string& displayName, const std::string& source,
                                                   const Defines& defines);

/// Forgets the in-memory cache (tests of the disk cache).
void clearShaderMemoryCache();

} // namespace csgv::gpu
