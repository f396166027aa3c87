// SPDX-License-Identifier: MIT
#include "csgv/gpu/ShaderCompiler.h"

#include "csgv/base/FileUtil.h"
#include "csgv/base/Hash.h"

#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <glslang/SPIRV/GlslangToSpv.h>
#include <spirv-tools/libspirv.hpp>
#include <spirv-tools/optimizer.hpp>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <future>
#include <map>
#include <mutex>
#include <unordered_map>
#include <unordered_set>

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

std::mutex g_mutex; // glslang's process state and the caches
std::map<std::string, std::vector<uint32_t>> g_cache;
/// Modules glslang has made and SPIRV-Tools is inlining, outside the lock: another caller of the
/// same key (a frame asking for a pipeline the warming is making) waits for it, not compiles it again.
std::map<std::string, std::shared_future<std::vector<uint32_t>>> g_inlining;

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

/// Whether glslang's SPIR-V goes through optimised() (CSGV_SPIRV_OPT=0: not, for comparing; the
/// cache keys differ).
bool optimisesSpirv() {
    const char* env = std::getenv("CSGV_SPIRV_OPT");
    return !(env && std::string(env) == "0");
}

/// Names what optimised() does in the cache key, with SPIRV-Tools' version: a change to either is
/// a new cache entry.
std::string spirvPassesTag() {
    return std::string("\nSPIRV-Tools ") + spvSoftwareVersionString() +
           ": wrap-opkill, dead-branch-elim, merge-return, inline-exhaustive, eliminate-dead-functions; "
           "AliasedPointer on buffer-reference variables; validated";
}

/// SPIRV-Tools 2023.1's inliner keeps a function's buffer-reference result in a Function variable
/// without the AliasedPointer or RestrictPointer decoration such a variable needs (the validation
/// layers refuse the module: "expected AliasedPointer or RestrictPointer for PhysicalStorageBuffer
/// pointer"). Decorates each AliasedPointer, as glslang decorates its own; false where the module
/// is not as expected (no annotation to insert after, a malformed instruction).
bool decorateBufferReferenceVariables(std::vector<uint32_t>& m) {
    constexpr uint32_t kOpTypeForwardPointer = 39, kOpTypePointer = 32, kOpVariable = 59, kOpDecorate = 71,
                       kOpGroupMemberDecorate = 75, kOpDecorateId = 332, kOpDecorateString = 5632,
                       kOpMemberDecorateString = 5633, kFunction = 7, kPhysicalStorageBuffer = 5349,
                       kRestrictPointer = 5355, kAliasedPointer = 5356;
    std::unordered_set<uint32_t> bufferPointers, decorated;
    std::unordered_map<uint32_t, uint32_t> functionPointee; // Function pointer type -> its pointee
    std::vector<std::pair<uint32_t, uint32_t>> variables;   // Function variables: type, id
    size_t afterAnnotations = 0;
    for (size_t i = 5; i < m.size();) {
        const uint32_t count = m[i] >> 16, op = m[i] & 0xFFFFu;
        if (count == 0 || i + count > m.size()) return false;
        if ((op >= kOpDecorate && op <= kOpGroupMemberDecorate) || op == kOpDecorateId || op == kOpDecorateString ||
            op == kOpMemberDecorateString)
            afterAnnotations = i + count;
        if (op == kOpDecorate && count >= 3 && (m[i + 2] == kAliasedPointer || m[i + 2] == kRestrictPointer))
            decorated.insert(m[i + 1]);
        if ((op == kOpTypePointer || op == kOpTypeForwardPointer) && count >= 3) {
            if (m[i + 2] == kPhysicalStorageBuffer) bufferPointers.insert(m[i + 1]);
            else if (op == kOpTypePointer && m[i + 2] == kFunction && count >= 4) functionPointee[m[i + 1]] = m[i + 3];
        }
        if (op == kOpVariable && count >= 4 && m[i + 3] == kFunction) variables.emplace_back(m[i + 1], m[i + 2]);
        i += count;
    }
    std::vector<uint32_t> added;
    for (const auto& [type, id] : variables) {
        const auto pointee = functionPointee.find(type);
        if (pointee == functionPointee.end() || !bufferPointers.count(pointee->second) || decorated.count(id)) continue;
        added.insert(added.end(), {(3u << 16) | kOpDecorate, id, kAliasedPointer});
        decorated.insert(id);
    }
    if (added.empty()) return true;
    if (afterAnnotations == 0) return false;
    m.insert(m.begin() + std::ptrdiff_t(afterAnnotations), added.begin(), added.end());
    return true;
}

