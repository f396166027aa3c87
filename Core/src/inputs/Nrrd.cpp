// SPDX-License-Identifier: MIT
/// @file Nrrd.cpp
/// @brief NRRD (`.nrrd` attached, `.nhdr` detached) as a streaming source: the header is read up
/// to its blank line and checked whole (parseNrrdHeader, also the fuzz target's entry), the data
/// located (line and byte skips; a raw file too short for the sizes is refused then), and the
/// voxels read slab by slab by VoxelFileSource: raw data by positioned reads of each slab's
/// bytes, gzip data through one stream kept open between slabs (an earlier slab restarts it),
/// and after the last voxel at most 64 KiB more (NrrdSource::atDataEnd). A detached `data file`
/// must lie inside the header's folder unless InputOptions::allowOutsidePaths (PathGuard.h).
/// Working memory: a 128 KiB decode buffer, plus 304 KiB for a gzip stream (its input buffer,
/// zlib's state and 32 KiB window), whatever the volume's size.
#include "InputCommon.h"

#include "csgv/inputs/HeaderFormats.h"
#include "csgv/inputs/PathGuard.h"

#include "csgv/base/Checked.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>

namespace csgv {

using namespace inputs;

namespace {

/// "not a NRRD file" when the first bytes cannot start a NRRD magic (checked as soon as four
/// bytes are there, so that a binary file is not searched for a blank line).
Status checkNrrdStart(const std::string& buf, const std::string& name) {
    if (buf.size() >= 4 && buf.compare(0, 4, "NRRD") != 0)
        return fail(name, "not a NRRD file: it starts with " + quotedText(buf.substr(0, 8)) +
                              ", not the magic NRRD0001 to NRRD0005");
    return Status::ok();
}

/// Finds the blank line that ends an attached header: `end` is where the header text ends (after
/// the last field's newline), `dataStart` where the data begin. False when there is none.
bool findBlankLine(const std::string& buf, size_t from, size_t& end, size_t& dataStart) {
    for (size_t i = buf.find('\n', from); i != std::string::npos; i = buf.find('\n', i + 1)) {
        if (i + 1 < buf.size() && buf[i + 1] == '\n') {
            end = i + 1;
            dataStart = i + 2;
            return true;
        }
        if (i + 2 < buf.size() && buf[i + 1] == '\r' && buf[i + 2] == '\n') {
            end = i + 1;
            dataStart = i + 3;
            return true;
        }
    }
    return false;
}

/// Reads a NRRD file's first bytes up to the blank line that ends its header (the data may be
/// gigabytes), or all of a detached header without one; at most kMaxNrrdHeaderBytes.
Result<std::string> readNrrdHeaderText(const std::string& path) {
    Result<uint64_t> size = fileSize(path);
    if (!size) return size.status();
    CFile file(std::fopen(path.c_str(), "rb"));
    if (!file.get()) return Status::error("cannot open '" + path + "': " + errnoText());
    std::string buf;
    std::vector<char> chunk(1 << 16);
    for (;;) {
        const size_t scanFrom = buf.size() > 2 ? buf.size() - 2 : 0;
        const size_t got = std::fread(chunk.data(), 1, chunk.size(), file.get());
        buf.append(chunk.data(), got);
        if (Status s = checkNrrdStart(buf, path); !s) return s;
        size_t end = 0, dataStart = 0;
        if (findBlankLine(buf, scanFrom, end, dataStart) || got == 0) break;
        if (buf.size() > kMaxNrrdHeaderBytes)
            return fail(path, "no blank line ends the NRRD header within its first " +
                                  std::to_string(kMaxNrrdHeaderBytes) + " bytes");
    }
    if (std::ferror(file.get())) return Status::error("cannot read '" + path + "': " + errnoText());
    return buf;
}

/// The header's lines split into lower-case field names and trimmed values.
Status splitNrrdFields(const std::string& text, const std::string& name, NrrdHeader& h) {
    std::vector<std::string> lines;
    for (size_t pos = 0; pos < text.size();) {
        size_t nl = text.find('\n', pos);
        if (nl == std::string::npos) nl = text.size();
        std::string line = text.substr(pos, nl - pos);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        lines.push_back(line);
        pos = nl + 1;
    }
    if (lines.empty()) return fail(name, "empty file, not a NRRD file");
    const std::string& magic = lines[0];
    if (magic.size() != 8 || magic.compare(0, 7, "NRRD000") != 0 || magic[7] < '1' || magic[7] > '5')
        return fail(name, "NRRD magic " + quotedText(magic) + " is not NRRD0001 to NRRD0005");

    for (size_t n = 1; n < lines.size(); ++n) {
        const std::string& line = lines[n];
        if (line.empty() || line[0] == '#') continue;
        const size_t colon = line.find(':');
        if (colon == std::string::npos)
            return fail(name, "header line " + std::to_string(n + 1) + " " + quotedText(line) +
                                  " is neither 'field: value' nor a '#' comment");
        if (colon + 1 < line.size() && line[colon + 1] == '=') continue; // key:=value pairs carry no geometry
        std::string field = lower(trim(line.substr(0, colon)));
        // Older NRRD versions spell some fields without the space.
        if (field == "datafile") field = "data file";
        else if (field == "byteskip") field = "byte skip";
        else if (field == "lineskip") field = "line skip";
        h.fields[field] = trim(line.substr(colon + 1));
        // "data file: LIST" is the last field: the lines after it name data files.
        if (field == "data file" && h.fields[field].compare(0, 4, "LIST") == 0) break;
    }
    return Status::ok();
}

bool nrrdType(const std::string& value, LabelType& type) {
    static const std::map<std::string, LabelType> kTypes = {
        {"signed char", LabelType::I8},
        {"int8", LabelType::I8},
        {"int8_t", LabelType::I8},
        {"uchar", LabelType::U8},
        {"unsigned char", LabelType::U8},
        {"uint8", LabelType::U8},
        {"uint8_t", LabelType::U8},
        {"short", LabelType::I16},
        {"short int", LabelType::I16},
        {"signed short", LabelType::I16},
        {"signed short int", LabelType::I16},
        {"int16", LabelType::I16},
        {"int16_t", LabelType::I16},
        {"ushort", LabelType::U16},
        {"unsigned short", LabelType::U16},
        {"unsigned short int", LabelType::U16},
        {"uint16", LabelType::U16},
        {"uint16_t", LabelType::U16},
        {"int", LabelType::I32},
        {"signed int", LabelType::I32},
        {"int32", LabelType::I32},
        {"int32_t", LabelType::I32},
        {"uint", LabelType::U32},
        {"unsigned int", LabelType::U32},
        {"uint32", LabelType::U32},
        {"uint32_t", LabelType::U32},
        {"longlong", LabelType::I64},
        {"long long", LabelType::I64},
        {"long long int", LabelType::I64},
        {"signed long long", LabelType::I64},
        {"signed long long int", LabelType::I64},
        {"int64", LabelType::I64},
        {"int64_t", LabelType::I64},
        {"ulonglong", LabelType::U64},
        {"unsigned long long", LabelType::U64},
        {"unsigned long long int", LabelType::U64},
        {"uint64", LabelType::U64},
        {"uint64_t", LabelType::U64},
        {"float", LabelType::F32},
        {"double", LabelType::F64},
    };
    std::string key;
    for (const std::string& w : splitWords(lower(value))) key += (key.empty() ? "" : " ") + w;
    const auto it = kTypes.find(key);
    if (it == kTypes.end()) return false;
    type = it->second;
    return true;
}

/// Space dimension of a NRRD `space` name, 0 when unknown.
int nrrdSpaceDimension(const std::string& value) {
    static const std::map<std::string, int> kSpaces = {
        {"right-anterior-superior", 3},     {"ras", 3},
        {"left-anterior-superior", 3},      {"las", 3},
        {"left-posterior-superior", 3},     {"lps", 3},
        {"right-anterior-superior-time", 4}, {"rast", 4},
        {"left-anterior-superior-time", 4}, {"last", 4},
        {"left-posterior-superior-time", 4}, {"lpst", 4},
        {"scanner-xyz", 3},                 {"scanner-xyz-time", 4},
        {"3d-right-handed", 3},             {"3d-left-handed", 3},
        {"3d-right-handed-time", 4},        {"3d-left-handed-time", 4},
    };
    const auto it = kSpaces.find(lower(trim(value)));
    return it == kSpaces.end() ? 0 : it->second;
}

/// One entry of `space directions` / `space origin`: a vector, or `none` (empty vector, isNone).
struct NrrdVector {
    bool isNone = false;
    std::vector<double> v;
};

/// Parses "(1,0,0) none (0,0.5,0)" into vectors; false with a reason on malformed text.
bool parseNrrdVectors(const std::string& text, std::vector<NrrdVector>& out, std::string& why) {
    size_t i = 0;
    while (i < text.size()) {
        if (std::isspace(static_cast<unsigned char>(text[i]))) {
            ++i;
            continue;
        }
        NrrdVector item;
        if (text[i] == '(') {
            const size_t close = text.find(')', i);
            if (close == std::string::npos) {
                why = "'(' without ')'";
                return false;
            }
            const std::string inner = text.substr(i + 1, close - i - 1);
            size_t start = 0;
            for (;;) {
                const size_t comma = inner.find(',', start);
                const std::string part =
                    inner.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
                double d;
                if (!parseDouble(part, d)) {
                    why = "component " + quotedText(trim(part)) + " is not a number";
                    return false;
                }
                item.v.push_back(d);
                if (comma == std::string::npos) break;
                start = comma + 1;
            }
            i = close + 1;
        } else {
            size_t e = i;
            while (e < text.size() && !std::isspace(static_cast<unsigned char>(text[e]))) ++e;
            const std::string word = text.substr(i, e - i);
            if (lower(word) != "none") {
                why = quotedText(word) + " is neither a vector '(x,y,z)' nor 'none'";
                return false;
            }
            item.isNone = true;
            i = e;
        }
        out.push_back(item);
    }
    return true;
}

std::string parentFolder(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    if (slash == std::string::npos) return "";
    return path.substr(0, slash + 1);
}

/// @brief The header checks, in order (parseNrrdHeader); each checks one group of fields and
/// records in the header, or in these plain fields, what later steps need.
struct NrrdFieldReader {
    const std::string& name;
    NrrdHeader& h;
    int64_t dimension = 0;
    size_t axes = 0;
    std::vector<NrrdVector> directions;
    std::vector<size_t> kept;

