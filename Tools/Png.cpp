// SPDX-License-Identifier: MIT
#include "Png.h"

#include "csgv/base/FileUtil.h"

#include <png.h>


namespace csgv {

// libpng's simplified API (1.6): 8-bit RGB/RGBA in and out, no gamma or colour transforms on
// such files, so the pixels read back are the pixels written.

Status writePng(const std::string& path, uint32_t width, uint32_t height, uint32_t channels,
                const std::vector<uint8_t>& pixels) {
    if ((channels != 3 && channels != 4) || pixels.size() != size_t(width) * height * channels || width == 0 || height == 0)
        return Status::error("PNG: bad image size");
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    image.width = width;
    image.height = height;
    image.format = channels == 4 ? PNG_FORMAT_RGBA : PNG_FORMAT_RGB;
    // Encoded to memory first, then written through AtomicFile: never a half file under the name.
    // One compression pass into a buffer of the largest size libpng can produce.
    png_alloc_size_t bytes = PNG_IMAGE_PNG_SIZE_MAX(image);
    std::vector<uint8_t> file(bytes);
    if (!png_image_write_to_memory(&image, file.data(), &bytes, 0, pixels.data(), 0, nullptr))
        return Status::error("PNG: " + std::string(image.message));
    file.resize(bytes);
    AtomicFile f;
    Status s = f.open(path);
    if (s) s = f.write(file.data(), file.size());
    if (s) s = f.commit();
    return s;
}

Status readPng(const std::string& path, uint32_t& width, uint32_t& height, uint32_t& channels,
               std::vector<uint8_t>& pixels) {
    width = height = channels = 0;
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&image, path.c_str()))
        return Status::error(path + ": " + std::string(image.message));
    const bool rgbOnly = image.format == PNG_FORMAT_RGB || image.format == PNG_FORMAT_RGBA;
    if (!rgbOnly || image.width == 0 || image.height == 0 || image.width > 65536 || image.height > 65536) {
        png_image_free(&image);
        return Status::error(path + ": only 8-bit RGB/RGBA PNGs are read");
    }
    channels = (image.format & PNG_FORMAT_FLAG_ALPHA) ? 4 : 3;
    pixels.resize(PNG_IMAGE_SIZE(image));
    if (!png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr))
        return Status::error(path + ": " + std::string(image.message));
    width = image.width;
    height = image.height;
    return Status::ok();
}

} // namespace csgv
