// SPDX-License-Identifier: MIT
#include "csgv/inputs/Compress.h"
#include "csgv/attributes/AttributeDb.h"
#include "csgv/base/FileUtil.h"
#include "csgv/codec/Metadata.h"
#include "csgv/inputs/Procedural.h"

#include <chrono>
#include <cstdio>
#include <cstring>

namespace csgv {

namespace {

bool endsWith(const std::string& s, const char* suffix) {
    const size_t n = std::strlen(suffix);
    return s.size() >= n && s.compare(s.size() - n, n, suffix) == 0;
}

std::string baseName(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

double since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// `.vraw` on disk, read slab by slab with positioned reads.
class VrawSlabSource : public SlabSource {
public:
    ~VrawSlabSource() override {
        if (m_file) std::fclose(m_file);
    }
    Status open(const std::string& path) {
        m_path = path;
        Result<uint64_t> size = fileSize(path);
        if (!size) return size.status();
        m_file = std::fopen(path.c_str(), "rb");
        if (!m_file) return Status::error("cannot open '" + path + "'");
        uint8_t head[160];
        const size_t got = std::fread(head, 1, sizeof(head), m_file);
        Result<VrawHeader> h = parseVrawHeader(head, got);
        if (!h) return Status(h.status()).prefix(path);
        Status s = h->checkLabelBytes(*size - h->headerBytes);
        if (!s) return s.prefix(path);
        m_header = *h;
        return Status::ok();
    }
    std::array<uint32_t, 3> dimensions() const override { return m_header.dim; }
    Status readSlab(uint32_t z0, uint32_t depth, uint32_t* out) override {
        const uint32_t bytes = m_header.bytesPerLabel;
        const uint64_t slice = uint64_t(m_header.dim[0]) * m_header.dim[1];
        const size_t n = size_t(slice * depth);
        if (fseeko(m_file, off_t(m_header.headerBytes + slice * z0 * bytes), SEEK_SET) != 0)
            return Status::error("cannot seek in '" + m_path + "'");
        // 32-bit labels land in place; narrower ones are widened from the slab's raw bytes.
        std::vector<uint8_t> narrow(bytes == 4 ? 0 : n * bytes);
        void* dst = bytes == 4 ? static_cast<void*>(out) : narrow.data();
        if (std::fread(dst, 1, n * bytes, m_file) != n * bytes) return Status::error("cannot read '" + m_path + "'");
        if (bytes != 4) widenLabels(narrow.data(), bytes, n, out);
        return Status::ok();
    }

private:
    std::string m_path;
    std::FILE* m_file = nullptr;
    VrawHeader m_header;
};

} // namespace

Result<std::unique_ptr<SlabSource>> openVrawSlabs(const std::string& path) {
    auto src = std::make_unique<VrawSlabSource>();
    Status s = src->open(path);
    if (!s) return s;
    return std::unique_ptr<SlabSource>(std::move(src));
}

Status compressToFile(const std::string& input, const std::string& output, const CompressOptions& options,
                      CompressReport* report) {
    CompressReport local;
    CompressReport& rep = report ? *report : local;
    rep = CompressReport{};
    Status s = checkEncodeOptions(options.encode);
    if (!s) return s;
    if (!endsWith(output, ".csgv")) return Status::error("output '" + output + "' must end in .csgv");

    VolumeMetadata md;
    md.source = isSynthName(input) ? input : baseName(input);
    LabelMapping mapping;
    Result<CompressedVolume> vol = Status::error("no input");
    auto t0 = std::chrono::steady_clock::now();
    const bool plainVraw = endsWith(input, ".vraw");
    if ((isSynthName(input) || plainVraw) && !options.relabel) {
        // Streamed: memory is the output plus a few slabs.
        std::unique_ptr<SlabSource> src;
        if (isSynthName(input)) {
            Result<SynthSpec> spec = parseSynthSpec(input);
            if (!spec) return spec.status();
            src = std::make_unique<ProceduralSlabSource>(*spec);
        } else {
            Result<std::unique_ptr<SlabSource>> r = openVrawSlabs(input);
            if (!r) return r.status();
            src = std::move(*r);
        }
        rep.streamed = true;
        md.dim = src->dimensions();
        vol = encodeVolume(*src, options.encode, options.maxOutputBytes);
        if (!vol) return Status(vol.status()).prefix(input);
        rep.encodeSeconds = since(t0);
    } else {
        InputVolume in;
        if (isSynthName(input)) {
            Result<SynthSpec> spec = parseSynthSpec(input);
            if (!spec) return spec.status();
            Result<LabelVolume> v = generateVolume(*spec, options.maxInputBytes / 2);
            if (!v) return v.status();
            in.dim = v->dim;
            in.values.assign(v->labels.begin(), v->labels.end());
        } else {
            Result<InputVolume> r = readInput(input, options.maxInputBytes);
            if (!r) return r.status();
            in = std::move(*r);
            md.geometry = cellGeometryFromPointGeometry(in.geometry);
        }
        md.dim = in.dim;
        md.originalType = labelTypeName(in.type);
        rep.readSeconds = since(t0);
        t0 = std::chrono::steady_clock::now();
        Result<LabelVolume> labels = prepareLabels(in, options.encode.brickSize, options.relabel, mapping);
        if (!labels) return Status(labels.status()).prefix(input);
        in = InputVolume{};
        vol = encodeVolume(*labels, options.encode);
        if (!vol) return Status(vol.status()).prefix(input);
        rep.encodeSeconds = since(t0);
    }
    if (vol->serializedSize() > options.maxOutputBytes)
        return Status::error("the compressed volume needs " + std::to_string(vol->serializedSize()) +
                             " bytes, more than the output limit");
    t0 = std::chrono::steady_clock::now();
    md.relabelled = mapping.relabelled;
    // Sidecars first, the volume last: a reader never sees a new .csgv with an old database.
    const std::string db = attributeDbPathFor(output);
    if (mapping.relabelled) {
        s = writeAttributeDb(db, md.dim, mapping.originalBits, isSignedType(mapping.type));
        if (!s) return s;
    } else if (fileExists(db)) {
        if (std::remove(db.c_str()) != 0) return Status::error("cannot remove the stale attribute database '" + db + "'");
    }
    s = writeMetadata(metadataPathFor(output), md);
    if (!s) return s;
    Limits limits;
    limits.maxOutputBytes = options.maxOutputBytes;
    s = writeCsgv(output, *vol, limits);
    if (!s) return s;
    rep.writeSeconds = since(t0);
    rep.dim = md.dim;
    rep.outputBytes = vol->serializedSize();
    rep.relabelled = mapping.relabelled;
    rep.labelCount = mapping.originalBits.size();
    rep.originalType = md.originalType;
    return Status::ok();
}

} // namespace csgv
