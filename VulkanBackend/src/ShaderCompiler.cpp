// SPDX-License-Identifier: MIT
#include "csgv/gpu/ShaderCompiler.h"

#include "csgv/base/FileUtil.h"
#include "csgv/base/Hash.h"

#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <glslang/SPIRV/GlslangToSpv.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>

namespace csgv::gpu {

// Generated at build time from shaders/*.glsl and *.comp (cmake/EmbedShaders.cmake).
struct EmbeddedFile {
    const char* name;
    const char* source;
};
extern const EmbeddedFile kEmbeddedShaders[];
extern const size_t kEmbeddedShaderCount;

const char* embeddedShader(const std::string& name) {
    for (size_t i = 0; i < kEmbeddedShaderCount; ++i)
        if (name == kEmbeddedShaders[i].name) return kEmbeddedShaders[i].source;
    return nullptr;
}

std::vector<std::string> embeddedShaderNames() {
    std::vector<std::string> names;
    for (size_t i = 0; i < kEmbeddedShaderCount; ++i) names.emplace_back(kEmbeddedShaders[i].name);
    return names;
}

namespace {

std::mutex g_mutex; // glslang's process state and the cache
std::map<std::string, std::vector<uint32_t>> g_cache;

/// Resolves #include against the embedded files only: nothing is searched on disk at run time.
class EmbeddedIncluder : public glslang::TShader::Includer {
public:
    IncludeResult* includeLocal(const char* header, const char*, size_t) override { return find(header); }
    IncludeResult* includeSystem(const char* header, const char*, size_t) override { return find(header); }
    void releaseInclude(IncludeResult* r) override { delete r; }

private:
    IncludeResult* find(const char* header) {
        const char* src = embeddedShader(header);
        if (!src) return nullptr;
        return new IncludeResult(header, src, std::char_traits<char>::length(src), nullptr);
    }
};

/// Every embedded source, so a cache file never outlives a change to an included file.
uint64_t embeddedFingerprint() {
    static const uint64_t value = [] {
        uint64_t h = fnv1a64("csgv shaders 1");
        for (const std::string& n : embeddedShaderNames()) h = fnv1a64(std::string(embeddedShader(n)), fnv1a64(n, h));
        return h;
    }();
    return value;
}

/// The disk cache's folder: CSGV_SHADER_CACHE_DIR (set but empty: no disk cache), else
/// $XDG_CACHE_HOME/csgv/shaders, else $HOME/.cache/csgv/shaders.
std::string diskCacheDir() {
    if (const char* dir = std::getenv("CSGV_SHADER_CACHE_DIR")) return dir;
    const char* xdg = std::getenv("XDG_CACHE_HOME");
    if (xdg && *xdg) return std::string(xdg) + "/csgv/shaders";
    const char* home = std::getenv("HOME");
    if (home && *home) return std::string(home) + "/.cache/csgv/shaders";
    return "";
}

/// The on-disk cache file for a key, or "" without a cache folder.
std::string diskCachePath(const std::string& key) {
    const std::string dir = diskCacheDir();
    if (dir.empty()) return "";
    char name[40];
    std::snprintf(name, sizeof(name), "/%016llx.spv", static_cast<unsigned long long>(fnv1a64(key, embeddedFingerprint())));
    return dir + name;
}

bool readDiskCache(const std::string& path, std::vector<uint32_t>& spirv) {
    if (path.empty()) return false;
    Result<std::vector<uint8_t>> bytes = readFile(path, 64ull << 20);
    if (!bytes || bytes->size() < 20 || bytes->size() % 4 != 0) return false;
    spirv.resize(bytes->size() / 4);
    std::memcpy(spirv.data(), bytes->data(), bytes->size());
    return spirv[0] == 0x07230203u; // SPIR-V magic
}

void writeDiskCache(const std::string& path, const std::vector<uint32_t>& spirv) {
    if (path.empty()) return;
    std::error_code ec; // a folder that cannot be made only means no cache entry, as below
    std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
    AtomicFile f; // a failure only means no cache entry
    if (f.open(path) && f.write(spirv.data(), spirv.size() * 4)) (void)f.commit();
}

} // namespace

Result<std::vector<uint32_t>> compileComputeSource(const std::string& displayName, const std::string& source,
                                                   const Defines& defines) {
    std::string preamble;
    for (const auto& d : defines) preamble += "#define " + d.first + " " + d.second + "\n";
    const std::string key = displayName + "\n" + preamble + "\n" + source;
    std::lock_guard<std::mutex> lock(g_mutex);
    auto cached = g_cache.find(key);
    if (cached != g_cache.end()) return cached->second;
    const std::string diskPath = diskCachePath(key);
    std::vector<uint32_t> fromDisk;
    if (readDiskCache(diskPath, fromDisk)) {
        g_cache[key] = fromDisk;
        return fromDisk;
    }
    static bool initialised = glslang::InitializeProcess();
    if (!initialised) return Status::error("glslang failed to initialise");

    glslang::TShader shader(EShLangCompute);
    const char* text = source.c_str();
    const char* names = displayName.c_str();
    shader.setStringsWithLengthsAndNames(&text, nullptr, &names, 1);
    shader.setPreamble(preamble.c_str());
    shader.setEnvInput(glslang::EShSourceGlsl, EShLangCompute, glslang::EShClientVulkan, 100);
    shader.setEnvClient(glslang::EShClientVulkan, glslang::EShTargetVulkan_1_2);
    shader.setEnvTarget(glslang::EShTargetSpv, glslang::EShTargetSpv_1_5);
    EmbeddedIncluder includer;
    const EShMessages messages = EShMessages(EShMsgSpvRules | EShMsgVulkanRules);
    if (!shader.parse(GetDefaultResources(), 460, false, messages, includer))
        return Status::error("shader " + displayName + " does not compile:\n" + shader.getInfoLog());
    glslang::TProgram program;
    program.addShader(&shader);
    if (!program.link(messages)) return Status::error("shader " + displayName + " does not link:\n" + program.getInfoLog());
    std::vector<uint32_t> spirv;
    spv::SpvBuildLogger logger;
    glslang::SpvOptions options;
    options.disableOptimizer = false;
    glslang::GlslangToSpv(*program.getIntermediate(EShLangCompute), spirv, &logger, &options);
    if (spirv.empty()) return Status::error("shader " + displayName + ": no SPIR-V produced: " + logger.getAllMessages());
    g_cache[key] = spirv;
    writeDiskCache(diskPath, spirv);
    return spirv;
}

void clearShaderMemoryCache() {
    std::lock_guard<std::mutex> lock(g_mutex);
    g_cache.clear();
}

Result<std::vector<uint32_t>> compileComputeShader(const std::string& name, const Defines& defines) {
    const char* src = embeddedShader(name);
    if (!src) return Status::error("no embedded shader named '" + name + "'");
    return compileComputeSource(name, src, defines);
}

} // namespace csgv::gpu
