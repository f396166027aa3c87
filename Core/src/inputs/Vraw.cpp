// SPDX-License-Identifier: MIT
/// @file Vraw.cpp
/// @brief Volcanite's `.vraw` / `.vraw.gz` as an input volume, streamed through InputStream
/// straight into full-width values (no copy of the file and no uint32 volume in between).
/// The checks and their order are those of the codec's readVraw: the file (or inflated) size
/// limit, the header, the label byte count, then the memory budget.
#include "InputCommon.h"

#include "csgv/base/Checked.h"
#include "csgv/codec/LabelVolume.h"

#include <algorithm>
#include <limits>

namespace csgv {
namespace inputs {

namespace {

/// Words stream failures as readFile (plain) and readFileMaybeGz (gzip) always have.
Status streamError(const std::string& path, bool gz, const InputStream& in, const Status& s) {
    if (gz) {
        if (in.failure() == InputStream::Failure::Open) return Status::error("cannot open '" + path + "'");
        return Status::error("cannot inflate '" + path + "': " + path + ": " + s.message());
    }
    if (in.failure() == InputStream::Failure::Open) return Status::error("cannot open '" + path + "': " + s.message());
    return Status::error("cannot read '" + path + "': short read");
}

/// Little-endian labels of 1, 2 or 4 bytes to full width.
void widenLabels(const uint8_t* p, uint32_t width, size_t n, uint64_t* out) {
    if (width == 4)
        for (size_t i = 0; i < n; ++i, p += 4)
            out[i] = uint64_t(p[0]) | uint64_t(p[1]) << 8 | uint64_t(p[2]) << 16 | uint64_t(p[3]) << 24;
    else if (width == 2)
        for (size_t i = 0; i < n; ++i, p += 2) out[i] = uint64_t(p[0]) | uint64_t(p[1]) << 8;
    else
        for (size_t i = 0; i < n; ++i) out[i] = p[i];
}

} // namespace

Result<InputVolume> readVrawInput(const std::string& path, uint64_t maxBytes) {
    const uint64_t fileLimit = maxBytes + 64; // the header's few bytes on top of the labels
    const bool gz = endsWithNoCase(path, ".gz");
    uint64_t plainBytes = 0;
    if (gz) {
        if (!fileExists(path)) return Status::error("cannot open '" + path + "': no such file");
    } else {
        Result<uint64_t> size = fileSize(path);
        if (!size) return size.status();
        if (*size > fileLimit)
            return Status::error("'" + path + "' is " + std::to_string(*size) + " bytes, more than the limit of " +
                                 std::to_string(fileLimit));
        plainBytes = *size;
    }
    InputStream in;
    if (Status s = in.open(path, gz ? InputStream::Mode::Auto : InputStream::Mode::Plain); !s)
        return streamError(path, gz, in, s);
    const auto tooLarge = [&]() {
        return Status::error("'" + path + "' inflates to more than the limit of " + std::to_string(fileLimit) +
                             " bytes");
    };
    // Inflates the rest to learn the content's size (and meet any corruption first, as a reader of
    // the whole file would).
    const auto drainRest = [&]() -> Status {
        Result<uint64_t> rest = in.skip(std::numeric_limits<uint64_t>::max());
        if (!rest) return streamError(path, gz, in, rest.status());
        if (in.position() > fileLimit) return tooLarge();
        return Status::ok();
    };

    uint8_t head[160]; // parseVrawHeader needs no more
    Result<size_t> headBytes = in.read(head, sizeof head);
    if (!headBytes) return streamError(path, gz, in, headBytes.status());
    Result<VrawHeader> h = parseVrawHeader(head, *headBytes);
    if (!h) {
        if (gz)
            if (Status s = drainRest(); !s) return s;
        return Status(h.status()).prefix(path);
    }
    const std::array<uint64_t, 3> d3 = {{h->dim[0], h->dim[1], h->dim[2]}};
    const uint64_t count = product3(d3[0], d3[1], d3[2]);
    const Status budget = checkBudget(path, d3, maxBytes);
    const bool withinBudget = budget.isOk();
    if (!gz) {
        if (Status s = h->checkLabelBytes(plainBytes - h->headerBytes); !s) return s.prefix(path);
        if (!withinBudget) return budget;
    }

    InputVolume vol;
    vol.dim = h->dim;
    vol.type = LabelType::U32; // uint8/uint16 labels widen, as readVraw does
    // Every content byte after the header is counted; labels are stored while wanted and the
    // budget allows (a surplus is only counted, for checkLabelBytes' message).
    const uint32_t width = h->bytesPerLabel;
    std::vector<uint8_t> buf(size_t(1) << 22);
    size_t pending = *headBytes - size_t(h->headerBytes); // label bytes read with the header
    std::copy(head + h->headerBytes, head + *headBytes, buf.begin());
    uint64_t labelBytes = pending;
    if (withinBudget) vol.values.reserve(size_t(std::min(count, (pending + in.remainingBound()) / width)));
    for (;;) {
        Result<size_t> n = in.read(buf.data() + pending, buf.size() - pending);
        if (!n) return streamError(path, gz, in, n.status());
        if (gz && in.position() > fileLimit) return tooLarge();
        labelBytes += *n;
        const size_t have = pending + *n;
        size_t used = have;
        if (withinBudget && vol.values.size() < count) {
            const size_t whole = size_t(std::min<uint64_t>(have / width, count - vol.values.size()));
            const size_t first = vol.values.size();
            vol.values.resize(first + whole);
            widenLabels(buf.data(), width, whole, vol.values.data() + first);
            used = whole * width;
        }
        // A label split across reads waits for its other bytes; anything else is surplus.
        pending = withinBudget && vol.values.size() < count ? have - used : 0;
        std::copy(buf.begin() + long(used), buf.begin() + long(used + pending), buf.begin());
        if (*n == 0) break;
    }
    if (gz) {
        if (Status s = h->checkLabelBytes(labelBytes); !s) return s.prefix(path);
        if (!withinBudget) return budget;
    }
    return vol;
}

} // namespace inputs
} // namespace csgv

namespace csgv {
namespace inputs {

bool claimsVraw(const std::string& path) { return endsWithNoCase(path, ".vraw") || endsWithNoCase(path, ".vraw.gz"); }

Result<std::unique_ptr<InputSource>> openVraw(const std::string& path, const InputOptions&) {
    return sourceOf(readVrawInput(path, uint64_t(16) << 30), "vraw");
}

} // namespace inputs
} // namespace csgv
