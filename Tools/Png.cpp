// SPDX-License-Identifier: MIT
#include "Png.h"

#include "csgv/base/FileUtil.h"

#include <cstring>

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

namespace {
uint32_t get32(const uint8_t* p) { return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3]; }
} // namespace

Status readPng(const std::string& path, uint32_t& width, uint32_t& height, uint32_t& channels,
               std::vector<uint8_t>& pixels) {
    Result<std::vector<uint8_t>> file = readFile(path, 1ull << 30);
    if (!file) return file.status();
    const std::vector<uint8_t>& f = *file;
    if (f.size() < 8 + 25 || std::memcmp(f.data(), "\x89PNG\r\n\x1a\n", 8) != 0) return Status::error(path + ": not a PNG");
    std::vector<uint8_t> packed;
    size_t at = 8;
    width = height = channels = 0;
    while (at + 12 <= f.size()) {
        const uint32_t n = get32(&f[at]);
        if (n > f.size() - at - 12) return Status::error(path + ": truncated chunk");
        const uint8_t* type = &f[at + 4];
        const uint8_t* data = &f[at + 8];
        if (!std::memcmp(type, "IHDR", 4)) {
            if (n != 13 || data[8] != 8 || (data[9] != 2 && data[9] != 6) || data[12] != 0)
                return Status::error(path + ": only 8-bit RGB/RGBA PNGs without interlacing are read");
            width = get32(data);
            height = get32(data + 4);
            channels = data[9] == 6 ? 4 : 3;
        } else if (!std::memcmp(type, "IDAT", 4)) {
            packed.insert(packed.end(), data, data + n);
        }
        at += 12 + n;
    }
    if (!width || !height || width > 65536 || height > 65536) return Status::error(path + ": bad PNG header");
    const size_t rowBytes = size_t(width) * channels + 1;
    std::vector<uint8_t> raw(rowBytes * height);
    uLongf rawSize = uLongf(raw.size());
    if (uncompress(raw.data(), &rawSize, packed.data(), uLong(packed.size())) != Z_OK || rawSize != raw.size())
        return Status::error(path + ": corrupt image data");
    pixels.resize(size_t(width) * height * channels);
    for (uint32_t y = 0; y < height; ++y) {
        if (raw[y * rowBytes] != 0) return Status::error(path + ": only PNG filter type 0 is read");
        std::memcpy(&pixels[y * (rowBytes - 1)], &raw[y * rowBytes + 1], rowBytes - 1);
    }
    return Status::ok();
}

} // namespace csgv
