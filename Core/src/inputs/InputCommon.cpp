// SPDX-License-Identifier: MIT
#include "InputCommon.h"

#include "csgv/base/Checked.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <locale>
#include <sstream>

namespace csgv {
namespace inputs {

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

std::string quoted(const std::string& s, size_t maxChars) {
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

std::string dimText(const std::array<uint64_t, 3>& d) {
    return std::to_string(d[0]) + " x " + std::to_string(d[1]) + " x " + std::to_string(d[2]);
}

Status checkBudget(const std::string& path, const std::array<uint64_t, 3>& d, uint64_t maxBytes) {
    const uint64_t need = mulSaturate(product3(d[0], d[1], d[2]), 8);
    if (need == kSaturated)
        return fail(path, dimText(d) + " voxels need more than 2^64 bytes");
    if (need > maxBytes)
        return fail(path, dimText(d) + " voxels need " + std::to_string(need) +
                              " bytes as 64-bit labels, more than the limit of " + std::to_string(maxBytes));
    return Status::ok();
}

namespace {

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
void loadIntegers(const uint8_t* p, bool bigEndian, bool isSigned, uint64_t* out, size_t n) {
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

/// Decodes `n` voxels of `type` from `p` into full-width values; `first` is the index of the
/// first of them in the volume (for messages).
Status decodeVoxels(const uint8_t* p, LabelType type, bool bigEndian, const std::array<uint32_t, 3>& dim,
                    const std::string& path, uint64_t first, uint64_t* out, size_t n) {
    const bool sgn = isSignedType(type);
    switch (type) {
    case LabelType::U8:
    case LabelType::I8: loadIntegers<1>(p, bigEndian, sgn, out, n); return Status::ok();
    case LabelType::U16:
    case LabelType::I16: loadIntegers<2>(p, bigEndian, sgn, out, n); return Status::ok();
    case LabelType::U32:
    case LabelType::I32: loadIntegers<4>(p, bigEndian, sgn, out, n); return Status::ok();
    case LabelType::U64:
    case LabelType::I64: loadIntegers<8>(p, bigEndian, false, out, n); return Status::ok();
    case LabelType::F32:
    case LabelType::F64: break;
    }
    const bool f32 = type == LabelType::F32;
    for (size_t i = 0; i < n; ++i) {
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
            return fail(path, voxelName(first + i, dim) + " holds " + formatDouble(v) + ", which is not an integer label (" +
                                  labelTypeName(type) + " voxels must hold integers within int64)");
        out[i] = uint64_t(iv);
    }
    return Status::ok();
}

} // namespace

Result<VoxelRead> readVoxels(InputStream& in, InputVolume& vol, bool bigEndian, const std::string& path) {
    const unsigned width = typeBytes(vol.type);
    const uint64_t count = vol.voxelCount();
    const uint64_t chunkVoxels = (uint64_t(4) << 20) / width;
    std::vector<uint8_t> bytes(size_t(std::min(count, chunkVoxels) * width));
    VoxelRead got;
    vol.values.clear();
    // As much as the file can hold (all of it for any honest file): one allocation, no regrowth.
    vol.values.reserve(size_t(std::min(count, in.remainingBound() / width)));
    for (uint64_t first = 0; first < count;) {
        const uint64_t want = std::min(chunkVoxels, count - first);
        Result<size_t> n = in.read(bytes.data(), size_t(want * width));
        if (!n) return n.status();
        got.bytes += *n;
        const uint64_t whole = *n / width;
        if (got.decode) {
            vol.values.resize(size_t(first + whole));
            got.decode = decodeVoxels(bytes.data(), vol.type, bigEndian, vol.dim, path, first, vol.values.data() + first,
                                      size_t(whole));
        }
        first += whole;
        if (*n < want * width) break;
    }
    return got;
}

} // namespace inputs
} // namespace csgv