    NrrdFieldReader(const std::string& file, NrrdHeader& header) : name(file), h(header) {}

    const std::string* field(const char* key) const {
        const auto it = h.fields.find(key);
        return it == h.fields.end() ? nullptr : &it->second;
    }

    Status requiredFields() const {
        for (const char* required : {"type", "dimension", "sizes", "encoding"})
            if (!field(required)) return fail(name, "the required NRRD field '" + std::string(required) + "' is missing");

        return Status::ok();
    }

    /// Voxel type, dimension, sizes, space directions, which axes are spatial.
    Status typeAndAxes() {
        const std::string& typeText = *field("type");
        if (!nrrdType(typeText, h.type))
            return fail(name, "type " + quotedText(typeText) +
                                  " is not supported (integer types of 8 to 64 bits, float or double)");

        if (!parseInt64(*field("dimension"), dimension) || dimension < 1)
            return fail(name, "dimension " + quotedText(*field("dimension")) + " is not a positive integer");
        if (dimension != 3 && dimension != 4)
            return fail(name, "dimension " + std::to_string(dimension) +
                                  " is not supported (3, or 4 with one axis of size 1)");
        axes = size_t(dimension);

        const std::vector<std::string> sizeWords = splitWords(*field("sizes"));
        if (sizeWords.size() != axes)
            return fail(name, "sizes " + quotedText(*field("sizes")) + " has " + std::to_string(sizeWords.size()) +
                                  " values, dimension is " + std::to_string(dimension));
        std::vector<uint64_t> sizes;
        for (const std::string& w : sizeWords) {
            int64_t v = 0;
            if (!parseInt64(w, v) || v < 1 || v > int64_t(0xFFFFFFFFu))
                return fail(name, "sizes value " + quotedText(w) + " is not an integer from 1 to 4294967295");
            sizes.push_back(uint64_t(v));
        }

        // Per-axis space directions (needed before choosing which of four axes to drop).
        if (const std::string* sd = field("space directions")) {
            std::string why;
            if (!parseNrrdVectors(*sd, directions, why)) return fail(name, "space directions: " + why);
            if (directions.size() != axes)
                return fail(name, "space directions has " + std::to_string(directions.size()) +
                                      " entries, dimension is " + std::to_string(dimension));
        }

        kept = {0, 1, 2};
        if (axes == 4) {
            // A 4D NRRD holds one 3D volume when one axis (usually a leading component axis) has size 1.
            size_t drop = 4;
            for (size_t a = 0; a < 4 && drop == 4; ++a)
                if (sizes[a] == 1 && !directions.empty() && directions[a].isNone) drop = a;
            if (drop == 4 && sizes[0] == 1) drop = 0;
            if (drop == 4 && sizes[3] == 1) drop = 3;
            if (drop == 4)
                return fail(name, "dimension 4 with sizes " + quotedText(*field("sizes")) +
                                      ": only a 4th axis of size 1 (leading or trailing) is supported");
            kept.clear();
            for (size_t a = 0; a < 4; ++a)
                if (a != drop) kept.push_back(a);
        }
        const std::array<uint64_t, 3> d3 = {{sizes[kept[0]], sizes[kept[1]], sizes[kept[2]]}};
        // Sizes whose voxels need more than 2^64 bytes (at full width) are refused here, so that
        // no later byte count overflows.
        if (Status s = checkBudget(name, d3, kSaturated - 1); !s) return s;
        h.dim = {{uint32_t(d3[0]), uint32_t(d3[1]), uint32_t(d3[2])}};

        return Status::ok();
    }

