// SPDX-License-Identifier: MIT
/// @file Nrrd.cpp
/// @brief NRRD (`.nrrd` attached, `.nhdr` detached): the header is read up to its blank line,
/// the data stream through InputStream (raw or gzip; byte and line skips; either byte order).
#include "InputCommon.h"

#include "csgv/base/Checked.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>

namespace csgv {

using namespace inputs;

namespace {

constexpr uint64_t kMaxNrrdHeader = uint64_t(4) << 20;

struct NrrdHeader {
    std::map<std::string, std::string> fields; ///< lower-case field name -> trimmed value
    bool attached = false;                      ///< a blank line ends the header, data follows
    uint64_t dataOffset = 0;
};

Result<NrrdHeader> readNrrdHeader(const std::string& path) {
    Result<uint64_t> size = fileSize(path);
    if (!size) return size.status();
    CFile file(std::fopen(path.c_str(), "rb"));
    if (!file.get()) return Status::error("cannot open '" + path + "': " + errnoText());

    // Read until the blank line that ends the header (the data may be gigabytes).
    std::string buf;
    size_t end = std::string::npos, dataStart = 0;
    std::vector<char> chunk(1 << 16);
    for (;;) {
        const size_t scanFrom = buf.size() > 2 ? buf.size() - 2 : 0;
        const size_t got = std::fread(chunk.data(), 1, chunk.size(), file.get());
        buf.append(chunk.data(), got);
        if (buf.size() >= 4 && buf.compare(0, 4, "NRRD") != 0)
            return fail(path, "not a NRRD file: it starts with " + quoted(buf.substr(0, 8)) +
                                  ", not the magic NRRD0001 to NRRD0005");
        for (size_t i = buf.find('\n', scanFrom); i != std::string::npos; i = buf.find('\n', i + 1)) {
            if (i + 1 < buf.size() && buf[i + 1] == '\n') {
                end = i + 1;
                dataStart = i + 2;
                break;
            }
            if (i + 2 < buf.size() && buf[i + 1] == '\r' && buf[i + 2] == '\n') {
                end = i + 1;
                dataStart = i + 3;
                break;
            }
        }
        if (end != std::string::npos || got == 0) break;
        if (buf.size() > kMaxNrrdHeader)
            return fail(path, "no blank line ends the NRRD header within its first " +
                                  std::to_string(kMaxNrrdHeader) + " bytes");
    }
    if (std::ferror(file.get())) return Status::error("cannot read '" + path + "': " + errnoText());

    NrrdHeader h;
    h.attached = end != std::string::npos;
    h.dataOffset = dataStart;
    const std::string text = h.attached ? buf.substr(0, end) : buf;

    std::vector<std::string> lines;
    for (size_t pos = 0; pos < text.size();) {
        size_t nl = text.find('\n', pos);
        if (nl == std::string::npos) nl = text.size();
        std::string line = text.substr(pos, nl - pos);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        lines.push_back(line);
        pos = nl + 1;
    }
    if (lines.empty()) return fail(path, "empty file, not a NRRD file");
    const std::string& magic = lines[0];
    if (magic.size() != 8 || magic.compare(0, 7, "NRRD000") != 0 || magic[7] < '1' || magic[7] > '5')
        return fail(path, "NRRD magic " + quoted(magic) + " is not NRRD0001 to NRRD0005");

    for (size_t n = 1; n < lines.size(); ++n) {
        const std::string& line = lines[n];
        if (line.empty() || line[0] == '#') continue;
        const size_t colon = line.find(':');
        if (colon == std::string::npos)
            return fail(path, "header line " + std::to_string(n + 1) + " " + quoted(line) +
                                  " is neither 'field: value' nor a '#' comment");
        if (colon + 1 < line.size() && line[colon + 1] == '=') continue; // key:=value pairs carry no geometry
        std::string name = lower(trim(line.substr(0, colon)));
        // Older NRRD versions spell some fields without the space.
        if (name == "datafile") name = "data file";
        else if (name == "byteskip") name = "byte skip";
        else if (name == "lineskip") name = "line skip";
        h.fields[name] = trim(line.substr(colon + 1));
        // "data file: LIST" is the last field: the lines after it name data files.
        if (name == "data file" && h.fields[name].compare(0, 4, "LIST") == 0) break;
    }
    return h;
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
                    why = "component " + quoted(trim(part)) + " is not a number";
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
                why = quoted(word) + " is neither a vector '(x,y,z)' nor 'none'";
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

/// @brief The steps of reading one NRRD volume, in order (readNrrd); each checks one group of
/// header fields and records, in these plain fields, what later steps need.
struct NrrdVolumeReader {
    const std::string& path;
    const NrrdHeader& h;
    InputVolume vol;
    int64_t dimension = 0;
    size_t axes = 0;
    std::vector<NrrdVector> directions;
    std::vector<size_t> kept;
    bool gzip = false;
    unsigned bytesPerVoxel = 1;
    bool bigEndian = false;
    std::string dataPath;
    uint64_t start = 0;
    int64_t lineSkip = 0, byteSkip = 0;

    NrrdVolumeReader(const std::string& file, const NrrdHeader& header) : path(file), h(header) {}

    const std::string* field(const char* name) const {
        const auto it = h.fields.find(name);
        return it == h.fields.end() ? nullptr : &it->second;
    }

    Status requiredFields() const {
        for (const char* required : {"type", "dimension", "sizes", "encoding"})
            if (!field(required)) return fail(path, "the required NRRD field '" + std::string(required) + "' is missing");

        return Status::ok();
    }

    /// Voxel type, dimension, sizes, space directions, which axes are spatial, the budget.
    Status typeAndAxes(uint64_t maxBytes) {
        const std::string& typeText = *field("type");
        if (!nrrdType(typeText, vol.type))
            return fail(path, "type " + quoted(typeText) +
                                  " is not supported (integer types of 8 to 64 bits, float or double)");

        if (!parseInt64(*field("dimension"), dimension) || dimension < 1)
            return fail(path, "dimension " + quoted(*field("dimension")) + " is not a positive integer");
        if (dimension != 3 && dimension != 4)
            return fail(path, "dimension " + std::to_string(dimension) +
                                  " is not supported (3, or 4 with one axis of size 1)");
        axes = size_t(dimension);

        const std::vector<std::string> sizeWords = splitWords(*field("sizes"));
        if (sizeWords.size() != axes)
            return fail(path, "sizes " + quoted(*field("sizes")) + " has " + std::to_string(sizeWords.size()) +
                                  " values, dimension is " + std::to_string(dimension));
        std::vector<uint64_t> sizes;
        for (const std::string& w : sizeWords) {
            int64_t v = 0;
            if (!parseInt64(w, v) || v < 1 || v > int64_t(0xFFFFFFFFu))
                return fail(path, "sizes value " + quoted(w) + " is not an integer from 1 to 4294967295");
            sizes.push_back(uint64_t(v));
        }

        // Per-axis space directions (needed before choosing which of four axes to drop).
        if (const std::string* sd = field("space directions")) {
            std::string why;
            if (!parseNrrdVectors(*sd, directions, why)) return fail(path, "space directions: " + why);
            if (directions.size() != axes)
                return fail(path, "space directions has " + std::to_string(directions.size()) +
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
                return fail(path, "dimension 4 with sizes " + quoted(*field("sizes")) +
                                      ": only a 4th axis of size 1 (leading or trailing) is supported");
            kept.clear();
            for (size_t a = 0; a < 4; ++a)
                if (a != drop) kept.push_back(a);
        }
        const std::array<uint64_t, 3> d3 = {{sizes[kept[0]], sizes[kept[1]], sizes[kept[2]]}};
        if (Status s = checkBudget(path, d3, maxBytes); !s) return s;
        vol.dim = {{uint32_t(d3[0]), uint32_t(d3[1]), uint32_t(d3[2])}};

        return Status::ok();
    }

    Status encodingAndEndian() {
        const std::string encoding = lower(*field("encoding"));
        if (encoding == "gzip" || encoding == "gz") gzip = true;
        else if (encoding != "raw")
            return fail(path, "encoding " + quoted(*field("encoding")) + " is not supported (raw or gzip)");

        bytesPerVoxel = typeBytes(vol.type);
        if (const std::string* e = field("endian")) {
            const std::string v = lower(*e);
            if (v == "big") bigEndian = true;
            else if (v != "little") return fail(path, "endian " + quoted(*e) + " is neither 'little' nor 'big'");
        } else if (bytesPerVoxel > 1) {
            return fail(path, "the field 'endian' is missing; it is required for " + std::string(labelTypeName(vol.type)) +
                                  " data");
        }

        return Status::ok();
    }

    /// Spacing, direction and origin.
    Status geometry() {
        int spaceDim = 0;
        if (const std::string* sp = field("space")) {
            spaceDim = nrrdSpaceDimension(*sp);
            if (spaceDim == 0) return fail(path, "space " + quoted(*sp) + " is not a NRRD space name");
        }
        if (const std::string* sdim = field("space dimension")) {
            int64_t v = 0;
            if (!parseInt64(*sdim, v) || v < 1)
                return fail(path, "space dimension " + quoted(*sdim) + " is not a positive integer");
            if (spaceDim != 0 && v != spaceDim)
                return fail(path, "space dimension " + std::to_string(v) + " contradicts space " + quoted(*field("space")));
            spaceDim = int(v);
        }
        Geometry& g = vol.geometry;
        if (!directions.empty()) {
            for (size_t k = 0; k < 3; ++k) {
                const size_t a = kept[k];
                const NrrdVector& dir = directions[a];
                if (dir.isNone)
                    return fail(path, "space directions: axis " + std::to_string(a) + " is 'none' but is a spatial axis");
                if (spaceDim != 0 && dir.v.size() != size_t(spaceDim))
                    return fail(path, "space directions: axis " + std::to_string(a) + " has " +
                                          std::to_string(dir.v.size()) + " components, space dimension is " +
                                          std::to_string(spaceDim));
                if (dir.v.size() != 3)
                    return fail(path, "space directions: axis " + std::to_string(a) + " has " +
                                          std::to_string(dir.v.size()) + " components; only 3D spaces are supported");
                const double norm = std::sqrt(dir.v[0] * dir.v[0] + dir.v[1] * dir.v[1] + dir.v[2] * dir.v[2]);
                if (!std::isfinite(norm) || norm == 0)
                    return fail(path, "space directions: axis " + std::to_string(a) + " vector (" + formatDouble(dir.v[0]) +
                                          "," + formatDouble(dir.v[1]) + "," + formatDouble(dir.v[2]) +
                                          ") has no usable length");
                g.spacing[k] = norm;
                for (int r = 0; r < 3; ++r) g.direction[3 * r + k] = dir.v[r] / norm;
            }
        } else if (const std::string* sp = field("spacings")) {
            const std::vector<std::string> words = splitWords(*sp);
            if (words.size() != axes)
                return fail(path, "spacings has " + std::to_string(words.size()) + " values, dimension is " +
                                      std::to_string(dimension));
            for (size_t k = 0; k < 3; ++k) {
                double v = 0;
                if (!parseDouble(words[kept[k]], v))
                    return fail(path, "spacings value " + quoted(words[kept[k]]) + " is not a number");
                if (std::isnan(v)) continue; // "nan": no spacing known along this axis
                if (!std::isfinite(v) || v == 0)
                    return fail(path, "spacings value " + quoted(words[kept[k]]) + " is not a usable spacing");
                // A negative spacing means the axis runs backwards; keep spacing positive.
                g.spacing[k] = std::fabs(v);
                if (v < 0) g.direction[4 * k] = -1;
            }
        }
        if (const std::string* so = field("space origin")) {
            std::vector<NrrdVector> origin;
            std::string why;
            if (!parseNrrdVectors(*so, origin, why)) return fail(path, "space origin: " + why);
            if (origin.size() != 1 || origin[0].isNone || origin[0].v.size() != 3)
                return fail(path, "space origin " + quoted(*so) + " is not one 3D vector '(x,y,z)'");
            for (int r = 0; r < 3; ++r) {
                if (!std::isfinite(origin[0].v[size_t(r)]))
                    return fail(path, "space origin " + quoted(*so) + " has a component that is not finite");
                g.origin[size_t(r)] = origin[0].v[size_t(r)];
            }
        }

        return Status::ok();
    }

    /// Which file holds the data, from where, and its line and byte skips.
    Status dataLocation() {
        dataPath = path;
        start = h.dataOffset;
        if (const std::string* df = field("data file")) {
            const std::vector<std::string> words = splitWords(*df);
            if (!words.empty() && words[0] == "LIST")
                return fail(path, "data file LIST (one data file per slice) is not supported; use a single data file");
            if (words.size() >= 4 && words[0].find('%') != std::string::npos)
                return fail(path, "data file format " + quoted(*df) +
                                      " (one data file per slice) is not supported; use a single data file");
            if (df->empty()) return fail(path, "the field 'data file' is empty");
            dataPath = (*df)[0] == '/' ? *df : parentFolder(path) + *df;
            start = 0;
        } else if (!h.attached) {
            return fail(path, "no data: the header has no 'data file' field and no blank line before attached data");
        }

        if (const std::string* ls = field("line skip"))
            if (!parseInt64(*ls, lineSkip) || lineSkip < 0)
                return fail(path, "line skip " + quoted(*ls) + " is not a non-negative integer");
        if (const std::string* bs = field("byte skip")) {
            if (!parseInt64(*bs, byteSkip) || byteSkip < -1)
                return fail(path, "byte skip " + quoted(*bs) + " is not -1 or a non-negative integer");
            if (byteSkip == -1 && gzip) return fail(path, "byte skip -1 is only allowed with raw encoding, not gzip");
        }

        return Status::ok();
    }

    /// Opens the data, skips to it and streams the voxels (raw or gzip) into the volume.
    Result<InputVolume> readData() {
        const std::string dataName = dataPath == path ? path : dataPath + " (data file of " + path + ")";
        Result<uint64_t> fileBytes = fileSize(dataPath);
        if (!fileBytes) return Status(fileBytes.status()).prefix(path);
        CFile file(std::fopen(dataPath.c_str(), "rb"));
        if (!file.get()) return fail(path, "cannot open data file '" + dataPath + "': " + errnoText());
        if (start > *fileBytes || !seekTo(file.get(), start))
            return fail(dataName, "no data after the header");
        for (int64_t line = 0; line < lineSkip; ++line) {
            int c;
            while ((c = std::getc(file.get())) != EOF && c != '\n') {
            }
            if (c == EOF)
                return fail(dataName, "line skip " + std::to_string(lineSkip) + " passes the end of the file");
        }
        if (lineSkip > 0) start = uint64_t(ftello(file.get()));

        const uint64_t dataBytes = vol.voxelCount() * bytesPerVoxel; // within maxBytes by checkBudget
        InputStream stream;
        if (gzip) {
            // Deflate cannot expand more than 1032:1, so a small file claiming a large volume is refused
            // before anything is read.
            const uint64_t compressed = *fileBytes - std::min(start, *fileBytes);
            if (mulSaturate(compressed, 1032) + 1024 < dataBytes + uint64_t(byteSkip))
                return fail(dataName, "truncated: " + std::to_string(compressed) +
                                          " bytes of gzip data cannot hold the " + std::to_string(dataBytes) +
                                          " bytes the header's sizes and type need");
            // With gzip, byte skip counts inflated bytes (as teem does).
            const uint64_t total = uint64_t(byteSkip) + dataBytes;
            Status s = stream.attach(file.get(), dataPath, InputStream::Mode::Inflate);
            Result<VoxelRead> got = VoxelRead{};
            if (s) {
                Result<uint64_t> skipped = stream.skip(uint64_t(byteSkip));
                if (!skipped) s = skipped.status();
            }
            if (s) {
                got = readVoxels(stream, vol, bigEndian, path);
                if (!got) s = got.status();
            }
            if (!s) {
                switch (stream.failure()) {
                case InputStream::Failure::Read: return fail(path, "cannot read '" + dataPath + "': " + s.message());
                case InputStream::Failure::Corrupt:
                    return fail(path, "corrupt gzip data in '" + dataPath + "': " + s.message());
                default: return s.prefix(path);
                }
            }
            if (stream.position() < total)
                return fail(path, "truncated gzip data in '" + dataPath + "': it inflates to " +
                                      std::to_string(stream.position()) + " bytes, the header's sizes and type need " +
                                      std::to_string(total) + (byteSkip ? " (with byte skip)" : ""));
            if (!got->decode) return got->decode;
            return vol;
        }

        uint64_t offset = start + uint64_t(std::max<int64_t>(byteSkip, 0));
        if (byteSkip == -1) {
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
        const std::string cannotRead = "cannot read " + std::to_string(dataBytes) + " bytes of data: ";
        if (!seekTo(file.get(), offset)) return fail(dataName, cannotRead + errnoText());
        if (Status s = stream.attach(file.get(), dataPath, InputStream::Mode::Plain); !s)
            return fail(dataName, cannotRead + s.message());
        Result<VoxelRead> got = readVoxels(stream, vol, bigEndian, path);
        if (!got) return fail(dataName, cannotRead + got.status().message());
        if (got->bytes != dataBytes) // the file shrank since its size was taken: errno says nothing
            return fail(dataName, cannotRead + "the file ends after " + std::to_string(got->bytes));
        if (!got->decode) return got->decode;
        return vol;
    }

};

} // namespace

Result<InputVolume> readNrrd(const std::string& path, uint64_t maxBytes) {
    Result<NrrdHeader> header = readNrrdHeader(path);
    if (!header) return header.status();
    NrrdVolumeReader r(path, *header);
    if (Status s = r.requiredFields(); !s) return s;
    if (Status s = r.typeAndAxes(maxBytes); !s) return s;
    if (Status s = r.encodingAndEndian(); !s) return s;
    if (Status s = r.geometry(); !s) return s;
    if (Status s = r.dataLocation(); !s) return s;
    return r.readData();
}

} // namespace csgv

namespace csgv {
namespace inputs {

bool claimsNrrd(const std::string& path) { return endsWithNoCase(path, ".nrrd") || endsWithNoCase(path, ".nhdr"); }

Result<std::unique_ptr<InputSource>> openNrrd(const std::string& path, const InputOptions&) {
    return sourceOf(readNrrd(path), "NRRD");
}

} // namespace inputs
} // namespace csgv
