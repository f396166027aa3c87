// SPDX-License-Identifier: MIT
/// @file RenderCommand.cpp
/// @brief `csgv render`: the batch front end of VulkanBackend's renderer.

#include "RenderCommand.h"
#include "CameraPath.h"
#include "CommandLine.h"
#include "FramePattern.h"
#include "Interrupt.h"
#include "Png.h"

#include "csgv/attributes/Attributes.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/TieredVolume.h"
#include "csgv/base/FileUtil.h"
#include "csgv/gpu/Renderer.h"
#include "csgv/gpu/UploadPolicy.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace csgv {

namespace {

using Vec3 = std::array<double, 3>;

struct RenderArgs {
    std::string input, output;
    uint32_t width = 640, height = 360;
    bool haveEye = false, haveCenter = false, haveUp = false;
    Vec3 eye{}, center{}, up{0, 0, 1};
    double fovY = 30;
    bool haveFovY = false;
    double parallelScale = 0; ///< > 0: parallel projection
    uint32_t frames = 1;
    std::string labelsOut, materials, video;
    FramePattern videoPattern;
    uint32_t orbit = 0;
    std::string cameraPath;       ///< --camera-path FILE: the poses to render, one after the other
    bool volcaniteCamera = false; ///< --camera volcanite: Volcanite 0.6's default orbital pose
    uint32_t framesPerView = 0;   ///< 0: until converged; N: exactly N frames a pose (previews allowed)
    bool compareConverged = false; ///< --compare-converged: each pose's last frame against its converged image
    uint64_t cacheMiB = 0; ///< 0: automatic (gpu::automaticCacheBytes)
    uint64_t deviceMemoryMiB = 0; ///< 0: automatic
    uint64_t hostMemoryMiB = 0;   ///< 0: automatic (TieredVolume::automaticBudget)
    gpu::RendererOptions::Decode decode = gpu::RendererOptions::Decode::Auto;
    uint32_t decodeSteps = gpu::RendererOptions::kDecodeStepsAuto;
    uint64_t prefetchVoxels = gpu::RendererOptions::kPrefetchAuto;
    bool cachePaletting = false;
    std::vector<std::string> attributeFiles;
    std::vector<std::pair<std::string, std::string>> derived; ///< name, SQL expression
    bool computedAttributes = false;
    Vec3 background{1, 1, 1};
    gpu::RenderSettings settings;
};

Status parseVec3(const std::string& s, Vec3& out) {
    double v[3];
    char extra = 0;
    if (std::sscanf(s.c_str(), "%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &extra) != 3 || !std::isfinite(v[0]) ||
        !std::isfinite(v[1]) || !std::isfinite(v[2]))
        return Status::error("expected three numbers x,y,z, not '" + s + "'");
    out = {v[0], v[1], v[2]};
    return Status::ok();
}

/// A bound as a person writes it: 1e-09, 0.01, 179, 1000000 (std::to_string gave 0.000000 for 1e-9).
std::string boundText(double v) {
    char text[32];
    std::snprintf(text, sizeof text, "%.10g", v);
    return text;
}

Status parseNumber(const std::string& s, double lo, double hi, double& out) {
    char* end = nullptr;
    out = std::strtod(s.c_str(), &end);
    if (s.empty() || *end != 0 || !std::isfinite(out) || out < lo || out > hi)
        return Status::error("expected a number from " + boundText(lo) + " to " + boundText(hi) + ", not '" + s + "'");
    return Status::ok();
}

Status parseRenderArgs(int argc, char** argv, RenderArgs& a) {
    CLI::App app;
    configureCommand(app);
    std::vector<std::string> positional;
    app.add_option("files", positional);
    bool noJitter = false, noDenoise = false;
    app.add_flag("--no-jitter", noJitter);
    app.add_flag("--no-denoise", noDenoise);
    app.add_flag("--tone-mapping", a.settings.toneMapping);
    app.add_flag("--finest", a.settings.finest);
    app.add_flag("--cache-paletting", a.cachePaletting);
    app.add_flag("--computed-attributes", a.computedAttributes);
    app.add_flag("--compare-converged", a.compareConverged);
    ValueOptions values(app);
    const auto number = [&values](const std::string& name, double lo, double hi, auto set) {
        values.add(name, [name, lo, hi, set](const std::string& v) {
            double n = 0;
            Status s = parseNumber(v, lo, hi, n);
            if (s) set(n);
            return s ? s : Status(s).prefix("option " + name);
        });
    };
    const auto vec = [&values](const std::string& name, Vec3& out, bool* given) {
        values.add(name, [name, &out, given](const std::string& v) {
            Status s = parseVec3(v, out);
            if (s && given) *given = true;
            return s ? s : Status(s).prefix("option " + name);
        });
    };
    values.add("--size", [&a](const std::string& v) {
        unsigned w = 0, h = 0;
        char extra = 0;
        if (std::sscanf(v.c_str(), "%ux%u%c", &w, &h, &extra) != 2 || w == 0 || h == 0 || w > 16384 || h > 16384)
            return Status::error("--size expects WxH between 1x1 and 16384x16384, not '" + v + "'");
        a.width = w;
        a.height = h;
        return Status::ok();
    });
    vec("--eye", a.eye, &a.haveEye);
    vec("--center", a.center, &a.haveCenter);
    vec("--up", a.up, &a.haveUp);
    values.add("--background", [&a](const std::string& v) {
        Status s = parseVec3(v, a.background);
        if (s && (std::min({a.background[0], a.background[1], a.background[2]}) < 0.0 ||
                  std::max({a.background[0], a.background[1], a.background[2]}) > 1.0))
            s = Status::error("expected red, green and blue from 0 to 1, not '" + v + "'");
        return s ? s : Status(s).prefix("option --background");
    });
    number("--fov-y", kMinFovY, kMaxFovY, [&a](double n) { a.fovY = n; a.haveFovY = true; });
    number("--parallel-scale", 1e-9, 1e12, [&a](double n) { a.parallelScale = n; });
    values.add("--decode", [&a](const std::string& v) {
        using D = gpu::RendererOptions::Decode;
        if (v == "auto") a.decode = D::Auto;
        else if (v == "gpu") a.decode = D::Gpu;
        else if (v == "host") a.decode = D::Host;
        else return Status::error("--decode expects auto, gpu or host, not '" + v + "'");
        return Status::ok();
    });
    values.add("--decode-steps", [&a](const std::string& v) {
        unsigned n = 0;
        char extra = 0;
        if (v == "all") a.decodeSteps = gpu::RendererOptions::kDecodeStepsAll;
        else if (v == "auto") a.decodeSteps = gpu::RendererOptions::kDecodeStepsAuto;
        else if (std::sscanf(v.c_str(), "%u%c", &n, &extra) == 1 && n >= 1 && n <= 1000000) a.decodeSteps = n;
        else return Status::error("--decode-steps expects auto, all or a number of steps from 1 to 1000000, not '" + v + "'");
        return Status::ok();
    });
    values.add("--shading", [&a](const std::string& v) {
        Result<gpu::Shading> m = gpu::parseShading(v);
        if (!m) return Status(m.status()).prefix("--shading");
        a.settings.shading = *m;
        return Status::ok();
    });
    number("--frames", 1, 1e6, [&a](double n) { a.frames = uint32_t(n); });
    number("--orbit", 1, 1e5, [&a](double n) { a.orbit = uint32_t(n); });
    number("--frames-per-view", 1, 1e6, [&a](double n) { a.framesPerView = uint32_t(n); });
    values.add("--camera", [&a](const std::string& v) {
        if (v != "volcanite") return Status::error("--camera expects volcanite (Volcanite 0.6's default orbital pose), not '" + v + "'");
        a.volcaniteCamera = true;
        return Status::ok();
    });
    values.add("--prefetch-voxels", [&a](const std::string& v) {
        double n = 0;
        if (v == "auto") a.prefetchVoxels = gpu::RendererOptions::kPrefetchAuto;
        else if (Status s = parseNumber(v, 0, 1e15, n); s) a.prefetchVoxels = uint64_t(n);
        else return Status(s).prefix("option --prefetch-voxels (a number of voxels, or auto)");
        return Status::ok();
    });
    number("--cache-mib", 0, 1 << 20, [&a](double n) { a.cacheMiB = uint64_t(n); });
    number("--device-memory-mib", 0, 1 << 24, [&a](double n) { a.deviceMemoryMiB = uint64_t(n); });
    number("--host-memory-mib", 0, 1 << 24, [&a](double n) { a.hostMemoryMiB = uint64_t(n); });
    number("--subsampling", 1, 8, [&a](double n) { a.settings.subsampling = uint32_t(n); });
    number("--lod-bias", -16, 16, [&a](double n) { a.settings.lodBias = float(n); });
    number("--blend", 0, 1, [&a](double n) { a.settings.shadingBlend = float(n); });
    values.add("--attributes", [&a](const std::string& v) {
        if (v.empty()) return Status::error("--attributes expects a file name, not ''");
        a.attributeFiles.push_back(v);
        return Status::ok();
    });
    values.add("--derive", [&a](const std::string& v) {
        const size_t eq = v.find('=');
        if (eq == std::string::npos || eq == 0 || eq + 1 == v.size())
            return Status::error("--derive expects NAME=SQL-EXPRESSION, not '" + v + "'");
        a.derived.emplace_back(v.substr(0, eq), v.substr(eq + 1));
        return Status::ok();
    });
    for (auto [name, target] : {std::pair<const char*, std::string*>{"--labels-out", &a.labelsOut},
                                {"--materials", &a.materials},
                                {"--camera-path", &a.cameraPath},
                                {"--video", &a.video}})
        values.add(name, [name, target](const std::string& v) {
            if (v.empty()) return Status::error(std::string(name) + " expects a file name, not ''");
            *target = v;
            return Status::ok();
        });
    if (Status s = parseCommand(app, argc, argv, " for render"); !s) return s;
    if (Status s = values.convert(); !s) return s;
    if (noJitter) a.settings.jitter = false;
    if (noDenoise) a.settings.denoise = false;
    if (positional.size() != 2) return Status::error("render needs IN.csgv and OUT.png");
    a.input = positional[0];
    a.output = positional[1];
    if (!a.video.empty() && a.orbit == 0 && a.cameraPath.empty())
        return Status::error("--video needs --orbit N or --camera-path FILE");
    if (a.compareConverged && a.framesPerView == 0)
        return Status::error("--compare-converged needs --frames-per-view N (without it every view converges)");
    if (!a.cameraPath.empty() && (a.orbit || a.haveEye || a.haveCenter || a.volcaniteCamera || a.haveUp || a.haveFovY))
        return Status::error("--camera-path gives every pose, its up vector and its field of view: it takes no --orbit, "
                             "--eye, --center, --camera, --up or --fov-y");
    if (a.haveFovY && a.parallelScale > 0)
        return Status::error("--fov-y is a perspective view's angle and --parallel-scale a parallel view's height: give one");
    if (a.volcaniteCamera && (a.haveEye || a.haveCenter || a.haveUp || a.haveFovY))
        return Status::error("--camera volcanite gives the eye, the centre, the up vector and the field of view: it takes "
                             "no --eye, --center, --up or --fov-y");
    if (!a.video.empty()) {
        Result<FramePattern> p = FramePattern::parse(a.video);
        if (!p) return p.status();
        a.videoPattern = *p;
    }
    // An output that could never replace what its name holds is refused before any work.
    for (const std::string* out : {&a.output, &a.labelsOut})
        if (!out->empty())
            if (Status s = replaceableOutput(*out); !s) return s;
    return Status::ok();
}

/// The outputs of one render (image, labels, video frames), written under temporary names and
/// published together at the end (publishTogether): an interrupt or an error leaves the old set
/// as it was. What is not published is removed when this goes.
struct PendingOutputs {
    std::vector<std::pair<std::string, std::string>> written; // temporary, target
    ~PendingOutputs() {
        for (const auto& w : written) std::remove(w.first.c_str()); // gone once published
    }
    /// Writes `target` under a temporary name with `write(temporary)`; errors name the target.
    template <class Write>
    Status add(const std::string& target, Write write) {
        if (Status s = replaceableOutput(target); !s) return s;
        const std::string tmp = temporaryNameFor(target);
        written.emplace_back(tmp, target);
        Status s = write(tmp);
        return s ? s : Status::error(renamedInMessage(s.message(), tmp, target));
    }
};

/// How much of a moving camera's frame shows what the converged image of its pose shows: of the
/// pixels where either shows something, those within 2/255 in every channel; the same of the
/// frame's previews (pixels without samples that show something).
struct Agreement {
    uint64_t shown = 0, same = 0, previews = 0, previewsSame = 0;
};
Agreement compareToConverged(const gpu::FrameOutput& moving, const gpu::FrameOutput& converged) {
    Agreement g;
    const auto near = [](uint32_t a, uint32_t b) {
        for (int k = 0; k < 32; k += 8)
            if (std::abs(int((a >> k) & 0xFFu) - int((b >> k) & 0xFFu)) > 2) return false;
        return true;
    };
    for (size_t i = 0; i < moving.rgba8.size() && i < converged.rgba8.size(); ++i) {
        const bool any = (moving.rgba8[i] >> 24) != 0 || (converged.rgba8[i] >> 24) != 0;
        if (!any) continue;
        const bool same = near(moving.rgba8[i], converged.rgba8[i]);
        ++g.shown;
        g.same += same;
        if (i < moving.samples.size() && moving.samples[i] == 0 && (moving.rgba8[i] >> 24) != 0) {
            ++g.previews;
            g.previewsSame += same;
        }
    }
    return g;
}

double percent(uint64_t part, uint64_t whole) { return whole ? 100.0 * double(part) / double(whole) : 100.0; }

double length3(const Vec3& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

/// The world box of the volume (corner geometry) as centre and radius.
void worldBounds(const CsgvFile& file, Vec3& centre, double& radius) {
    const Geometry& g = file.metadata.geometry;
    Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (int c = 0; c < 8; ++c) {
        const double idx[3] = {double((c & 1) ? file.volume.dim[0] : 0), double((c & 2) ? file.volume.dim[1] : 0),
                               double((c & 4) ? file.volume.dim[2] : 0)};
        for (int r = 0; r < 3; ++r) {
            double w = g.origin[r];
            for (int k = 0; k < 3; ++k) w += g.direction[3 * r + k] * idx[k] * g.spacing[k];
            lo[r] = std::min(lo[r], w);
            hi[r] = std::max(hi[r], w);
        }
    }
    for (int r = 0; r < 3; ++r) centre[r] = 0.5 * (lo[r] + hi[r]);
    radius = 0.5 * length3({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
}

std::array<double, 16> cameraMatrix(const RenderArgs& a, const CameraPose& pose, double radius, const Vec3& boxCentre) {
    const Vec3& eye = pose.eye;
    const double dist = length3({eye[0] - boxCentre[0], eye[1] - boxCentre[1], eye[2] - boxCentre[2]});
    const double zNear = std::max(dist - radius, std::max(radius, 1e-6) * 1e-3);
    const double zFar = dist + radius + 1e-6;
    const double aspect = double(a.width) / a.height;
    const std::array<double, 16> view = lookAtMatrix(eye, pose.center, pose.up);
    const std::array<double, 16> proj =
        a.parallelScale > 0 ? orthographicMatrix(-a.parallelScale * aspect, a.parallelScale * aspect, -a.parallelScale,
                                                 a.parallelScale, zNear, zFar)
                            : perspectiveMatrix(pose.fovY, aspect, zNear, zFar);
    return multiply(proj, view);
}

uint8_t toByte(float v) { return uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); }

Status writeImage(const std::string& path, const gpu::FrameOutput& out, const Vec3& bg) {
    std::vector<uint8_t> px(size_t(out.width) * out.height * 3);
    for (uint32_t y = 0; y < out.height; ++y)
        for (uint32_t x = 0; x < out.width; ++x) {
            const size_t src = size_t(out.height - 1 - y) * out.width + x, dst = (size_t(y) * out.width + x) * 3;
            const float* c = &out.rgba[4 * src];
            for (int k = 0; k < 3; ++k) px[dst + k] = toByte(c[k] + (1.0f - c[3]) * float(bg[k]));
        }
    return writePng(path, out.width, out.height, 3, px);
}

Status writeLabels(const std::string& path, const gpu::FrameOutput& out) {
    std::vector<uint8_t> bytes(size_t(out.width) * out.height * 4);
    for (uint32_t y = 0; y < out.height; ++y)
        for (uint32_t x = 0; x < out.width; ++x) {
            const uint32_t l = out.label[size_t(out.height - 1 - y) * out.width + x];
            uint8_t* p = &bytes[(size_t(y) * out.width + x) * 4];
            p[0] = uint8_t(l);
            p[1] = uint8_t(l >> 8);
            p[2] = uint8_t(l >> 16);
            p[3] = uint8_t(l >> 24);
        }
    AtomicFile f;
    Status s = f.open(path);
    if (s) s = f.write(bytes.data(), bytes.size());
    if (s) s = f.commit();
    return s;
}

/// A batch render draws the whole document or refuses it: an error naming every material that
/// cannot be drawn as it stands (Core's drawableMaterials, which the GUI uses to leave them out).
Status drawable(const MaterialDocument& doc, const std::vector<std::string>& attributes) {
    std::vector<std::string> skipped;
    (void)drawableMaterials(doc, &attributes, &skipped);
    std::string message;
    for (const std::string& reason : skipped) message += (message.empty() ? "" : "; ") + reason;
    return message.empty() ? Status::ok() : Status::error(message);
}

/// The per-label attributes the materials use, as floats indexed by the stored label: from the
/// file's database, --attributes tables (CSV/text or SQLite), --computed-attributes and --derive.
Status gatherAttributes(const RenderArgs& a, const CsgvFile& file, const MaterialDocument& doc,
                        std::map<std::string, std::vector<float>>& out, AttributeTable& table) {
    std::vector<std::string> used;
    for (const std::string& n : attributesUsed(doc))
        if (n != "label") used.push_back(n);
    // Tables and derived attributes given are read, and their errors said, even when no material
    // uses them yet (found by an attack pass: a missing file or bad SQL went unnoticed).
    if (used.empty() && a.attributeFiles.empty() && a.derived.empty()) return drawable(doc, {"label"});
    Status s;
    if (file.hasAttributes) {
        Result<AttributeTable> t = attributesFromDatabase(file.attributes);
        if (!t) return t.status();
        table = std::move(*t);
    }
    for (const std::string& path : a.attributeFiles) {
        Result<AttributeTable> t = readAttributeFile(path);
        if (!t) return t.status();
        if (!(s = table.merge(*t, AttributeTable::OnConflict::Replace))) return Status(s).prefix(path);
    }
    if (a.computedAttributes) {
        Result<AttributeTable> t = computeAttributes(file);
        if (!t) return Status(t.status()).prefix("computing attributes");
        if (!(s = table.merge(*t, AttributeTable::OnConflict::Replace))) return s;
    }
    for (const auto& d : a.derived)
        if (!(s = addDerivedAttribute(table, d.first, d.second, true))) return s;
    std::vector<std::string> names = table.columnNames();
    names.push_back("label");
    if (!(s = drawable(doc, names)) || used.empty()) return s;
    // Stored labels index the arrays: ids of a relabelled file, else the labels themselves.
    uint64_t labelCount = 0;
    if (!file.hasAttributes) {
        const uint32_t L = file.volume.levels();
        for (uint64_t b = 0; b < file.volume.brickCount(); ++b) {
            if (!brickSound(file.volume, b)) continue; // a bad brick: drawn empty
            const BrickWords bw = file.volume.brick(b);
            for (uint32_t k = 0; k < bw.words[L]; ++k) labelCount = std::max<uint64_t>(labelCount, uint64_t(bw.words[bw.size - 1 - k]) + 1);
        }
        if (labelCount > (uint64_t(1) << 26))
            return Status::error("labels go up to " + std::to_string(labelCount - 1) +
                                 ": too large to index attribute arrays; relabel the volume (csgv compress --relabel)");
    }
    for (const std::string& n : used) {
        Result<std::vector<float>> v = file.hasAttributes ? table.denseFloatColumnForIds(n, file.attributes.labels)
                                                          : table.denseFloatColumn(n, labelCount);
        if (!v) return Status(v.status()).prefix("attribute '" + n + "'");
        out[n] = std::move(*v);
    }
    return Status::ok();
}

double since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

} // namespace

std::string shadingChoices() {
    std::string names;
    for (const gpu::ShadingMode& m : gpu::kShadingModeTable) names += (names.empty() ? "" : "|") + std::string(m.name);
    return names;
}

int cmdRender(int argc, char** argv) {
    auto fail = [](const std::string& m) { return interrupt::failed(m); };
    RenderArgs a;
    Status s = parseRenderArgs(argc, argv, a);
    if (!s) return fail(s.message());
    const auto tStart = std::chrono::steady_clock::now();
    // A camera path is read before anything is set up: its errors come at once.
    std::vector<CameraPose> path;
    if (!a.cameraPath.empty()) {
        Result<std::vector<CameraPose>> read = readCameraPath(a.cameraPath);
        if (!read) return fail(read.message());
        path = std::move(*read);
    }
    Result<CsgvFile> file = openCsgvMapped(a.input);
    if (!file) return fail(file.message());
    const double openMs = since(tStart);
    MaterialDocument doc = defaultMaterials();
    if (!a.materials.empty()) {
        Result<std::vector<uint8_t>> text = readFile(a.materials, 64ull << 20);
        if (!text) return fail(text.message());
        Result<MaterialDocument> parsed = parseMaterials(std::string(text->begin(), text->end()));
        if (!parsed) return fail(a.materials + ": " + parsed.message());
        doc = std::move(*parsed);
        if (!(s = resolveColormapNames(doc))) return fail(a.materials + ": " + s.message());
    }
    std::map<std::string, std::vector<float>> attributes;
    AttributeTable table;
    if (!(s = gatherAttributes(a, *file, doc, attributes, table))) return fail(s.message());
    // The label overlays ("hidden", "only", "selected") drawn as ParaView draws them: the plain
    // document effectiveMaterials makes, the labels' attribute values from the same table.
    doc = effectiveMaterials(doc, table.attributeFunction());
    const auto tContext = std::chrono::steady_clock::now();
    Result<std::unique_ptr<gpu::Context>> ctx = gpu::Context::create();
    if (!ctx) return fail(ctx.message());
    const double contextMs = since(tContext);
    const auto tUpload = std::chrono::steady_clock::now();
    // The backend's upload policy, for one renderer (csgv/gpu/UploadPolicy.h).
    gpu::UploadRequest want;
    want.deviceMemoryBytes = a.deviceMemoryMiB << 20;
    want.cacheBytes = a.cacheMiB << 20;
    want.decode = a.decode;
    want.cachePaletting = a.cachePaletting ? 1 : 0;
    // An encoding larger than the host-memory budget keeps its finest level in the file.
    const uint64_t hostBudget = a.hostMemoryMiB ? a.hostMemoryMiB << 20 : TieredVolume::automaticBudget();
    if (TieredVolume::wanted(file->volume, hostBudget)) {
        TieredVolume::Options to;
        to.budgetBytes = hostBudget;
        to.progress = [](double) { return !cancelRequested(); };
        Result<std::shared_ptr<const TieredVolume>> tiers = TieredVolume::create(std::make_shared<const CompressedVolume>(file->volume), to);
        if (!tiers) return fail(cancelRequested() ? "interrupted: stopped, no image written" : a.input + ": " + tiers.message());
        want.tiers = *tiers;
    }
    const CompressedVolume& drawn = want.tiers ? want.tiers->coarse() : file->volume;
    const gpu::UploadPlan plan = gpu::planUpload((*ctx)->device(), drawn, want);
    Result<std::unique_ptr<gpu::GpuVolume>> volume = gpu::GpuVolume::create(**ctx, drawn, plan.volume);
    if (!volume) return fail(volume.message());
    std::shared_ptr<gpu::GpuVolume> shared(std::move(*volume));
    const double uploadMs = since(tUpload);
    const auto tRenderer = std::chrono::steady_clock::now();
    gpu::RendererOptions options = plan.share(shared->deviceBytes(), 1, a.decode);
    options.decodeStepsPerFrame = a.decodeSteps;
    options.prefetchVoxels = a.prefetchVoxels;
    gpu::RenderSettings settings = a.settings;
    settings.sampleTarget = a.frames;
    const auto makeRenderer = [&](const gpu::RendererOptions& o) -> Result<std::unique_ptr<gpu::Renderer>> {
        Result<std::unique_ptr<gpu::Renderer>> made = gpu::Renderer::create(**ctx, shared, o);
        if (!made) return made.status();
        (*made)->setGeometry(file->metadata.geometry);
        if (Status m = (*made)->setMaterials(doc, attributes, file->hasAttributes && !file->wideLabels ? file->idToLabel : std::vector<uint32_t>{}); !m)
            return m;
        (*made)->setSettings(settings);
        return made;
    };
    Result<std::unique_ptr<gpu::Renderer>> renderer = makeRenderer(options);
    if (!renderer) return fail(renderer.message());
    gpu::Renderer& r = **renderer;
    // --compare-converged: a second renderer whose decodes end in their frame renders each pose to
    // its converged image (not timed).
    std::unique_ptr<gpu::Renderer> reference;
    if (a.compareConverged) {
        gpu::RendererOptions every = options;
        every.decodeStepsPerFrame = gpu::RendererOptions::kDecodeStepsAll;
        Result<std::unique_ptr<gpu::Renderer>> made = makeRenderer(every);
        if (!made) return fail("--compare-converged: " + made.message());
        reference = std::move(*made);
    }
    std::printf("device: %s (%s)\n", (*ctx)->device().name.c_str(), (*ctx)->device().type.c_str());
    std::printf("cache_bits_per_voxel: %u\n", shared->cacheBits());
    std::printf("detail_separated: %s\n", shared->separated() ? "yes" : "no"); // the finest level in host memory
    std::printf("host_memory_budget_mib: %.2f\n", hostBudget / 1048576.0);
    std::printf("finest_level_on_disk: %s\n", want.tiers ? "yes" : "no");
    if (want.tiers) std::printf("host_coarse_mib: %.2f\n", want.tiers->residentBytes() / 1048576.0);
    std::printf("setup_ms: %.1f (open %.1f, device %.1f, tiers and upload %.1f, renderer %.1f)\n", since(tStart), openMs,
                contextMs, uploadMs, since(tRenderer));

    Vec3 boxCentre{};
    double radius = 1;
    worldBounds(*file, boxCentre, radius);
    // The poses: a camera path, else the given (or default, or Volcanite's) pose, orbited.
    std::vector<CameraPose> poses = path;
    if (poses.empty()) {
        CameraPose first;
        first.center = a.haveCenter ? a.center : boxCentre;
        first.up = a.up;
        first.fovY = a.fovY;
        first.eye = a.eye;
        if (a.volcaniteCamera) {
            const Geometry& g = file->metadata.geometry;
            first = volcanitePose(boxCentre, {file->volume.dim[0] * g.spacing[0], file->volume.dim[1] * g.spacing[1],
                                              file->volume.dim[2] * g.spacing[2]});
        } else if (!a.haveEye) { // a default view from the front, above and to the right
            const double dist = radius / std::sin(a.fovY * 3.14159265358979 / 360.0) * 1.05;
            const Vec3& c = first.center;
            first.eye = {c[0] + 0.55 * dist, c[1] - 0.7 * dist, c[2] + 0.45 * dist};
        }
        if (const std::string why = poseProblem(first); !why.empty()) return fail("the camera: " + why);
        poses = a.orbit ? orbitPoses(first, a.orbit) : std::vector<CameraPose>{first};
    }
    const uint32_t views = uint32_t(poses.size());
    PendingOutputs outputs; // published together after the last view
    std::vector<double> frameTimes, viewTimes, asConverged, previewsAsConverged;
    double firstFrameMs = -1;
    uint64_t cacheUsed = 0;
    uint32_t fewestSamples = ~0u; // of any view's last frame: below --frames, a view stopped short
    gpu::FrameOutput out;
    constexpr uint32_t kMeasuredViews = 16;
    gpu::Renderer::WorkingSet largest; // the largest measured view's working set
    uint32_t largestView = 0;
    for (uint32_t v = 0; v < views; ++v) {
        const uint32_t mark = r.frameMark();
        gpu::FrameInput in;
        in.width = a.width;
        in.height = a.height;
        in.worldToClip = cameraMatrix(a, poses[v], radius, boxCentre);
        double viewMs = 0;
        // Frames until every pixel holds the requested samples (bounded: FrameStats::idleLimit()
        // idle frames in a row end it), or exactly --frames-per-view of them (a moving camera:
        // one frame a pose shows what it holds, previews included, as an interactive view does).
        const uint32_t maxFrames =
            a.framesPerView ? a.framesPerView : a.frames * settings.subsampling * settings.subsampling + 256;
        uint32_t idle = 0, minSamples = 0;
        bool cacheFull = false; // in some frame of this view
        for (uint32_t f = 0; f < maxFrames; ++f) {
            if (cancelRequested()) return fail("interrupted: stopped, no image written");
            Result<gpu::FrameStats> st = r.renderFrame(in);
            if (!st) return fail(st.message());
            viewMs += st->milliseconds;
            cacheUsed = std::max(cacheUsed, st->cacheUsedBytes);
            cacheFull = cacheFull || st->cacheFull;
            frameTimes.push_back(st->milliseconds);
            std::printf("frame %u: %.1f ms, decoded %u bricks, new samples %u, missing %u, min samples %u%s%s",
                        unsigned(frameTimes.size()), st->milliseconds, st->decodedBricks, st->newSamples,
                        st->missingPixels, st->minSamples, st->cacheFull ? ", cache full" : "",
                        st->requestLimited ? ", requests limited" : "");
            if (st->detailRequests || st->detailUploads)
                std::printf(", detail asked %u uploaded %u", st->detailRequests, st->detailUploads);
            if (st->carriedDecodes) std::printf(", decodes carried %u", st->carriedDecodes);
            std::printf("\n");
            minSamples = st->minSamples;
            if (firstFrameMs < 0 && st->minSamples >= 1) firstFrameMs = since(tStart);
            if (a.framesPerView) continue;
            if (st->minSamples >= a.frames) break;
            idle = st->idle() ? idle + 1 : 0;
            if (idle >= st->idleLimit()) break;
        }
        fewestSamples = std::min(fewestSamples, minSamples);
        // The image is read back where something uses it: the last view (the output), --video's
        // images and --compare-converged (a long path read every view back: a fifth of the
        // process's time at 1280x720 on lavapipe, outside the timed frames).
        if ((v + 1 == views || reference || !a.video.empty()) && !(s = r.readOutput(out))) return fail(s.message());
        if (reference) {
            uint32_t idleRef = 0;
            for (uint32_t f = 0; f < a.frames * settings.subsampling * settings.subsampling + 256; ++f) {
                if (cancelRequested()) return fail("interrupted: stopped, no image written");
                Result<gpu::FrameStats> st = reference->renderFrame(in);
                if (!st) return fail("--compare-converged: " + st.message());
                if (st->minSamples >= a.frames) break;
                idleRef = st->idle() ? idleRef + 1 : 0;
                if (idleRef >= st->idleLimit()) break;
            }
            gpu::FrameOutput converged;
            if (!(s = reference->readOutput(converged, gpu::Renderer::Color8))) return fail(s.message());
            const Agreement g = compareToConverged(out, converged);
            asConverged.push_back(percent(g.same, g.shown));
            previewsAsConverged.push_back(percent(g.previewsSame, g.previews));
            std::printf("view %u as converged: %.1f %% of %llu pixels, previews %.1f %% of %llu\n", v, asConverged.back(),
                        static_cast<unsigned long long>(g.shown), previewsAsConverged.back(),
                        static_cast<unsigned long long>(g.previews));
        }
        // The view's working set, outside its time (the brick table read back, 16 bytes a brick):
        // for the first kMeasuredViews views and every view whose cache ran full (a long path over
        // a large volume would read the table once a pose).
        if (v < kMeasuredViews || cacheFull) {
            Result<gpu::Renderer::WorkingSet> ws = r.workingSet(mark);
            if (!ws) return fail(ws.message());
            if (ws->bytes > largest.bytes) {
                largest = *ws;
                largestView = v;
            }
        }
        viewTimes.push_back(viewMs);
        if (!a.video.empty()) {
            const std::string name = a.videoPattern.format(v);
            s = outputs.add(name, [&](const std::string& tmp) { return writeImage(tmp, out, a.background); });
            if (!s) return fail(s.message());
            std::printf("view %u: %.1f ms -> %s\n", v, viewMs, name.c_str());
        }
    }
    s = outputs.add(a.output, [&](const std::string& tmp) { return writeImage(tmp, out, a.background); });
    if (s && !a.labelsOut.empty())
        s = outputs.add(a.labelsOut, [&](const std::string& tmp) { return writeLabels(tmp, out); });
    if (s) s = publishTogether(outputs.written);
    if (!s) return fail(s.message());
    std::vector<double> sorted = frameTimes;
    std::sort(sorted.begin(), sorted.end());
    std::printf("frames: %zu\n", frameTimes.size());
    std::printf("views: %u\n", views);
    if (a.framesPerView) std::printf("frames_per_view: %u\n", a.framesPerView);
    std::vector<double> sortedViews = viewTimes;
    std::sort(sortedViews.begin(), sortedViews.end());
    std::printf("median_view_ms: %.1f\n", sortedViews.empty() ? 0.0 : sortedViews[sortedViews.size() / 2]);
    double pathMs = 0;
    for (double t : viewTimes) pathMs += t;
    std::printf("path_ms: %.1f\n", pathMs);
    // Not converged: the frame cap or idle frames ended a view first (a cache far too small for
    // the view converges, but slowly: raise the budget or lower the resolution).
    if (a.framesPerView) std::printf("converged: %s (--frames-per-view: a pixel holds %u of %u samples)\n",
                                     fewestSamples >= a.frames ? "yes" : "no", fewestSamples, a.frames);
    else if (fewestSamples >= a.frames) std::printf("converged: yes\n");
    else std::printf("converged: no (a pixel holds %u of %u samples)\n", fewestSamples, a.frames);
    std::printf("median_frame_ms: %.1f\n", sorted.empty() ? 0.0 : sorted[sorted.size() / 2]);
    if (reference) {
        for (std::vector<double>* shares : {&asConverged, &previewsAsConverged}) std::sort(shares->begin(), shares->end());
        std::printf("as_converged_pct: %.1f (median over views; previews %.1f)\n", asConverged[asConverged.size() / 2],
                    previewsAsConverged[previewsAsConverged.size() / 2]);
    }
    std::printf("time_to_first_frame_ms: %.1f\n", firstFrameMs);
    for (const auto& b : r.memory().buffers) std::printf("device_memory %s: %.2f MiB\n", b.first.c_str(), b.second / 1048576.0);
    std::printf("device_memory_total_mib: %.2f\n", r.memory().total() / 1048576.0);
    std::printf("device_memory_budget_mib: %.2f\n", r.deviceMemoryBudget() / 1048576.0);
    std::printf("cache_used_mib: %.2f\n", cacheUsed / 1048576.0);
    // A view whose bricks the cache cannot hold decodes some of them again and again before it
    // converges (many more frames than an unconstrained cache needs): say so, and what would hold it.
    const double setMiB = largest.bytes / 1048576.0, cacheMiB = largest.cacheBytes / 1048576.0;
    std::printf("view_working_set_mib: %.2f (view %u: %llu bricks; the brick cache holds %.2f MiB)\n", setMiB,
                largestView, (unsigned long long)largest.bricks, cacheMiB);
    if (largest.bytes <= largest.cacheBytes)
        std::printf("cache_holds_view: yes\n");
    else
        std::printf("cache_holds_view: no: view %u touches %llu bricks, about %.1f MiB of brick cache, and the cache has "
                    "%.1f MiB: it decodes bricks again before it converges (raise --cache-mib, or --device-memory-mib "
                    "that the cache is part of, by at least %.0f MiB, or render a smaller image)\n",
                    largestView, (unsigned long long)largest.bricks, setMiB, cacheMiB,
                    std::ceil((largest.bytes - largest.cacheBytes) / 1048576.0));
    if (want.tiers) {
        const TierCounts t = want.tiers->counts();
        std::printf("file_read_bricks: %llu\nfile_read_mib: %.2f\ndisk_read_mib: %.2f\nread_ahead_bricks: %llu\n",
                    (unsigned long long)t.fileBricks, t.fileBytes / 1048576.0, t.diskBytes / 1048576.0,
                    (unsigned long long)t.readAheadBricks);
    }
    std::printf("host_peak_rss_mib: %.1f\n", peakRssMiB());
    std::printf("bad_bricks: %llu\n", (unsigned long long)r.badBricks());
    if (r.badBricks())
        std::fprintf(stderr, "csgv: warning: %s: %llu %s to decode and %s drawn empty; the first: %s\n",
                     a.input.c_str(), (unsigned long long)r.badBricks(),
                     r.badBricks() == 1 ? "brick failed" : "bricks failed", r.badBricks() == 1 ? "is" : "are",
                     r.firstBadBrick().c_str());
    const gpu::DetailCounts detail = r.detailCounts();
    std::printf("detail_streaming: %s\n", r.streamsDetail() ? "yes" : "no");
    if (r.streamsDetail())
        std::printf("detail_uploaded_bricks: %llu\ndetail_uploaded_mib: %.2f\ndetail_evicted_bricks: %llu\n",
                    (unsigned long long)detail.uploadedBricks, detail.uploadedBytes / 1048576.0,
                    (unsigned long long)detail.evictedBricks);
    return 0;
}

} // namespace csgv