    Status encodingAndEndian() {
        const std::string encoding = lower(*field("encoding"));
        if (encoding == "gzip" || encoding == "gz") h.gzip = true;
        else if (encoding != "raw")
            return fail(name, "encoding " + quotedText(*field("encoding")) + " is not supported (raw or gzip)");

        if (const std::string* e = field("endian")) {
            const std::string v = lower(*e);
            if (v == "big") h.bigEndian = true;
            else if (v != "little") return fail(name, "endian " + quotedText(*e) + " is neither 'little' nor 'big'");
        } else if (typeBytes(h.type) > 1) {
            return fail(name, "the field 'endian' is missing; it is required for " + std::string(labelTypeName(h.type)) +
                                  " data");
        }

        return Status::ok();
    }

    /// Spacing, direction and origin.
    Status geometry() {
        int spaceDim = 0;
        if (const std::string* sp = field("space")) {
            spaceDim = nrrdSpaceDimension(*sp);
            if (spaceDim == 0) return fail(name, "space " + quotedText(*sp) + " is not a NRRD space name");
        }
        if (const std::string* sdim = field("space dimension")) {
            int64_t v = 0;
            if (!parseInt64(*sdim, v) || v < 1)
                return fail(name, "space dimension " + quotedText(*sdim) + " is not a positive integer");
            if (spaceDim != 0 && v != spaceDim)
                return fail(name, "space dimension " + std::to_string(v) + " contradicts space " + quotedText(*field("space")));
            spaceDim = int(v);
        }
        Geometry& g = h.geometry;
        if (!directions.empty()) {
            for (size_t k = 0; k < 3; ++k) {
                const size_t a = kept[k];
                const NrrdVector& dir = directions[a];
                if (dir.isNone)
                    return fail(name, "space directions: axis " + std::to_string(a) + " is 'none' but is a spatial axis");
                if (spaceDim != 0 && dir.v.size() != size_t(spaceDim))
                    return fail(name, "space directions: axis " + std::to_string(a) + " has " +
                                          std::to_string(dir.v.size()) + " components, space dimension is " +
                                          std::to_string(spaceDim));
                if (dir.v.size() != 3)
                    return fail(name, "space directions: axis " + std::to_string(a) + " has " +
                                          std::to_string(dir.v.size()) + " components; only 3D spaces are supported");
                const double norm = std::sqrt(dir.v[0] * dir.v[0] + dir.v[1] * dir.v[1] + dir.v[2] * dir.v[2]);
                if (!std::isfinite(norm) || norm == 0)
                    return fail(name, "space directions: axis " + std::to_string(a) + " vector (" + formatDouble(dir.v[0]) +
                                          "," + formatDouble(dir.v[1]) + "," + formatDouble(dir.v[2]) +
                                          ") has no usable length");
                g.spacing[k] = norm;
                for (int r = 0; r < 3; ++r) g.direction[3 * r + k] = dir.v[r] / norm;
            }
        } else if (const std::string* sp = field("spacings")) {
            const std::vector<std::string> words = splitWords(*sp);
            if (words.size() != axes)
                return fail(name, "spacings has " + std::to_string(words.size()) + " values, dimension is " +
                                      std::to_string(dimension));
            for (size_t k = 0; k < 3; ++k) {
                double v = 0;
                if (!parseDouble(words[kept[k]], v))
                    return fail(name, "spacings value " + quotedText(words[kept[k]]) + " is not a number");
                if (std::isnan(v)) continue; // "nan": no spacing known along this axis
                if (!std::isfinite(v) || v == 0)
                    return fail(name, "spacings value " + quotedText(words[kept[k]]) + " is not a usable spacing");
                // A negative spacing means the axis runs backwards; keep spacing positive.
                g.spacing[k] = std::fabs(v);
                if (v < 0) g.direction[4 * k] = -1;
            }
        }
        if (const std::string* so = field("space origin")) {
            std::vector<NrrdVector> origin;
            std::string why;
            if (!parseNrrdVectors(*so, origin, why)) return fail(name, "space origin: " + why);
            if (origin.size() != 1 || origin[0].isNone || origin[0].v.size() != 3)
                return fail(name, "space origin " + quotedText(*so) + " is not one 3D vector '(x,y,z)'");
            for (int r = 0; r < 3; ++r) {
                if (!std::isfinite(origin[0].v[size_t(r)]))
                    return fail(name, "space origin " + quotedText(*so) + " has a component that is not finite");
                g.origin[size_t(r)] = origin[0].v[size_t(r)];
            }
        }

        return Status::ok();
    }

