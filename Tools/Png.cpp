// SPDX-License-Identifier: MIT
#include "Png.h"

#include "csgv/FileUtil.h"

#include <zlib.h>

namespace csgv {

namespace {

void put32(std::vector<uint8_t>& out, uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) out.push_back(uint8_t(v >> s));
}

void chunk(std::vector<uint8_t>& out, const char* type, const std::vector<uint8_t>& data) {
    put32(out, uint32_t(data.size()));
    const size_t start = out.size();
    out.insert(out.end(), type, type + 4);
    out.insert(out.end(), data.begin(), data.end());
    put32(out, uint32_t(crc32(0, out.data() + start, uInt(out.size() - start))));
}

} // namespace

Status writePng(const std::string& path, uint32_t width, uint32_t height, uint32_t channels,
                const std::vector<uint8_t>& pixels) {
    if ((channels != 3 && channels != 4) || pixels.size() != size_t(width) * height * channels || width == 0 || height == 0)
        return Status::error("PNG: bad image size");
    std::vector<uint8_t> raw;
    raw.reserve((size_t(width) * channels + 1) * height);
    for (uint32_t y = 0; y < height; ++y) {
        raw.push_back(0); // filter: none
        const uint8_t* row = pixels.data() + size_t(y) * width * channels;
        raw.insert(raw.end(), row, row + size_t(width) * channels);
    }
    uLongf packedSize = compressBound(uLong(raw.size()));
    std::vector<uint8_t> packed(packedSize);
    if (compress2(packed.data(), &packedSize, raw.data(), uLong(raw.size()), 6) != Z_OK)
        return Status::error("PNG: compression failed");
    packed.resize(packedSize);
    std::vector<uint8_t> file = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    std::vector<uint8_t> header;
    put32(header, width);
    put32(header, height);
    header.push_back(8);
    header.push_back(channels == 4 ? 6 : 2);
    header.push_back(0);
    header.push_back(0);
    header.push_back(0);
    chunk(file, "IHDR", header);
    chunk(file, "IDAT", packed);
    chunk(file, "IEND", {});
    AtomicFile f;
    Status s = f.open(path);
    if (s) s = f.write(file.data(), file.size());
    if (s) s = f.commit();
    return s;
}

} // namespace csgv
