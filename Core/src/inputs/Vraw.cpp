// SPDX-License-Identifier: MIT
/// @file Vraw.cpp
/// @brief Volcanite's `.vraw` / `.vraw.gz` as a streaming source. The header ("W H D", the label
/// type) is checked at open; a plain file must then hold exactly the labels it claims (a
/// truncated one is refused before any voxel is read). The labels are read slab by slab by
/// VoxelFileSource: positioned reads of each slab's bytes in a plain file, one gzip stream kept
/// open between slabs otherwise (an earlier slab restarts it), whose label count is checked
/// where it runs out or, for a surplus, after the last voxel, with readVraw's message.
/// uint8/uint16 labels widen to uint32, as readVraw does. Working memory:
/// VoxelFileSource's (a decode buffer and a gzip stream, and for gzip read in bands of rows one
/// inflated slab, in memory up to 64 MiB, else in a scratch file).
#include "InputCommon.h"

#include "csgv/base/Checked.h"
#include "csgv/codec/LabelVolume.h"

#include <limits>

namespace csgv {
namespace inputs {

namespace {

/// Words stream failures as readFileMaybeGz always has.
Status vrawStreamError(const std::string& path, const InputStream& in, const Status& s) {
    if (in.failure() == InputStream::Failure::Open) return Status::error("cannot open '" + path + "'");
    return Status::error("cannot inflate '" + path + "': " + path + ": " + s.message());
}

LabelType storedType(uint32_t bytesPerLabel) {
    return bytesPerLabel == 1 ? LabelType::U8 : bytesPerLabel == 2 ? LabelType::U16 : LabelType::U32;
}

/// @brief The labels of one `.vraw` file, after its text header.
class VrawSource : public VoxelFileSource {
public:
    explicit VrawSource(const VrawHeader& header) : m_header(header) {}

protected:
    Status truncated(uint64_t available) const override {
        return Status(m_header.checkLabelBytes(available)).prefix(path());
    }
    Status streamFailure(const InputStream& in, const Status& s) const override {
        return vrawStreamError(path(), in, s);
    }
    /// Labels beyond the claimed ones are an error too (readVraw wants the exact count); reading
    /// on to the stream's end also verifies the gzip checksum.
    Status atDataEnd(InputStream& in) override {
        uint8_t extra = 0;
        Result<size_t> n = in.read(&extra, 1);
        if (!n) return streamFailure(in, n.status());
        if (*n == 0) return Status::ok();
        Result<uint64_t> rest = in.skip(std::numeric_limits<uint64_t>::max());
        if (!rest) return streamFailure(in, rest.status());
        return truncated(dataBytes() + 1 + *rest);
    }

private:
    VrawHeader m_header;
};

} // namespace

bool claimsVraw(const std::string& path) { return endsWithNoCase(path, ".vraw") || endsWithNoCase(path, ".vraw.gz"); }

Result<std::unique_ptr<InputSource>> openVraw(const std::string& path, const InputOptions& options) {
    const bool gzName = endsWithNoCase(path, ".gz");
    if (gzName) {
        if (Status s = regularFile(path); !s) return s;
    }
    Result<uint64_t> size = fileSize(path);
    if (!size) return size.status();
    // A `.vraw.gz` whose content is not gzip is read as it is (what gzopen does).
    InputStream in;
    if (Status s = in.open(path, gzName ? InputStream::Mode::Auto : InputStream::Mode::Plain); !s)
        return gzName ? vrawStreamError(path, in, s) : Status::error("cannot open '" + path + "': " + s.message());

    uint8_t head[160]; // parseVrawHeader needs no more
    Result<size_t> headBytes = in.read(head, sizeof head);
    if (!headBytes) return vrawStreamError(path, in, headBytes.status());
    Result<VrawHeader> h = parseVrawHeader(head, *headBytes);
    if (!h) {
        if (in.compressed()) {
            // Corruption further on is met first, as by a reader of the whole file.
            Result<uint64_t> rest = in.skip(std::numeric_limits<uint64_t>::max());
            if (!rest) return vrawStreamError(path, in, rest.status());
        }
        return Status(h.status()).prefix(path);
    }
    const uint64_t labelBytes = mulSaturate(product3(h->dim[0], h->dim[1], h->dim[2]), h->bytesPerLabel);
    if (labelBytes == kSaturated) return Status(h->checkLabelBytes(0)).prefix(path);

    VoxelData data;
    data.file = path;
    data.compressed = in.compressed();
    data.mode = InputStream::Mode::Auto;
    data.stored = storedType(h->bytesPerLabel);
    if (data.compressed) {
        data.skip = h->headerBytes;
    } else {
        if (Status s = h->checkLabelBytes(*size - h->headerBytes); !s) return s.prefix(path);
        data.fileOffset = h->headerBytes;
    }
    InputInfo info;
    info.dim = h->dim;
    info.type = LabelType::U32;
    info.format = "vraw";
    info.detail = std::string(labelTypeName(data.stored)) + " labels" + (data.compressed ? ", gzip" : "");
    auto src = std::make_unique<VrawSource>(*h);
    if (Status s = src->init(path, info, data, options); !s) return s;
    return std::unique_ptr<InputSource>(std::move(src));
}

} // namespace inputs
} // namespace csgv