    /// Which file holds the data, and its line and byte skips.
    Status dataLocation() {
        if (const std::string* df = field("data file")) {
            const std::vector<std::string> words = splitWords(*df);
            if (!words.empty() && words[0] == "LIST")
                return fail(name, "data file LIST (one data file per slice) is not supported; use a single data file");
            if (words.size() >= 4 && words[0].find('%') != std::string::npos)
                return fail(name, "data file format " + quotedText(*df) +
                                      " (one data file per slice) is not supported; use a single data file");
            if (df->empty()) return fail(name, "the field 'data file' is empty");
            h.dataFile = *df;
        } else if (!h.attached) {
            return fail(name, "no data: the header has no 'data file' field and no blank line before attached data");
        }

        if (const std::string* ls = field("line skip"))
            if (!parseInt64(*ls, h.lineSkip) || h.lineSkip < 0)
                return fail(name, "line skip " + quotedText(*ls) + " is not a non-negative integer");
        if (const std::string* bs = field("byte skip")) {
            if (!parseInt64(*bs, h.byteSkip) || h.byteSkip < -1)
                return fail(name, "byte skip " + quotedText(*bs) + " is not -1 or a non-negative integer");
            if (h.byteSkip == -1 && h.gzip)
                return fail(name, "byte skip -1 is only allowed with raw encoding, not gzip");
        }

        return Status::ok();
    }
};

/// @brief A NRRD volume's data (raw or gzip, attached or in a data file), read slab by slab
/// (VoxelFileSource: positioned reads, or one gzip stream kept open; at most 128 KiB + 304 KiB
/// of working memory).
class NrrdSource : public VoxelFileSource {
public:
    NrrdSource(const std::string& dataName, int64_t byteSkip) : m_dataName(dataName), m_byteSkip(byteSkip) {}

protected:
    Status truncated(uint64_t available) const override {
        if (!data().compressed)
            return fail(m_dataName, "truncated: " + std::to_string(available) + " bytes of data from offset " +
                                        std::to_string(data().fileOffset) + ", the header's sizes and type need " +
                                        std::to_string(dataBytes()));
        const uint64_t skip = uint64_t(m_byteSkip);
        return fail(path(), "truncated gzip data in '" + data().file + "': it inflates to " +
                                std::to_string(available + skip) + " bytes, the header's sizes and type need " +
                                std::to_string(dataBytes() + skip) + (skip ? " (with byte skip)" : ""));
    }

