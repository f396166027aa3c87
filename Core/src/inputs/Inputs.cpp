// SPDX-License-Identifier: MIT
#include "csgv/inputs/Inputs.h"
#include "csgv/base/Checked.h"
#include "csgv/base/FileUtil.h"
#include "csgv/codec/LabelVolume.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <locale>
#include <map>
#include <sstream>
#include <zlib.h>

namespace csgv {

const char* labelTypeName(LabelType type) {
    switch (type) {
    case LabelType::U8: return "uint8";
    case LabelType::I8: return "int8";
    case LabelType::U16: return "uint16";
    case LabelType::I16: return "int16";
    case LabelType::U32: return "uint32";
    case LabelType::I32: return "int32";
    case LabelType::U64: return "uint64";
    case LabelType::I64: return "int64";
    case LabelType::F32: return "float32";
    case LabelType::F64: return "float64";
    }
    return "unknown";
}

bool isSignedType(LabelType type) {
    // Floats count as signed: their integers are stored as int64 and may be negative.
    switch (type) {
    case LabelType::I8:
    case LabelType::I16:
    case LabelType::I32:
    case LabelType::I64:
    case LabelType::F32:
    case LabelType::F64: return true;
    default: return false;
    }
}

namespace {

Status fail(const std::string& path, const std::string& what) { return Status::error(path + ": " + what); }

std::string lower(std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

bool endsWith(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string trim(const std::string& s) {
    size_t b = 0, e = s.size();
    while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
    while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
    return s.substr(b, e - b);
}

/// Quotes text from a file for a message: bounded, with unprintable bytes escaped, so that a
/// binary file named as NRRD does not fill the message with garbage.
std::string quoted(const std::string& s, size_t maxChars = 60) {
    std::string out = "'";
    for (size_t i = 0; i < s.size() && i < maxChars; ++i) {
        const unsigned char c = static_cast<unsigned char>(s[i]);
        if (c >= 32 && c < 127) {
            out += char(c);
        } else {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\x%02x", c);
            out += buf;
        }
    }
    if (s.size() > maxChars) out += "...";
    return out + "'";
}

// Numbers in headers are parsed and printed in the classic locale: a host application may have
// set a locale whose decimal separator is a comma.
std::string formatDouble(double v) {
    std::ostringstream o;
    o.imbue(std::locale::classic());
    o.precision(17);
    o << v;
    return o.str();
}

bool parseDouble(const std::string& text, double& out) {
    const std::string t = lower(trim(text));
    if (t == "nan" || t == "+nan" || t == "-nan") {
        out = std::numeric_limits<double>::quiet_NaN();
        return true;
    }
    if (t == "inf" || t == "+inf" || t == "infinity" || t == "+infinity" || t == "-inf" || t == "-infinity") {
        out = t[0] == '-' ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
        return true;
    }
    if (t.empty()) return false;
    std::istringstream in(t);
    in.imbue(std::locale::classic());
    double v = 0;
    if (!(in >> v)) return false;
    char extra = 0;
    if (in >> extra) return false;
    out = v;
    return true;
}

bool parseInt64(const std::string& text, int64_t& out) {
    const std::string t = trim(text);
    size_t i = 0;
    bool negative = false;
    if (i < t.size() && (t[i] == '+' || t[i] == '-')) negative = t[i++] == '-';
    if (i == t.size()) return false;
    uint64_t v = 0;
    for (; i < t.size(); ++i) {
        if (t[i] < '0' || t[i] > '9') return false;
        const uint64_t digit = uint64_t(t[i] - '0');
        if (v > (uint64_t(1) << 62) / 10) return false; // far beyond any size or skip a header may name
        v = v * 10 + digit;
    }
    out = negative ? -int64_t(v) : int64_t(v);
    return true;
}

std::vector<std::string> splitWords(const std::string& s) {
    std::istringstream in(s);
    std::vector<std::string> words;
    std::string w;
    while (in >> w) words.push_back(w);
    return words;
}

std::string errnoText() { return std::strerror(errno); }

/// @brief Closes a C file on every return path.
class CFile {
public:
    explicit CFile(std::FILE* f) : m_file(f) {}
    ~CFile() {
        if (m_file) std::fclose(m_file);
    }
    CFile(const CFile&) = delete;
    CFile& operator=(const CFile&) = delete;
    std::FILE* get() const { return m_file; }

private:
    std::FILE* m_file;
};

bool seekTo(std::FILE* f, uint64_t offset) {
#if defined(_WIN32)
    return _fseeki64(f, int64_t(offset), SEEK_SET) == 0;
#else
    return fseeko(f, off_t(offset), SEEK_SET) == 0;
#endif
}

// ------------------------------------------------------------------------------------------------
// Voxel conversion
// ------------------------------------------------------------------------------------------------

unsigned typeBytes(LabelType type) {
    switch (type) {
    case LabelType::U8:
    case LabelType::I8: return 1;
    case LabelType::U16:
    case LabelType::I16: return 2;
    case LabelType::U32:
    case LabelType::I32:
    case LabelType::F32: return 4;
    default: return 8;
    }
}

template <unsigned W>
inline uint64_t loadBits(const uint8_t* p, bool bigEndian) {
    uint64_t v = 0;
    if (bigEndian)
        for (unsigned b = 0; b < W; ++b) v = (v << 8) | p[b];
    else
        for (unsigned b = W; b-- > 0;) v = (v << 8) | p[b];
    return v;
}

template <unsigned W>
void loadIntegers(const uint8_t* p, bool bigEndian, bool isSigned, std::vector<uint64_t>& out) {
    const size_t n = out.size();
    for (size_t i = 0; i < n; ++i) {
        uint64_t v = loadBits<W>(p + i * W, bigEndian);
        if (isSigned && W < 8) {
            const unsigned shift = 64 - 8 * W;
            v = uint64_t(int64_t(v << shift) >> shift);
        }
        out[i] = v;
    }
}

std::string voxelName(uint64_t i, const std::array<uint32_t, 3>& dim) {
    const uint64_t x = i % dim[0], y = (i / dim[0]) % dim[1], z = i / (uint64_t(dim[0]) * dim[1]);
    return "voxel " + std::to_string(i) + " (x " + std::to_string(x) + ", y " + std::to_string(y) + ", z " +
           std::to_string(z) + ")";
}

/// Converts a float that must hold an integer; false for fractions, NaN, infinities and values
/// outside int64.
bool floatToInt64(double v, int64_t& out) {
    if (!std::isfinite(v) || v != std::trunc(v)) return false;
    if (v < -9223372036854775808.0 || v >= 9223372036854775808.0) return false;
    out = int64_t(v);
    return true;
}

/// Decodes `out.size()` voxels of `type` from `p` into full-width values.
Status decodeVoxels(const uint8_t* p, LabelType type, bool bigEndian, const std::array<uint32_t, 3>& dim,
                    const std::string& path, std::vector<uint64_t>& out) {
    const bool sgn = isSignedType(type);
    switch (type) {
    case LabelType::U8:
    case LabelType::I8: loadIntegers<1>(p, bigEndian, sgn, out); return Status::ok();
    case LabelType::U16:
    case LabelType::I16: loadIntegers<2>(p, bigEndian, sgn, out); return Status::ok();
    case LabelType::U32:
    case LabelType::I32: loadIntegers<4>(p, bigEndian, sgn, out); return Status::ok();
    case LabelType::U64:
    case LabelType::I64: loadIntegers<8>(p, bigEndian, false, out); return Status::ok();
    case LabelType::F32:
    case LabelType::F64: break;
    }
    const bool f32 = type == LabelType::F32;
    for (size_t i = 0; i < out.size(); ++i) {
        double v;
        if (f32) {
            const uint32_t bits = uint32_t(loadBits<4>(p + 4 * i, bigEndian));
            float f;
            std::memcpy(&f, &bits, 4);
            v = f;
        } else {
            const uint64_t bits = loadBits<8>(p + 8 * i, bigEndian);
            std::memcpy(&v, &bits, 8);
        }
        int64_t iv;
        if (!floatToInt64(v, iv))
            return fail(path, voxelName(i, dim) + " holds " + formatDouble(v) + ", which is not an integer label (" +
                                  labelTypeName(type) + " voxels must hold integers within int64)");
        out[i] = uint64_t(iv);
    }
    return Status::ok();
}

std::string dimText(const std::array<uint64_t, 3>& d) {
    return std::to_string(d[0]) + " x " + std::to_string(d[1]) + " x " + std::to_string(d[2]);
}

/// Refuses volumes whose full-width values (8 bytes a voxel) exceed maxBytes, before anything
/// of that size is allocated.
Status checkBudget(const std::string& path, const std::array<uint64_t, 3>& d, uint64_t maxBytes) {
    const uint64_t need = mulSaturate(product3(d[0], d[1], d[2]), 8);
    if (need == kSaturated)
        return fail(path, dimText(d) + " voxels need more than 2^64 bytes");
    if (need > maxBytes)
        return fail(path, dimText(d) + " voxels need " + std::to_string(need) +
                              " bytes as 64-bit labels, more than the limit of " + std::to_string(maxBytes));
    return Status::ok();
}

// ------------------------------------------------------------------------------------------------
// Whole and partial file reads
// ------------------------------------------------------------------------------------------------

/// Reads up to `length` bytes starting at `offset` of a file, inflating gzip content (zlib passes
/// other content through); fewer when the file ends first. Bytes before `offset` are discarded
/// and the buffer grows as bytes arrive, so a header that claims more than the file holds costs
/// no allocation of the claimed size.
Result<std::vector<uint8_t>> readRangeMaybeGz(const std::string& path, uint64_t offset, uint64_t length) {
    if (!fileExists(path)) return Status::error("cannot open '" + path + "': no such file");
    gzFile f = gzopen(path.c_str(), "rb");
    if (!f) return Status::error("cannot open '" + path + "': " + errnoText());
    gzbuffer(f, 1 << 18);
    const auto failed = [&]() {
        int code = 0;
        const std::string why = gzerror(f, &code);
        gzclose(f);
        return Status::error("cannot inflate '" + path + "': " + why);
    };
    std::vector<uint8_t> data;
    std::vector<uint8_t> scratch(size_t(std::min<uint64_t>(offset, 1 << 16)));
    for (uint64_t skipped = 0; skipped < offset;) {
        const int n = gzread(f, scratch.data(), unsigned(std::min<uint64_t>(scratch.size(), offset - skipped)));
        if (n < 0) return failed();
        if (n == 0) {
            gzclose(f);
            return data;
        }
        skipped += uint64_t(n);
    }
    while (data.size() < length) {
        const uint64_t want = std::min<uint64_t>(length - data.size(), uint64_t(1) << 24);
        const size_t old = data.size();
        data.resize(old + size_t(want));
        const int n = gzread(f, data.data() + old, unsigned(want));
        if (n < 0) return failed();
        data.resize(old + size_t(n));
        if (n == 0) break;
    }
    gzclose(f);
    return data;
}

/// Inflates a gzip or zlib stream that starts at the current position of `f`: discards the first
/// `skip` inflated bytes, then fills `out` exactly. Concatenated gzip members are followed.
Status inflateInto(std::FILE* f, const std::string& dataPath, uint64_t skip, uint8_t* out, uint64_t outBytes) {
    z_stream s{};
    if (inflateInit2(&s, 15 + 32) != Z_OK) return Status::error("cannot start zlib for '" + dataPath + "'");
    std::vector<uint8_t> in(1 << 18);
    std::vector<uint8_t> scratch(skip ? (1 << 16) : 0);
    const uint64_t total = skip + outBytes;
    uint64_t produced = 0;
    bool inputEnded = false;
    Status status;
    while (produced < total) {
        if (s.avail_in == 0 && !inputEnded) {
            const size_t got = std::fread(in.data(), 1, in.size(), f);
            if (got == 0) {
                if (std::ferror(f)) {
                    status = Status::error("cannot read '" + dataPath + "': " + errnoText());
                    break;
                }
                inputEnded = true;
            }
            s.next_in = in.data();
            s.avail_in = uInt(got);
        }
        if (s.avail_in == 0 && inputEnded) {
            status = Status::error("truncated gzip data in '" + dataPath + "': it inflates to " +
                                   std::to_string(produced) + " bytes, the header's sizes and type need " +
                                   std::to_string(total) + (skip ? " (with byte skip)" : ""));
            break;
        }
        uint64_t room;
        if (produced < skip) {
            room = std::min<uint64_t>(scratch.size(), skip - produced);
            s.next_out = scratch.data();
        } else {
            room = std::min<uint64_t>(uint64_t(1) << 30, total - produced);
            s.next_out = out + (produced - skip);
        }
        s.avail_out = uInt(room);
        const int ret = inflate(&s, Z_NO_FLUSH);
        produced += room - s.avail_out;
        if (ret == Z_STREAM_END) {
            if (produced < total) inflateReset(&s); // a further gzip member may follow
            continue;
        }
        if (ret == Z_BUF_ERROR) continue; // needs more input; the next round reads or reports the end
        if (ret != Z_OK) {
            status = Status::error("corrupt gzip data in '" + dataPath + "': " +
                                   (s.msg ? std::string(s.msg) : "zlib error " + std::to_string(ret)));
            break;
        }
    }
    inflateEnd(&s);
    return status;
}

// ------------------------------------------------------------------------------------------------
// NRRD
// ------------------------------------------------------------------------------------------------

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

} // namespace

Result<InputVolume> readNrrd(const std::string& path, uint64_t maxBytes) {
    Result<NrrdHeader> header = readNrrdHeader(path);
    if (!header) return header.status();
    const NrrdHeader& h = *header;
    const auto field = [&](const char* name) -> const std::string* {
        const auto it = h.fields.find(name);
        return it == h.fields.end() ? nullptr : &it->second;
    };
    for (const char* required : {"type", "dimension", "sizes", "encoding"})
        if (!field(required)) return fail(path, "the required NRRD field '" + std::string(required) + "' is missing");

    InputVolume vol;
    const std::string& typeText = *field("type");
    if (!nrrdType(typeText, vol.type))
        return fail(path, "type " + quoted(typeText) +
                              " is not supported (integer types of 8 to 64 bits, float or double)");

    int64_t dimension = 0;
    if (!parseInt64(*field("dimension"), dimension) || dimension < 1)
        return fail(path, "dimension " + quoted(*field("dimension")) + " is not a positive integer");
    if (dimension != 3 && dimension != 4)
        return fail(path, "dimension " + std::to_string(dimension) +
                              " is not supported (3, or 4 with one axis of size 1)");
    const size_t axes = size_t(dimension);

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
    std::vector<NrrdVector> directions;
    if (const std::string* sd = field("space directions")) {
        std::string why;
        if (!parseNrrdVectors(*sd, directions, why)) return fail(path, "space directions: " + why);
        if (directions.size() != axes)
            return fail(path, "space directions has " + std::to_string(directions.size()) +
                                  " entries, dimension is " + std::to_string(dimension));
    }

    std::vector<size_t> kept = {0, 1, 2};
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

    const std::string encoding = lower(*field("encoding"));
    bool gzip = false;
    if (encoding == "gzip" || encoding == "gz") gzip = true;
    else if (encoding != "raw")
        return fail(path, "encoding " + quoted(*field("encoding")) + " is not supported (raw or gzip)");

    const unsigned bytesPerVoxel = typeBytes(vol.type);
    bool bigEndian = false;
    if (const std::string* e = field("endian")) {
        const std::string v = lower(*e);
        if (v == "big") bigEndian = true;
        else if (v != "little") return fail(path, "endian " + quoted(*e) + " is neither 'little' nor 'big'");
    } else if (bytesPerVoxel > 1) {
        return fail(path, "the field 'endian' is missing; it is required for " + std::string(labelTypeName(vol.type)) +
                              " data");
    }

    // ---- geometry
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

    // ---- where the data is
    std::string dataPath = path;
    uint64_t start = h.dataOffset;
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

    int64_t lineSkip = 0, byteSkip = 0;
    if (const std::string* ls = field("line skip"))
        if (!parseInt64(*ls, lineSkip) || lineSkip < 0)
            return fail(path, "line skip " + quoted(*ls) + " is not a non-negative integer");
    if (const std::string* bs = field("byte skip")) {
        if (!parseInt64(*bs, byteSkip) || byteSkip < -1)
            return fail(path, "byte skip " + quoted(*bs) + " is not -1 or a non-negative integer");
        if (byteSkip == -1 && gzip) return fail(path, "byte skip -1 is only allowed with raw encoding, not gzip");
    }

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

    const uint64_t n = vol.voxelCount();
    const uint64_t dataBytes = n * bytesPerVoxel; // within maxBytes by checkBudget
    std::vector<uint8_t> data;
    if (gzip) {
        // Deflate cannot expand more than 1032:1, so a small file claiming a large volume is refused
        // before its buffer is allocated.
        const uint64_t compressed = *fileBytes - std::min(start, *fileBytes);
        if (mulSaturate(compressed, 1032) + 1024 < dataBytes + uint64_t(byteSkip))
            return fail(dataName, "truncated: " + std::to_string(compressed) +
                                      " bytes of gzip data cannot hold the " + std::to_string(dataBytes) +
                                      " bytes the header's sizes and type need");
        data.resize(size_t(dataBytes));
        if (Status s = inflateInto(file.get(), dataPath, uint64_t(byteSkip), data.data(), dataBytes); !s)
            return s.prefix(path);
    } else {
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
        data.resize(size_t(dataBytes));
        if (!seekTo(file.get(), offset) ||
            (dataBytes && std::fread(data.data(), 1, size_t(dataBytes), file.get()) != dataBytes))
            return fail(dataName, "cannot read " + std::to_string(dataBytes) + " bytes of data: " + errnoText());
    }

    vol.values.resize(size_t(n));
    if (Status s = decodeVoxels(data.data(), vol.type, bigEndian, vol.dim, path, vol.values); !s) return s;
    return vol;
}

// ------------------------------------------------------------------------------------------------
// NIfTI-1
// ------------------------------------------------------------------------------------------------

namespace {

constexpr size_t kNiftiHeader = 348;

/// @brief Reads fields of a NIfTI-1 header in the file's byte order.
struct NiftiFields {
    const uint8_t* p;
    bool big;
    uint64_t raw(size_t off, unsigned w) const {
        uint64_t v = 0;
        if (big)
            for (unsigned b = 0; b < w; ++b) v = (v << 8) | p[off + b];
        else
            for (unsigned b = w; b-- > 0;) v = (v << 8) | p[off + b];
        return v;
    }
    int16_t i16(size_t off) const { return int16_t(uint16_t(raw(off, 2))); }
    int32_t i32(size_t off) const { return int32_t(uint32_t(raw(off, 4))); }
    double f32(size_t off) const {
        const uint32_t bits = uint32_t(raw(off, 4));
        float f;
        std::memcpy(&f, &bits, 4);
        return f;
    }
};

bool niftiType(int code, LabelType& type) {
    switch (code) {
    case 2: type = LabelType::U8; return true;
    case 4: type = LabelType::I16; return true;
    case 8: type = LabelType::I32; return true;
    case 16: type = LabelType::F32; return true;
    case 64: type = LabelType::F64; return true;
    case 256: type = LabelType::I8; return true;
    case 512: type = LabelType::U16; return true;
    case 768: type = LabelType::U32; return true;
    case 1024: type = LabelType::I64; return true;
    case 1280: type = LabelType::U64; return true;
    default: return false;
    }
}

const char* niftiTypeName(int code) {
    switch (code) {
    case 1: return "binary";
    case 32: return "complex64";
    case 128: return "RGB24";
    case 1536: return "float128";
    case 1792: return "complex128";
    case 2048: return "complex256";
    case 2304: return "RGBA32";
    default: return "unknown";
    }
}

/// nifti1_io's rule: a pixdim that is not positive counts as 1.
double niftiSpacing(double v) { return std::isfinite(v) && v > 0 ? v : 1.0; }

} // namespace

Result<InputVolume> readNifti(const std::string& path, uint64_t maxBytes) {
    Result<std::vector<uint8_t>> head = readRangeMaybeGz(path, 0, kNiftiHeader + 4);
    if (!head) return head.status();
    if (head->size() < kNiftiHeader)
        return fail(path, "only " + std::to_string(head->size()) + " bytes, too short for a NIfTI-1 header (348)");
    NiftiFields hf{head->data(), false};
    const int32_t sizeofHdr = hf.i32(0);
    if (sizeofHdr != 348) {
        hf.big = true;
        if (hf.i32(0) != 348) {
            hf.big = false;
            if (sizeofHdr == 540 || NiftiFields{head->data(), true}.i32(0) == 540)
                return fail(path, "NIfTI-2 (sizeof_hdr 540) is not supported, only NIfTI-1");
            return fail(path, "not a NIfTI-1 file: sizeof_hdr is " + std::to_string(sizeofHdr) + ", expected 348");
        }
    }
    const std::string magic(reinterpret_cast<const char*>(head->data()) + 344, 4);
    if (magic == std::string("ni1\0", 4))
        return fail(path, "a NIfTI-1 .hdr/.img pair (magic 'ni1') is not supported; use a single .nii file");
    if (magic != std::string("n+1\0", 4))
        return fail(path, "NIfTI-1 magic " + quoted(magic) + " is not 'n+1'");

    int dim[8];
    for (int i = 0; i < 8; ++i) dim[i] = hf.i16(40 + 2 * size_t(i));
    if (dim[0] < 2 || dim[0] > 7)
        return fail(path,
                    "dim[0] is " + std::to_string(dim[0]) + "; a label volume needs 3 (or 2, or 4 with dim[4] = 1)");
    std::array<uint64_t, 3> d3 = {{1, 1, 1}};
    for (int i = 1; i <= dim[0]; ++i) {
        if (dim[i] < 1)
            return fail(path, "dim[" + std::to_string(i) + "] is " + std::to_string(dim[i]) + ", not a positive size");
        if (i <= 3) d3[size_t(i - 1)] = uint64_t(dim[i]);
        else if (dim[i] != 1)
            return fail(path, "dim[" + std::to_string(i) + "] is " + std::to_string(dim[i]) +
                                  ": only one 3D volume is supported (dim[4..7] must be 1)");
    }

    InputVolume vol;
    const int datatype = hf.i16(70);
    if (!niftiType(datatype, vol.type))
        return fail(path, "datatype " + std::to_string(datatype) + " (" + niftiTypeName(datatype) +
                              ") is not supported; a label volume needs an integer or float type");

    double slope = hf.f32(112), inter = hf.f32(116);
    // nifti1_io treats non-finite scale fields as absent.
    if (!std::isfinite(slope)) slope = 0;
    if (!std::isfinite(inter)) inter = 0;
    if (!(slope == 0 || (slope == 1 && inter == 0)))
        return fail(path, "scaled data (scl_slope " + formatDouble(slope) + ", scl_inter " + formatDouble(inter) +
                              "): labels must be stored unscaled");

    const double voxOffset = hf.f32(108);
    if (!std::isfinite(voxOffset) || voxOffset < double(kNiftiHeader) || voxOffset != std::floor(voxOffset) ||
        voxOffset > 1e12)
        return fail(path, "vox_offset " + formatDouble(voxOffset) + " is not a whole byte offset of at least 348");

    if (Status s = checkBudget(path, d3, maxBytes); !s) return s;
    vol.dim = {{uint32_t(d3[0]), uint32_t(d3[1]), uint32_t(d3[2])}};

    // ---- geometry
    Geometry& g = vol.geometry;
    const int qformCode = hf.i16(252), sformCode = hf.i16(254);
    double pixdim[8];
    for (int i = 0; i < 8; ++i) pixdim[i] = hf.f32(76 + 4 * size_t(i));
    if (sformCode > 0) {
        double m[3][4];
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) m[r][c] = hf.f32(280 + 16 * size_t(r) + 4 * size_t(c));
        for (int c = 0; c < 3; ++c) {
            const double norm = std::sqrt(m[0][c] * m[0][c] + m[1][c] * m[1][c] + m[2][c] * m[2][c]);
            if (!std::isfinite(norm) || norm == 0)
                return fail(path, "sform (sform_code " + std::to_string(sformCode) + ") column " + std::to_string(c) +
                                      " has no usable length");
            g.spacing[size_t(c)] = norm;
            for (int r = 0; r < 3; ++r) g.direction[size_t(3 * r + c)] = m[r][c] / norm;
        }
        for (int r = 0; r < 3; ++r) {
            if (!std::isfinite(m[r][3])) return fail(path, "sform offset is not finite");
            g.origin[size_t(r)] = m[r][3];
        }
    } else if (qformCode > 0) {
        // The quaternion rule of the NIfTI-1 standard (nifti1.h, method 2), as nifti1_io applies it.
        double b = hf.f32(256), c = hf.f32(260), d = hf.f32(264);
        double a = 1.0 - (b * b + c * c + d * d);
        if (a < 1e-7) {
            const double len = std::sqrt(b * b + c * c + d * d);
            if (!std::isfinite(len) || len == 0) return fail(path, "qform quaternion is not usable");
            b /= len;
            c /= len;
            d /= len;
            a = 0;
        } else {
            a = std::sqrt(a);
        }
        const double qfac = pixdim[0] < 0 ? -1.0 : 1.0;
        const double rot[9] = {a * a + b * b - c * c - d * d, 2 * (b * c - a * d),         2 * (b * d + a * c),
                               2 * (b * c + a * d),         a * a + c * c - b * b - d * d, 2 * (c * d - a * b),
                               2 * (b * d - a * c),         2 * (c * d + a * b),         a * a + d * d - c * c - b * b};
        for (int i = 0; i < 9; ++i) g.direction[size_t(i)] = rot[i] * ((i % 3 == 2) ? qfac : 1.0);
        for (int k = 0; k < 3; ++k) g.spacing[size_t(k)] = niftiSpacing(pixdim[k + 1]);
        for (int r = 0; r < 3; ++r) {
            const double o = hf.f32(268 + 4 * size_t(r));
            if (!std::isfinite(o)) return fail(path, "qform offset is not finite");
            g.origin[size_t(r)] = o;
        }
        for (double v : g.direction)
            if (!std::isfinite(v)) return fail(path, "qform quaternion is not finite");
    } else {
        for (int k = 0; k < 3; ++k) g.spacing[size_t(k)] = niftiSpacing(pixdim[k + 1]);
    }

    // ---- voxels
    const uint64_t offset = uint64_t(voxOffset);
    const uint64_t dataBytes = vol.voxelCount() * typeBytes(vol.type);
    Result<std::vector<uint8_t>> bytes = readRangeMaybeGz(path, offset, dataBytes);
    if (!bytes) return bytes.status();
    if (bytes->size() < dataBytes)
        return fail(path, "truncated: " + std::to_string(bytes->size()) +
                              " bytes of voxel data after vox_offset " + std::to_string(offset) + ", " +
                              dimText(d3) + " " + labelTypeName(vol.type) + " voxels need " +
                              std::to_string(dataBytes));
    vol.values.resize(size_t(vol.voxelCount()));
    if (Status s = decodeVoxels(bytes->data(), vol.type, hf.big, vol.dim, path, vol.values); !s) return s;
    return vol;
}

Result<InputVolume> readInput(const std::string& path, uint64_t maxBytes) {
    const std::string name = lower(path);
    if (endsWith(name, ".vraw") || endsWith(name, ".vraw.gz")) {
        Result<LabelVolume> raw = readVraw(path, maxBytes);
        if (!raw) return raw.status();
        const std::array<uint64_t, 3> d3 = {{raw->dim[0], raw->dim[1], raw->dim[2]}};
        if (Status s = checkBudget(path, d3, maxBytes); !s) return s;
        InputVolume vol;
        vol.dim = raw->dim;
        vol.type = LabelType::U32; // readVraw widens uint8/uint16 labels to uint32
        vol.values.assign(raw->labels.begin(), raw->labels.end());
        return vol;
    }
    if (endsWith(name, ".nrrd") || endsWith(name, ".nhdr")) return readNrrd(path, maxBytes);
    if (endsWith(name, ".nii") || endsWith(name, ".nii.gz")) return readNifti(path, maxBytes);
    return fail(path, "unsupported input format; supported suffixes are .vraw, .vraw.gz, .nrrd, .nhdr, .nii and "
                      ".nii.gz");
}

} // namespace csgv