/// Every function inlined into the entry point by SPIRV-Tools (spirv-opt's --merge-return and
/// --inline-entry-points-exhaustive), which Debian's glslang does not do (it is built without
/// SPIRV-Tools). lavapipe turns a pipeline's SPIR-V into NIR in every process that makes it (Mesa's
/// disk cache keeps only the machine code made from that NIR), and inlining there cost most of it:
/// render.comp took 250-280 ms of a first frame, inlined here 45-55 ms (about 150 ms once, then
/// kept in the disk cache). Only inlining: spirv-opt -O, or its locals turned to SSA, cut the NIR
/// time as much but made lavapipe's code for the render pass slower (+7.5 % JIT instructions,
/// render dispatch 18.4 -> 20.4 ms on synth 512^3 at 1280x720); inlining alone costs +1.7 % JIT
/// instructions (synth 256^3, 640x360). The result is validated. Where the optimiser refuses the
/// module or its result is not valid, glslang's module is returned and `why` says what happened.
std::vector<uint32_t> optimised(const std::vector<uint32_t>& spirv, std::string& why) {
    std::string first; // the first error either tool reports
    auto consumer = [&first](spv_message_level_t level, const char*, const spv_position_t&, const char* message) {
        if (first.empty() && level <= SPV_MSG_ERROR && message) first = message;
    };
    spvtools::Optimizer optimizer(SPV_ENV_VULKAN_1_2);
    optimizer.SetMessageConsumer(consumer);
    optimizer.RegisterPass(spvtools::CreateWrapOpKillPass())
        .RegisterPass(spvtools::CreateDeadBranchElimPass())
        .RegisterPass(spvtools::CreateMergeReturnPass()) // the inliner needs one return a function
        .RegisterPass(spvtools::CreateInlineExhaustivePass())
        .RegisterPass(spvtools::CreateEliminateDeadFunctionsPass());
    std::vector<uint32_t> out;
    if (!optimizer.Run(spirv.data(), spirv.size(), &out) || out.empty()) {
        why = "SPIRV-Tools refused it: " + first;
        return spirv;
    }
    if (!decorateBufferReferenceVariables(out)) {
        why = "its buffer-reference variables could not be decorated";
        return spirv;
    }
    spvtools::SpirvTools validator(SPV_ENV_VULKAN_1_2);
    validator.SetMessageConsumer(consumer);
    if (!validator.Validate(out)) {
        why = "the inlined module is not valid: " + first;
        return spirv;
    }
    return out;
}

/// glslang's SPIR-V for a source with its defines (the caller holds g_mutex: glslang's process
/// state); every glslang object is gone when it returns.
Result<std::vector<uint32_t>> glslangSpirv(const std::string& displayName, const std::string& source,
                                           const std::string& preamble) {
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
    return spirv;
}

} // namespace

Result<std::vector<uint32_t>> compileComputeSource(const std::string& displayName, const std::string& source,
                                                   const Defines& defines) {
    std::string preamble;
    for (const auto& d : defines) preamble += "#define " + d.first + " " + d.second + "\n";
    const bool optimise = optimisesSpirv();
    const std::string key = displayName + "\n" + preamble + "\n" + source + (optimise ? spirvPassesTag() : "");
    std::unique_lock<std::mutex> lock(g_mutex);
    auto cached = g_cache.find(key);
    if (cached != g_cache.end()) return cached->second;
    auto inlining = g_inlining.find(key);
    if (inlining != g_inlining.end()) {
        const std::shared_future<std::vector<uint32_t>> made = inlining->second;
        lock.unlock();
        return made.get();
    }
    const std::string diskPath = diskCachePath(key);
    std::vector<uint32_t> fromDisk;
    if (readDiskCache(diskPath, fromDisk)) {
        g_cache[key] = fromDisk;
        return fromDisk;
    }
    Result<std::vector<uint32_t>> made = glslangSpirv(displayName, source, preamble);
    if (!made) return made;
    std::vector<uint32_t> spirv = std::move(*made);
    std::string why;
    if (optimise) {
        // SPIRV-Tools has no process state: the other pipelines' shaders compile meanwhile.
        std::promise<std::vector<uint32_t>> inlined;
        g_inlining[key] = inlined.get_future().share();
        lock.unlock();
        try {
            spirv = optimised(spirv, why);
        } catch (const std::exception& e) { // out of memory, say: glslang's module, as for a refusal
            why = e.what();
        }
        lock.lock();
        g_inlining.erase(key);
        inlined.set_value(spirv);
    }
    if (!why.empty()) // loud, and not kept on disk: the next process tries again (the gpu tests fail on this line)
        std::fprintf(stderr, "CSGV: shader %s: not inlined (%s); glslang's module is used\n", displayName.c_str(),
                     why.c_str());
    g_cache[key] = spirv;
    if (why.empty()) writeDiskCache(diskPath, spirv);
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