    Status streamFailure(const InputStream& in, const Status& s) const override {
        switch (in.failure()) {
        case InputStream::Failure::Open:
            return fail(path(), "cannot open data file '" + data().file + "': " + s.message());
        case InputStream::Failure::Read: return fail(path(), "cannot read '" + data().file + "': " + s.message());
        case InputStream::Failure::Corrupt:
            return fail(path(), "corrupt gzip data in '" + data().file + "': " + s.message());
        default: return Status(s).prefix(path());
        }
    }

    /// Reads on a little past the last voxel: a stream that ends there has its checksums verified
    /// (and a small surplus, such as padding, is allowed, as teem reads only what it needs); one
    /// that goes on is refused without inflating the rest, which may be gigabytes (a header whose
    /// sizes are too small, or a decompression bomb behind a small volume). Bytes after the last
    /// gzip member that are no gzip member are corrupt data here, as everywhere in the stream.
    Status atDataEnd(InputStream& in) override {
        const uint64_t skip = uint64_t(m_byteSkip);
        const std::string needed = std::to_string(dataBytes() + skip) + " bytes the header's sizes and type need" +
                                   (skip ? " (with byte skip)" : "");
        std::vector<uint8_t> probe(kSurplusProbeBytes + 1);
        Result<size_t> got = in.read(probe.data(), probe.size());
        if (!got && in.failure() == InputStream::Failure::Corrupt)
            return fail(path(), "corrupt gzip data in '" + data().file + "' after the " + needed + ": " + got.message());
        if (!got) return streamFailure(in, got.status());
        if (*got <= kSurplusProbeBytes) return Status::ok();
        return fail(path(), "gzip data in '" + data().file + "' inflate to more than the " + needed + ": over " +
                                std::to_string(kSurplusProbeBytes) + " bytes more follow (refused without inflating the rest)");
    }

private:
    static constexpr size_t kSurplusProbeBytes = size_t(64) << 10;

