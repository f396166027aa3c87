// SPDX-License-Identifier: MIT
/// @file GlslShim.h
/// @brief Macros that make one header valid C++17 and GLSL 4.60, so a fact that both the host
/// and the shaders need (a constant, a bit trick, a struct layout) is written once.
///
/// A shared header includes this one and then uses only:
/// - `CSGV_CONST(type, name, value)`: a constant (`constexpr` in C++, `const` in GLSL);
/// - `CSGV_VEC3_ARRAY(name, n) CSGV_VEC3(x, y, z), ... CSGV_ARRAY_END`: a constant array of
///   3-vectors (`float name[n][3]` in C++, `vec3 name[n]` in GLSL: one dynamic index a lookup,
///   which lavapipe compiles far better than three into a float array);
/// - `CSGV_FN`: in front of a function (`constexpr inline` in C++, nothing in GLSL); the body
///   must be the common subset of both languages (no `const` locals, no casts, unsigned literals);
/// - `uint32_t` (GLSL `uint`), `float`, `uint64_t` (GLSL with GL_EXT_shader_explicit_arithmetic_types_int64);
/// - `CSGV_VEC4(name)`, `CSGV_UVEC4(name)`, `CSGV_MAT4(name)`, `CSGV_VEC4_ARRAY(name, n)`:
///   struct members laid out as std430 vectors (`float name[4]` ... in C++);
/// - `CSGV_NAMESPACE_BEGIN(ns)` / `CSGV_NAMESPACE_END`: a C++ namespace (nothing in GLSL, so
///   names must be unique across the shaders);
/// - include guards rather than `#pragma once`; comments in multi-line macros as `/* */`.
/// The shader compiler resolves `#include "csgv/..."` against its embedded copies of these
/// headers (cmake/EmbedShaders.cmake), never against the disk.
#ifndef CSGV_BASE_GLSL_SHIM_H
#define CSGV_BASE_GLSL_SHIM_H

#ifdef __cplusplus
#include <cstddef> // offsetof, for the static_asserts on shared layouts
#include <cstdint>
#define CSGV_CONST(type, name, value) inline constexpr type name = value;
#define CSGV_ARRAY_END };
#define CSGV_VEC3_ARRAY(name, n) inline constexpr float name[n][3] = {
#define CSGV_VEC3(x, y, z) {x, y, z}
#define CSGV_FN constexpr inline
#define CSGV_VEC4(name) float name[4];
#define CSGV_UVEC4(name) uint32_t name[4];
#define CSGV_MAT4(name) float name[16];
#define CSGV_VEC4_ARRAY(name, n) float name[n][4];
#define CSGV_NAMESPACE_BEGIN(ns) namespace ns {
#define CSGV_NAMESPACE_END }
#else
#define uint32_t uint
#define CSGV_CONST(type, name, value) const type name = value;
#define CSGV_ARRAY_END );
#define CSGV_VEC3_ARRAY(name, n) const vec3 name[n] = vec3[n](
#define CSGV_VEC3(x, y, z) vec3(x, y, z)
#define CSGV_FN
#define CSGV_VEC4(name) vec4 name;
#define CSGV_UVEC4(name) uvec4 name;
#define CSGV_MAT4(name) mat4 name;
#define CSGV_VEC4_ARRAY(name, n) vec4 name[n];
#define CSGV_NAMESPACE_BEGIN(ns)
#define CSGV_NAMESPACE_END
#endif

#endif // CSGV_BASE_GLSL_SHIM_H