    std::string m_dataName;
    int64_t m_byteSkip;
};

/// Where the voxels are: the data file (or the header's own file), positioned after the line
/// skip and, for raw data, the byte skip; raw data must fit in the file (a truncated file is
/// refused here, before any voxel is read), gzip data must be able to inflate to them.
Result<VoxelData> locateNrrdData(const std::string& path, const NrrdHeader& h, const std::string& dataPath,
                                 const std::string& dataName) {
    VoxelData d;
    d.file = dataPath;
    d.compressed = h.gzip;
    d.mode = InputStream::Mode::Inflate;
    d.stored = h.type;
    d.bigEndian = h.bigEndian;
    uint64_t start = h.dataFile.empty() ? h.dataOffset : 0;

    Result<uint64_t> fileBytes = fileSize(dataPath);
    if (!fileBytes) return Status(fileBytes.status()).prefix(path);
    CFile file(std::fopen(dataPath.c_str(), "rb"));
    if (!file.get()) return fail(path, "cannot open data file '" + dataPath + "': " + errnoText());
    if (start > *fileBytes || !seekTo(file.get(), start)) return fail(dataName, "no data after the header");
    for (int64_t line = 0; line < h.lineSkip; ++line) {
        int c;
        while ((c = std::getc(file.get())) != EOF && c != '\n') {
        }
        if (c == EOF) return fail(dataName, "line skip " + std::to_string(h.lineSkip) + " passes the end of the file");
    }
    if (h.lineSkip > 0) start = uint64_t(ftello(file.get()));

    const uint64_t dataBytes = h.voxelCount() * typeBytes(h.type); // below 2^64: parseNrrdHeader
    if (h.gzip) {
        // Deflate cannot expand more than 1032:1, so a small file claiming a large volume is refused
        // before anything is read.
        const uint64_t compressed = *fileBytes - std::min(start, *fileBytes);
        if (mulSaturate(compressed, 1032) + 1024 < dataBytes + uint64_t(h.byteSkip))
            return fail(dataName, "truncated: " + std::to_string(compressed) + " bytes of gzip data cannot hold the " +
                                      std::to_string(dataBytes) + " bytes the header's sizes and type need");
        // With gzip, byte skip counts inflated bytes (as teem does).
        d.fileOffset = start;
        d.skip = uint64_t(h.byteSkip);
        return d;
    }

    uint64_t offset = start + uint64_t(std::max<int64_t>(h.byteSkip, 0));
    if (h.byteSkip == -1) {
        // The data are the last bytes of the file.
        if (*fileBytes < start + dataBytes)
            return fail(dataName, "truncated: " + std::to_string(*fileBytes - start) +
                                      " bytes after the header, the header's sizes and type need " +
                                      std::to_string(dataBytes));
        offset = *fileBytes - dataBytes;
    }
    if (offset > *fileBytes || *fileBytes - offset < dataBytes)
        return fail(dataName, "truncated: " + std::to_string(offset > *fileBytes ? 0 : *fileBytes - offset) +
                                  " bytes of data from offset " + std::to_string(offset) +
                                  ", the header's sizes and type need " + std::to_string(dataBytes));
    d.fileOffset = offset;
    return d;
}

} // namespace

namespace inputs {

Result<NrrdHeader> parseNrrdHeader(const std::string& text, const std::string& name) {
    if (Status s = checkNrrdStart(text, name); !s) return s;
    NrrdHeader h;
    size_t end = 0, dataStart = 0;
    h.attached = findBlankLine(text, 0, end, dataStart);
    h.dataOffset = h.attached ? dataStart : 0;
    if (Status s = splitNrrdFields(h.attached ? text.substr(0, end) : text, name, h); !s) return s;
    NrrdFieldReader r(name, h);
    if (Status s = r.requiredFields(); !s) return s;
    if (Status s = r.typeAndAxes(); !s) return s;
    if (Status s = r.encodingAndEndian(); !s) return s;
    if (Status s = r.geometry(); !s) return s;
    if (Status s = r.dataLocation(); !s) return s;
    return h;
}

Result<std::unique_ptr<InputSource>> openNrrdSource(const std::string& path, const InputOptions& options,
                                                    const uint64_t* wholeVolumeBudget) {
    Result<std::string> text = readNrrdHeaderText(path);
    if (!text) return text.status();
    Result<NrrdHeader> h = parseNrrdHeader(*text, path);
    if (!h) return h.status();
    if (wholeVolumeBudget)
        if (Status s = checkBudget(path, {{h->dim[0], h->dim[1], h->dim[2]}}, *wholeVolumeBudget); !s) return s;

    std::string dataPath = path;
    if (!h->dataFile.empty()) {
        Result<std::string> named = resolveInside(
            {h->dataFile, parentFolder(path), "data file", "the header's folder"}, options.allowOutsidePaths);
        if (!named) return Status(named.status()).prefix(path);
        dataPath = *named;
    }
    const std::string dataName = dataPath == path ? path : dataPath + " (data file of " + path + ")";
    Result<VoxelData> data = locateNrrdData(path, *h, dataPath, dataName);
    if (!data) return data.status();

    InputInfo info;
    info.dim = h->dim;
    info.type = h->type;
    info.geometry = h->geometry;
    info.format = "NRRD";
    info.detail = voxelDetail(h->type, h->bigEndian, h->gzip);
    if (dataPath != path) {
        info.detail += ", data in '" + dataPath + "'";
        std::error_code ec;
        info.namedFiles.push_back(std::filesystem::absolute(dataPath, ec).string());
    }
    auto src = std::make_unique<NrrdSource>(dataName, h->byteSkip);
    if (Status s = src->init(path, info, *data, options); !s) return s;
    return std::unique_ptr<InputSource>(std::move(src));
}

bool claimsNrrd(const std::string& path) { return endsWithNoCase(path, ".nrrd") || endsWithNoCase(path, ".nhdr"); }

Result<std::unique_ptr<InputSource>> openNrrd(const std::string& path, const InputOptions& options) {
    return openNrrdSource(path, options, nullptr);
}

} // namespace inputs

Result<InputVolume> readNrrd(const std::string& path, uint64_t maxBytes) {
    Result<std::unique_ptr<InputSource>> src = inputs::openNrrdSource(path, InputOptions{}, &maxBytes);
    if (!src) return src.status();
    return readAll(**src, path, maxBytes);
}

} // namespace csgv
