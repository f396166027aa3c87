// SPDX-License-Identifier: MIT
/// @file Tiff.cpp
/// @brief TIFF input through libtiff, streamed page by page: a multi-page file (page z is slice
/// z), a folder of single-page slice files, a glob of them, or an ordered list of them.
///
/// Forms (claimsTiff; `.zarr` and precomputed folders are claimed before this one):
/// - `X.tif` / `X.tiff`: every IFD of the main chain is one z page (SubIFDs are not visited);
///   a single-page file is a volume of depth 1.
/// - `DIR/` or an existing directory: its `*.tif` / `*.tiff` files (case-insensitive, hidden
///   files skipped), one slice each.
/// - a glob (`*`, `?` or `[` in the last path component, matched with fnmatch(3) over that
///   folder's listing, hidden files only by an explicit leading dot; wildcards in the folder
///   part are taken literally): one slice per file.
/// - a list of files (openTiffSlices, what ParaView's file dialog hands over for a file series):
///   one slice per file, in the order given.
/// Slices of a folder or glob are sorted by name in natural order: runs of digits compare by
/// value, so `slice_2` comes before `slice_10` (names equal by value, such as `s01` and `s1`,
/// fall back to byte order). Each slice file must have one page: a folder (or list) of
/// multi-page files is refused rather than concatenated, because such files usually are separate
/// volumes (channels, time points).
/// A matching name that is no regular file (a dangling link, a FIFO, a folder) is an error naming
/// it, not a slice skipped; no file is opened in a way that could block (PathGuard.h). A page
/// chain whose next-IFD offset points back to an earlier page is reported as the loop it is.
///
/// Samples: one per pixel, 8/16/32/64-bit unsigned or signed integers, or 32/64-bit floats that
/// hold integers; any strip or tile layout and any compression this libtiff decodes. A palette
/// page with one sample is read as its colour indices. Every page
/// must have the same width, height and type (checked when opened, and again when read, since
/// the buffers are sized from the page's own tags). Geometry: spacing 1, origin 0: TIFF has no
/// z spacing tag, and its X/YResolution are mostly a meaningless 72 dpi default.
///
/// Working memory: one decoded strip or tile (reused; pixels are widened from it straight into
/// the caller's slab), libtiff's buffer of one strip's compressed bytes and the codec's state
/// (ReadMemory). Their sum over the largest of each on any page is checked against
/// InputOptions::maxWorkingBytes when the input is opened, before any pixel is decoded, and again
/// as each page is read (the file may have changed). A tile far larger than its image, or a strip
/// or tile claiming far more compressed bytes than its pixels can need, is refused by name: only a
/// crafted or corrupt header has one. One file is open at a time: the multi-page file, or the
/// slice being read. Each page's IFD offset is cached when opened, so a page is reached with
/// one TIFFSetSubDirectory, not by walking the chain.
///
/// libtiff's messages: each handle is opened with TIFFOpenExt and its own error and warning
/// handlers (libtiff >= 4.5), which take precedence over the process-wide ones, so nothing is
/// printed and no global state is touched (another libtiff user in the process, such as VTK's
/// TIFF reader, may install its own global handlers). Errors are kept with the handle and end up
/// in the Status; warnings are dropped.
#include "InputCommon.h"

#include "csgv/inputs/PathGuard.h"

#include <tiffio.h>

#include <fnmatch.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdarg>
#include <cstring>
#include <filesystem>
#include <limits>
#include <type_traits>
#include <unordered_map>

#if TIFFLIB_VERSION < 20221213
#error "TIFF input needs libtiff 4.5 or newer (TIFFOpenExt with per-handle error handlers)"
#endif

namespace csgv {
namespace inputs {

namespace fs = std::filesystem;

namespace {

// ---- libtiff handles with their own message capture -----------------------------------------

int keepError(TIFF*, void* userData, const char*, const char* fmt, va_list ap) {
    auto* errors = static_cast<std::string*>(userData);
    char text[512];
    std::vsnprintf(text, sizeof text, fmt, ap);
    if (errors->size() < 2000) *errors += std::string(errors->empty() ? "" : "; ") + text;
    return 1; // handled: libtiff's global handler (stderr by default) is not called
}

int dropWarning(TIFF*, void*, const char*, const char*, va_list) { return 1; }

struct TiffCloser {
    void operator()(TIFF* tif) const { TIFFClose(tif); }
};

/// @brief One open TIFF file and the errors libtiff reported on it.
class TiffHandle {
public:
    TiffHandle() = default;
    TiffHandle(TiffHandle&&) = default;
    /// Closes the old file first, while the string its error handler writes to still exists
    /// (the implicit one would free the string first: members are assigned in declaration order).
    TiffHandle& operator=(TiffHandle&& other) noexcept {
        if (this != &other) {
            m_tif = std::move(other.m_tif);
            m_errors = std::move(other.m_errors);
            m_fileBytes = other.m_fileBytes;
        }
        return *this;
    }

    /// Opens `file`; an error's message is only the reason (callers name the file).
    static Result<TiffHandle> open(const std::string& file, uint64_t maxAlloc) {
        TiffHandle h;
        h.m_errors = std::make_unique<std::string>();
        // Opened by us, so that a FIFO is refused instead of blocking; libtiff closes it from then on.
        Result<int> fd = openRegularFile(file);
        if (!fd) return fd.status();
        struct stat st {};
        if (::fstat(*fd, &st) != 0) {
            const std::string why = errnoText();
            ::close(*fd);
            return Status::error(why);
        }
        h.m_fileBytes = uint64_t(st.st_size);
        TIFFOpenOptions* opts = TIFFOpenOptionsAlloc();
        TIFFOpenOptionsSetErrorHandlerExtR(opts, keepError, h.m_errors.get());
        TIFFOpenOptionsSetWarningHandlerExtR(opts, dropWarning, nullptr);
        // A backstop against sizes a corrupt header claims (strip buffers are checked before
        // reading); directory arrays get at least 64 MiB, so a small working budget still opens.
        const uint64_t cap = std::max<uint64_t>(maxAlloc, uint64_t(64) << 20);
        TIFFOpenOptionsSetMaxSingleMemAlloc(opts, tmsize_t(std::min<uint64_t>(cap, INT64_MAX / 2)));
        // "m": read(2), not mmap: a file truncated while mapped would raise SIGBUS.
        h.m_tif.reset(TIFFFdOpenExt(*fd, file.c_str(), "rm", opts));
        TIFFOpenOptionsFree(opts);
        if (!h.m_tif) {
            ::close(*fd); // a failed open leaves the descriptor to its caller
            return Status::error(h.libtiffSays());
        }
        return Result<TiffHandle>(std::move(h));
    }
    TIFF* get() const { return m_tif.get(); }
    uint64_t fileBytes() const { return m_fileBytes; }
    /// libtiff's errors since the last call, for a message.
    std::string libtiffSays() {
        std::string s = m_errors && !m_errors->empty() ? "libtiff: " + *m_errors : "libtiff gave no reason";
        if (m_errors) m_errors->clear();
        return s;
    }

private:
    std::unique_ptr<std::string> m_errors; // stable address for the handler; outlives m_tif
    std::unique_ptr<TIFF, TiffCloser> m_tif;
    uint64_t m_fileBytes = 0;
};

// ---- one page's layout ------------------------------------------------------------------------

/// a + b, or kSaturated where that would wrap (sizes from a header).
constexpr uint64_t addSaturate(uint64_t a, uint64_t b) { return a > kSaturated - b ? kSaturated : a + b; }

/// @brief What a page is (size, type) and how its pixels are stored (strips or tiles).
struct PageLayout {
    uint32_t width = 0, height = 0;
    LabelType type = LabelType::U8;
    bool tiled = false;
    uint32_t tileWidth = 0, tileHeight = 0; ///< tiled
    uint32_t rowsPerStrip = 0;              ///< stripped (clamped to the height)
    uint16_t compression = COMPRESSION_NONE;
    uint64_t largestCompressed = 0; ///< the most compressed bytes of one strip or tile (once checked)

    /// Bytes of one decoded strip or tile (saturating: a header may claim tiles of 2^32 x 2^32).
    uint64_t blockBytes() const {
        const uint64_t pixels = tiled ? uint64_t(tileWidth) * tileHeight : uint64_t(rowsPerStrip) * width;
        return mulSaturate(pixels, typeBytes(type));
    }
    uint64_t blockCount() const {
        if (!tiled) return (uint64_t(height) + rowsPerStrip - 1) / rowsPerStrip;
        return ((uint64_t(width) + tileWidth - 1) / tileWidth) * ((uint64_t(height) + tileHeight - 1) / tileHeight);
    }
    std::string sizeAndType() const {
        return std::to_string(width) + " x " + std::to_string(height) + " " + labelTypeName(type);
    }
};

std::string compressionName(uint16_t c) {
    switch (c) {
    case COMPRESSION_NONE: return "uncompressed";
    case COMPRESSION_LZW: return "LZW";
    case COMPRESSION_ADOBE_DEFLATE:
    case COMPRESSION_DEFLATE: return "deflate";
    case COMPRESSION_PACKBITS: return "PackBits";
    case COMPRESSION_JPEG:
    case COMPRESSION_OJPEG: return "JPEG";
    case COMPRESSION_LZMA: return "LZMA";
    case COMPRESSION_ZSTD: return "zstd";
    case COMPRESSION_WEBP: return "WebP";
    default: break;
    }
    const TIFFCodec* codec = TIFFFindCODEC(c);
    return codec ? std::string(codec->name) : "compression " + std::to_string(c);
}

std::string layoutText(const PageLayout& p) {
    const std::string blocks = p.tiled ? "tiles " + std::to_string(p.tileWidth) + "x" + std::to_string(p.tileHeight)
                                       : "strips of " + std::to_string(p.rowsPerStrip) + " rows";
    return blocks + ", " + compressionName(p.compression);
}

/// The label type of a page's samples; empty `why` when supported.
LabelType sampleType(uint16_t bits, uint16_t format, std::string& why) {
    if (bits == 1) {
        why = "is a bilevel (1 bit per pixel) image; label volumes need 8, 16, 32 or 64-bit integer samples";
        return LabelType::U8;
    }
    if (bits != 8 && bits != 16 && bits != 32 && bits != 64) {
        why = "has " + std::to_string(bits) + "-bit samples; supported are 8, 16, 32 and 64 bits";
        return LabelType::U8;
    }
    if (format == SAMPLEFORMAT_UINT || format == SAMPLEFORMAT_VOID)
        return bits == 8 ? LabelType::U8 : bits == 16 ? LabelType::U16 : bits == 32 ? LabelType::U32 : LabelType::U64;
    if (format == SAMPLEFORMAT_INT)
        return bits == 8 ? LabelType::I8 : bits == 16 ? LabelType::I16 : bits == 32 ? LabelType::I32 : LabelType::I64;
    if (format == SAMPLEFORMAT_IEEEFP && (bits == 32 || bits == 64))
        return bits == 32 ? LabelType::F32 : LabelType::F64;
    why = "has sample format " + std::to_string(format) + " with " + std::to_string(bits) +
          " bits (supported: unsigned and signed integers, 32/64-bit floats holding integers)";
    return LabelType::U8;
}

/// The page's samples as a label type; an empty string when supported, else what is wrong.
std::string readSamples(TIFF* tif, PageLayout& p) {
    uint16_t spp = 1, bits = 1, format = SAMPLEFORMAT_UINT, photometric = PHOTOMETRIC_MINISBLACK;
    TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLESPERPIXEL, &spp);
    TIFFGetFieldDefaulted(tif, TIFFTAG_BITSPERSAMPLE, &bits);
    TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLEFORMAT, &format);
    TIFFGetField(tif, TIFFTAG_PHOTOMETRIC, &photometric);
    if (spp != 1) {
        const char* kind = photometric == PHOTOMETRIC_RGB       ? " (RGB)"
                           : photometric == PHOTOMETRIC_PALETTE ? " (palette)"
                           : photometric == PHOTOMETRIC_YCBCR   ? " (YCbCr)"
                                                                : "";
        return "has " + std::to_string(spp) + " samples per pixel" + kind + "; a label image has 1 (a grey-scale page)";
    }
    std::string why;
    p.type = sampleType(bits, format, why);
    return why;
}

/// A tile may pad the image (tiles are multiples of 16 wide and tall, and a writer may use one
/// size for every image), but one larger than the whole image and than this is no layout a
/// writer chooses: a header written to make a reader allocate.
constexpr uint64_t kLargestPaddingTileBytes = uint64_t(16) << 20;

/// Empty when the page's tiles are of a size an image can have, else what is wrong.
std::string tileSizeProblem(const PageLayout& p) {
    const auto upTo16 = [](uint32_t n) { return (uint64_t(n) + 15) / 16 * 16; };
    const uint64_t paddedImage = product3(upTo16(p.width), upTo16(p.height), typeBytes(p.type));
    if (p.blockBytes() <= std::max(paddedImage, kLargestPaddingTileBytes)) return {};
    return "has tiles of " + std::to_string(p.tileWidth) + " x " + std::to_string(p.tileHeight) + " for a " +
           std::to_string(p.width) + " x " + std::to_string(p.height) +
           " image: a tile far larger than the image (a corrupt or crafted header)";
}

/// How the page's pixels are stored: strips or tiles, and the codec; empty when readable.
std::string readBlocks(TIFF* tif, PageLayout& p) {
    uint32_t imageDepth = 1;
    TIFFGetFieldDefaulted(tif, TIFFTAG_IMAGEDEPTH, &imageDepth);
    if (imageDepth != 1)
        return "is a 3D tile stack (ImageDepth " + std::to_string(imageDepth) + "), which is not supported";
    TIFFGetFieldDefaulted(tif, TIFFTAG_COMPRESSION, &p.compression);
    if (!TIFFIsCODECConfigured(p.compression))
        return "uses " + compressionName(p.compression) + ", which this libtiff cannot decode";
    p.tiled = TIFFIsTiled(tif) != 0;
    uint64_t blocks = 0;
    if (p.tiled) {
        TIFFGetField(tif, TIFFTAG_TILEWIDTH, &p.tileWidth);
        TIFFGetField(tif, TIFFTAG_TILELENGTH, &p.tileHeight);
        if (p.tileWidth == 0 || p.tileHeight == 0) return "is tiled but has no tile size";
        if (std::string why = tileSizeProblem(p); !why.empty()) return why;
        blocks = TIFFNumberOfTiles(tif);
    } else {
        uint32_t rps = p.height;
        TIFFGetFieldDefaulted(tif, TIFFTAG_ROWSPERSTRIP, &rps);
        p.rowsPerStrip = std::min(std::max(rps, 1u), p.height);
        blocks = TIFFNumberOfStrips(tif);
    }
    if (blocks == p.blockCount()) return {};
    return "has " + std::to_string(blocks) + (p.tiled ? " tiles" : " strips") + " where its size needs " +
           std::to_string(p.blockCount());
}

/// Reads the current directory's layout; `where` names the page in messages ("page 3", a file).
Result<PageLayout> readLayout(TiffHandle& h, const std::string& path, const std::string& where) {
    TIFF* tif = h.get();
    PageLayout p;
    if (!TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &p.width) || !TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &p.height) ||
        p.width == 0 || p.height == 0)
        return fail(path, where + " has no image size (ImageWidth/ImageLength missing or 0)");
    if (std::string why = readSamples(tif, p); !why.empty()) return fail(path, where + " " + why);
    if (std::string why = readBlocks(tif, p); !why.empty()) return fail(path, where + " " + why);
    return p;
}

/// The first way `p` differs from `ref` (page 0), empty when it does not.
std::string differenceFrom(const PageLayout& p, const PageLayout& ref) {
    if (p.width == ref.width && p.height == ref.height && p.type == ref.type) return {};
    return " is " + p.sizeAndType() + " but the first page is " + ref.sizeAndType() + " (every page must match)";
}

/// The state a codec keeps while decoding one strip or tile, beside the decoded and compressed
/// bytes: zlib's inflate state and 32 KiB window, libtiff's LZW code table (5119 entries of 16
/// bytes). Other codecs (JPEG, LZMA, zstd, WebP...) stage up to a decoded block of their own and
/// keep tables or a window: an estimate of one more block and 1 MiB.
uint64_t decoderStateBytes(const PageLayout& p) {
    switch (p.compression) {
    case COMPRESSION_NONE:
    case COMPRESSION_PACKBITS: return 0;
    case COMPRESSION_ADOBE_DEFLATE:
    case COMPRESSION_DEFLATE: return uint64_t(64) << 10;
    case COMPRESSION_LZW: return uint64_t(128) << 10;
    default: return addSaturate(p.blockBytes(), uint64_t(1) << 20);
    }
}

/// @brief The working memory reading needs: the largest decoded strip or tile (the reader's one
/// buffer), the most compressed bytes of one (libtiff's raw buffer) and the largest codec state,
/// over the pages seen so far.
struct ReadMemory {
    uint64_t block = 0, compressed = 0, decoder = 0;
    uint64_t total() const { return addSaturate(addSaturate(block, compressed), decoder); }
    void add(const PageLayout& p) {
        block = std::max(block, p.blockBytes());
        compressed = std::max(compressed, p.largestCompressed);
        decoder = std::max(decoder, decoderStateBytes(p));
    }
    /// "a decoded strip of N bytes, ...": what total() is made of, for a message.
    std::string parts(bool tiled) const {
        return std::string("a decoded ") + (tiled ? "tile" : "strip") + " of " + std::to_string(block) + " bytes, " +
               std::to_string(compressed) + " compressed bytes of one and " + std::to_string(decoder) +
               " bytes of decoder state";
    }
};

/// Compressed bytes beyond which a strip or tile holds more than any codec writes for its pixels
/// (LZW's worst case is 1.5 times, JPEG's headers a few KiB): a corrupt or crafted byte count.
uint64_t mostCompressedBytes(const PageLayout& p) { return addSaturate(mulSaturate(p.blockBytes(), 4), 64 << 10); }

// ---- finding the slice files ----------------------------------------------------------------

/// Natural order: digit runs by value, everything else byte by byte (see @file).
bool naturalLess(const std::string& a, const std::string& b) {
    auto digit = [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; };
    size_t i = 0, j = 0;
    while (i < a.size() && j < b.size()) {
        if (digit(a[i]) && digit(b[j])) {
            size_t ie = i, je = j;
            while (ie < a.size() && digit(a[ie]))
                ++ie;
            while (je < b.size() && digit(b[je]))
                ++je;
            while (i + 1 < ie && a[i] == '0')
                ++i; // leading zeros do not change the value
            while (j + 1 < je && b[j] == '0')
                ++j;
            if (ie - i != je - j) return ie - i < je - j;
            if (int c = a.compare(i, ie - i, b, j, je - j)) return c < 0;
            i = ie;
            j = je;
            continue;
        }
        if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
        ++i;
        ++j;
    }
    if ((i < a.size()) != (j < b.size())) return j < b.size();
    return a < b;
}

bool isTiffName(const std::string& name) {
    const std::string l = lower(name);
    return endsWith(l, ".tif") || endsWith(l, ".tiff");
}

bool hasWildcard(const std::string& s) { return s.find_first_of("*?[") != std::string::npos; }

std::string lastComponent(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

/// The files of `dir` whose name `keep` accepts, in natural order. Each must be a regular file
/// (symbolic links followed): a dangling link, a FIFO or a folder among the slices is an error
/// naming it, since skipping it would silently make the volume thinner (and a FIFO would block).
template <typename Keep>
Result<std::vector<std::string>> listFolder(const std::string& dir, const std::string& path, Keep keep) {
    const std::string folder = dir.empty() ? "." : dir;
    std::error_code ec;
    fs::directory_iterator it(folder, ec), end;
    std::vector<std::string> names;
    for (; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (!keep(name)) continue;
        const std::string kind = notRegularFile(it->path().string());
        if (!kind.empty())
            return fail(path, "slice " + quotedText(name, 200) + " is " + kind + ", not a TIFF file (remove it, or name the slices by a glob that leaves it out)");
        names.push_back(name);
    }
    if (ec) return fail(path, "cannot list folder " + folder + ": " + ec.message());
    std::sort(names.begin(), names.end(), naturalLess);
    const std::string prefix = dir.empty() ? "" : dir.back() == '/' ? dir : dir + "/";
    for (std::string& n : names)
        n = prefix + n;
    return names;
}

/// @brief The files of an input and how they were named.
struct Listing {
    enum class Form { MultiPage, Folder, Glob, List } form = Form::MultiPage;
    std::vector<std::string> files;
};

Result<Listing> listFiles(const std::string& path) {
    Listing l;
    if (isDir(path) || (!path.empty() && path.back() == '/')) {
        l.form = Listing::Form::Folder;
        Result<std::vector<std::string>> files =
            listFolder(path, path, [](const std::string& n) { return n[0] != '.' && isTiffName(n); });
        if (!files) return files.status();
        if (files->empty()) return fail(path, "the folder holds no .tif or .tiff slice files");
        l.files = std::move(*files);
    } else if (hasWildcard(lastComponent(path))) {
        l.form = Listing::Form::Glob;
        const size_t slash = path.find_last_of('/');
        const std::string dir = slash == std::string::npos ? "" : path.substr(0, slash + 1);
        const std::string pattern = lastComponent(path);
        Result<std::vector<std::string>> files = listFolder(
            dir, path, [&](const std::string& n) { return fnmatch(pattern.c_str(), n.c_str(), FNM_PERIOD) == 0; });
        if (!files) return files.status();
        if (files->empty()) return fail(path, "no file matches the pattern " + quotedText(pattern));
        l.files = std::move(*files);
    } else {
        l.files = {path};
    }
    return l;
}

/// A list of slice files as given; like listFolder, a name that is no regular file is an error
/// naming it (`name` starts the message).
Result<Listing> listGiven(const std::vector<std::string>& files, const std::string& name) {
    Listing l;
    l.form = Listing::Form::List;
    if (files.empty()) return Status::error("no TIFF slice files given");
    for (size_t z = 0; z < files.size(); ++z) {
        const std::string kind = notRegularFile(files[z]);
        if (kind.empty()) continue;
        return fail(name, "slice " + quotedText(files[z], 400) + " (z " + std::to_string(z) + ") " +
                              (kind == "missing" ? std::string("does not exist") : "is " + kind + ", not a TIFF file"));
    }
    l.files = files;
    return l;
}

// ---- the page chain ---------------------------------------------------------------------------

/// The offset of the IFD that follows the one at `ifd` (0 at the chain's end), read from the file
/// (libtiff keeps it private), so that a chain looping back is reported as such. False when the
/// IFD cannot be read (libtiff then says why).
bool nextIfdOffset(TIFF* tif, uint64_t ifd, uint64_t& next) {
    const int fd = TIFFFileno(tif);
    const bool big = TIFFIsBigTIFF(tif) != 0;
    const uint16_t one = 1;
    uint8_t hostFirst = 0;
    std::memcpy(&hostFirst, &one, 1);
    const bool fileLittle = (hostFirst == 1) != (TIFFIsByteSwapped(tif) != 0);
    auto readUint = [&](uint64_t at, unsigned bytes, uint64_t& v) {
        uint8_t b[8];
        if (at > uint64_t(std::numeric_limits<off_t>::max()) || ::pread(fd, b, bytes, off_t(at)) != ssize_t(bytes))
            return false;
        v = 0;
        for (unsigned i = 0; i < bytes; ++i) v |= uint64_t(b[fileLittle ? i : bytes - 1 - i]) << (8 * i);
        return true;
    };
    uint64_t entries = 0;
    if (!readUint(ifd, big ? 8 : 2, entries) || entries > (uint64_t(1) << 40)) return false;
    return readUint(ifd + (big ? 8 : 2) + entries * (big ? 20 : 12), big ? 8 : 4, next);
}

// ---- pixels -------------------------------------------------------------------------------------

/// libtiff delivers decoded samples in the host's byte order (InputCommon's widenSamples widens them).
bool hostIsLittleEndian() {
    const uint16_t one = 1;
    uint8_t first = 0;
    std::memcpy(&first, &one, 1);
    return first == 1;
}

// ---- the source -------------------------------------------------------------------------------

/// @brief Pages of one multi-page file or of many slice files, read one strip or tile at a time.
class TiffSource : public InputSource {
public:
    /// @brief Where page z is: a file of m_files and the offset of its IFD.
    struct PageRef {
        uint32_t file = 0;
        uint64_t ifdOffset = 0;
    };

    TiffSource(std::string path, Listing listing, const InputOptions& options)
        : m_path(std::move(path)), m_form(listing.form), m_files(std::move(listing.files)),
          m_maxWorkingBytes(options.maxWorkingBytes) {}

    Status scan() {
        if (Status s = m_form == Listing::Form::MultiPage ? scanMultiPage() : scanSlices(); !s) return s;
        if (m_pages.size() > std::numeric_limits<uint32_t>::max())
            return fail(m_path, std::to_string(m_pages.size()) + " pages are more than a volume's depth can be");
        m_info.dim = {m_first.width, m_first.height, uint32_t(m_pages.size())};
        m_info.type = m_first.type;
        m_info.format = "TIFF";
        m_info.detail = describe();
        return Status::ok();
    }

    Status readSlab(uint32_t z0, uint32_t depth, uint64_t* out) override {
        if (Status s = checkSlab(m_info, z0, depth, m_path); !s) return s;
        const uint64_t slice = uint64_t(m_info.dim[0]) * m_info.dim[1];
        for (uint32_t z = z0; z < z0 + depth; ++z)
            if (Status s = readPage(z, out + slice * (z - z0)); !s) return s;
        return Status::ok();
    }

    uint64_t workingBytes() const override { return m_block.capacity() + m_largestCompressedBlock; }

private:
    std::string pageName(uint32_t z) const {
        if (m_form == Listing::Form::MultiPage) return "page " + std::to_string(z);
        // The whole path of a listed slice: a list may span folders, and the name is all a user
        // has to find the one that differs.
        if (m_form == Listing::Form::List) return "slice " + m_files[m_pages[z].file] + " (z " + std::to_string(z) + ")";
        return "slice " + fs::path(m_files[m_pages[z].file]).filename().string() + " (z " + std::to_string(z) + ")";
    }

    /// Makes m_files[file] the open file (one at a time).
    Status openFile(uint32_t file) {
        if (m_handle.get() && m_openFile == file) return Status::ok();
        m_handle = TiffHandle();
        Result<TiffHandle> h = TiffHandle::open(m_files[file], m_maxWorkingBytes);
        if (!h) {
            const std::string what =
                m_form == Listing::Form::MultiPage
                    ? std::string("cannot be opened as TIFF")
                    : "slice " + quotedText(fs::path(m_files[file]).filename().string(), 200) + " cannot be opened as TIFF";
            return fail(m_path, what + ": " + h.message());
        }
        m_handle = std::move(*h);
        m_openFile = file;
        return Status::ok();
    }

    /// Layout of the current directory, which must match the first page's.
    Result<PageLayout> checkedLayout(uint32_t z) {
        Result<PageLayout> p = readLayout(m_handle, m_path, pageName(z));
        if (!p) return p;
        if (!m_haveFirst) { // the first page scanned is the reference
            m_first = *p;
            m_haveFirst = true;
        }
        if (std::string diff = differenceFrom(*p, m_first); !diff.empty()) return fail(m_path, pageName(z) + diff);
        if (Status s = checkBlocksInFile(*p, z); !s) return s;
        if (Status s = checkMemory(*p, z); !s) return s;
        return p;
    }

    /// Adds page z to the working memory reading needs, and refuses it when that passes the
    /// working-memory limit.
    Status checkMemory(const PageLayout& p, uint32_t z) {
        m_need.add(p);
        if (m_need.total() <= m_maxWorkingBytes) return Status::ok();
        return fail(m_path, pageName(z) + ": reading needs " + std::to_string(m_need.total()) +
                                " bytes of working memory (" + m_need.parts(p.tiled) +
                                "), more than the working-memory limit of " + std::to_string(m_maxWorkingBytes) +
                                " bytes; a file saved with smaller strips or tiles needs less");
    }

    Status scanMultiPage() {
        if (Status s = openFile(0); !s) return s;
        TIFF* tif = m_handle.get();
        std::unordered_map<uint64_t, uint32_t> pageAt; // IFD offset -> page: a chain that loops is named
        for (uint32_t z = 0;; ++z) {
            const uint64_t ifd = uint64_t(TIFFCurrentDirOffset(tif));
            pageAt.emplace(ifd, z);
            m_pages.push_back({0, ifd});
            if (Result<PageLayout> p = checkedLayout(z); !p) return p.status();
            if (TIFFLastDirectory(tif)) return Status::ok();
            uint64_t next = 0;
            if (nextIfdOffset(tif, ifd, next))
                if (const auto seen = pageAt.find(next); seen != pageAt.end())
                    return fail(m_path, "its page chain loops back to page " + std::to_string(seen->second) + " after " +
                                            std::to_string(z + 1) + (z == 0 ? " page" : " pages") + " (the IFD at offset " +
                                            std::to_string(ifd) + " names the one at offset " + std::to_string(next) +
                                            " as its next)");
            if (!TIFFReadDirectory(tif))
                return fail(m_path, "page " + std::to_string(z + 1) +
                                        " cannot be read (truncated or corrupt file?): " + m_handle.libtiffSays());
        }
    }

    Status scanSlices() {
        for (uint32_t f = 0; f < m_files.size(); ++f) {
            if (Status s = openFile(f); !s) return s;
            m_pages.push_back({f, uint64_t(TIFFCurrentDirOffset(m_handle.get()))});
            if (Result<PageLayout> p = checkedLayout(f); !p) return p.status();
            if (TIFFLastDirectory(m_handle.get())) continue;
            if (m_form == Listing::Form::List)
                return fail(m_path, pageName(f) +
                                        " has more than one page; a list of slices takes single-page (2D) TIFF files "
                                        "(a multi-page file is a volume of its own)");
            return fail(m_path, pageName(f) +
                                    " has more than one page; slices of a folder or glob must be single-page "
                                    "TIFF files (a multi-page file is opened by its own name)");
        }
        return Status::ok();
    }

    std::string describe() const {
        const std::string n = std::to_string(m_pages.size());
        switch (m_form) {
        case Listing::Form::MultiPage:
            return (m_pages.size() == 1 ? "single page" : "multi-page, " + n + " pages") + ", " + layoutText(m_first);
        case Listing::Form::Folder: return "folder of " + n + " slices, " + layoutText(m_first);
        case Listing::Form::Glob: return "glob of " + n + " slices, " + layoutText(m_first);
        case Listing::Form::List: return "list of " + n + " slices, " + layoutText(m_first);
        }
        return {};
    }

    /// Seeks page z, checks it again (the file may have changed since it was opened) and decodes
    /// it into `out` (one page, x fastest).
    Status readPage(uint32_t z, uint64_t* out) {
        const PageRef& ref = m_pages[z];
        if (Status s = openFile(ref.file); !s) return s;
        if (!TIFFSetSubDirectory(m_handle.get(), toff_t(ref.ifdOffset)))
            return fail(m_path, pageName(z) + " cannot be read: " + m_handle.libtiffSays());
        Result<PageLayout> p = checkedLayout(z);
        if (!p) return p.status();
        if (Status s = resizeOrFail(m_block, size_t(p->blockBytes()), m_path); !s) return s;
        m_largestCompressedBlock = std::max(m_largestCompressedBlock, p->largestCompressed);
        return p->tiled ? readTiles(*p, z, out) : readStrips(*p, z, out);
    }

    /// Every strip or tile must lie inside the file (a truncated file gets a message that says
    /// so) and hold no more compressed bytes than its pixels can need; sets p.largestCompressed.
    Status checkBlocksInFile(PageLayout& p, uint32_t z) {
        TIFF* tif = m_handle.get();
        const uint64_t fileBytes = m_handle.fileBytes();
        const char* kind = p.tiled ? "tile" : "strip";
        for (uint32_t b = 0; b < p.blockCount(); ++b) {
            int err = 0;
            const uint64_t offset = TIFFGetStrileOffsetWithErr(tif, b, &err);
            const uint64_t bytes = err ? 0 : TIFFGetStrileByteCountWithErr(tif, b, &err);
            if (err)
                return fail(m_path, pageName(z) + ": the position of " + kind + " " + std::to_string(b) +
                                        " cannot be read: " + m_handle.libtiffSays());
            if (offset > fileBytes || bytes > fileBytes - offset)
                return fail(m_path, pageName(z) + ": " + kind + " " + std::to_string(b) + " (bytes " +
                                        std::to_string(offset) + " to " + std::to_string(offset + bytes) +
                                        ") lies beyond the end of the file (" + std::to_string(fileBytes) +
                                        " bytes): the file is truncated (or its offsets are corrupt)");
            if (bytes > mostCompressedBytes(p))
                return fail(m_path, pageName(z) + ": " + kind + " " + std::to_string(b) + " claims " +
                                        std::to_string(bytes) + " compressed bytes for " +
                                        std::to_string(p.blockBytes()) +
                                        " decoded ones, far more than any codec writes (a corrupt or crafted header)");
            p.largestCompressed = std::max(p.largestCompressed, bytes);
        }
        return Status::ok();
    }

    Status decodeFailed(uint32_t z, const char* kind, uint32_t block, tmsize_t got, uint64_t want) {
        return fail(m_path, pageName(z) + ": " + kind + " " + std::to_string(block) + " cannot be decoded (" +
                                (got < 0 ? std::string("error")
                                         : std::to_string(got) + " of " + std::to_string(want) + " bytes") +
                                "): " + m_handle.libtiffSays());
    }

    /// Widens one row of `n` samples starting at (x, y) of page z.
    Status widenRow(const PageLayout& p, const uint8_t* src, uint64_t* page, uint32_t x, uint32_t y, uint32_t z,
                    size_t n) {
        double bad = 0;
        // libtiff hands samples over in the host's byte order.
        const size_t at = widenSamples(src, p.type, !hostIsLittleEndian(), page + uint64_t(y) * p.width + x, n, bad);
        if (at == n) return Status::ok();
        return fail(m_path, pageName(z) + ": voxel (x " + std::to_string(x + at) + ", y " + std::to_string(y) + ") " +
                                notAnIntegerLabel(bad) + " (" +
                                labelTypeName(p.type) + " voxels must hold integers within int64)");
    }

    /// Zeroes the block buffer before a decode: libtiff 4.5 may report a damaged deflate strip as
    /// decoded in full while leaving its last bytes unwritten (fuzz_tiff), which then held the
    /// previous strip's pixels, so that reading a page twice gave different values.
    void clearBlock(size_t bytes) { std::memset(m_block.data(), 0, std::min(bytes, m_block.size())); }

    Status readStrips(const PageLayout& p, uint32_t z, uint64_t* page) {
        const size_t rowBytes = size_t(p.width) * typeBytes(p.type);
        for (uint32_t s = 0; s < p.blockCount(); ++s) {
            const uint32_t y0 = s * p.rowsPerStrip;
            const uint32_t rows = std::min(p.rowsPerStrip, p.height - y0);
            const tmsize_t want = tmsize_t(rows * rowBytes);
            clearBlock(size_t(want));
            const tmsize_t got = TIFFReadEncodedStrip(m_handle.get(), s, m_block.data(), want);
            if (got != want) return decodeFailed(z, "strip", s, got, uint64_t(want));
            for (uint32_t r = 0; r < rows; ++r)
                if (Status st = widenRow(p, m_block.data() + r * rowBytes, page, 0, y0 + r, z, p.width); !st) return st;
        }
        return Status::ok();
    }

    Status readTiles(const PageLayout& p, uint32_t z, uint64_t* page) {
        const size_t tileRowBytes = size_t(p.tileWidth) * typeBytes(p.type);
        const tmsize_t want = tmsize_t(p.blockBytes());
        for (uint32_t y0 = 0; y0 < p.height; y0 += p.tileHeight) {
            for (uint32_t x0 = 0; x0 < p.width; x0 += p.tileWidth) {
                const uint32_t tile = TIFFComputeTile(m_handle.get(), x0, y0, 0, 0);
                clearBlock(size_t(want));
                const tmsize_t got = TIFFReadEncodedTile(m_handle.get(), tile, m_block.data(), want);
                if (got != want) return decodeFailed(z, "tile", tile, got, uint64_t(want));
                const uint32_t rows = std::min(p.tileHeight, p.height - y0);
                const uint32_t cols = std::min(p.tileWidth, p.width - x0);
                for (uint32_t r = 0; r < rows; ++r)
                    if (Status st = widenRow(p, m_block.data() + r * tileRowBytes, page, x0, y0 + r, z, cols); !st)
                        return st;
            }
        }
        return Status::ok();
    }

    std::string m_path;
    Listing::Form m_form;
    std::vector<std::string> m_files;
    std::vector<PageRef> m_pages;
    PageLayout m_first; ///< page 0, which every page must match
    bool m_haveFirst = false;
    uint64_t m_maxWorkingBytes;
    TiffHandle m_handle;
    uint32_t m_openFile = 0;
    std::vector<uint8_t> m_block;          ///< one decoded strip or tile
    uint64_t m_largestCompressedBlock = 0; ///< libtiff's raw buffer holds at most this (pages read)
    ReadMemory m_need;                     ///< what reading needs, over the pages checked
};

} // namespace

bool claimsTiff(const std::string& path) {
    if (path.empty()) return false;
    if (isTiffName(path) || hasWildcard(lastComponent(path))) return true;
    if (!isDir(path)) return path.back() == '/';
    std::error_code ec;
    // A folder is a TIFF stack when it holds a TIFF file, or nothing at all (then the opener says
    // it is empty); a folder of other files (a precomputed scale, say) is not claimed.
    bool otherFiles = false;
    for (fs::directory_iterator it(path, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        std::error_code statError; // a dangling link is skipped; `ec` keeps the iteration's state
        if (name.empty() || name[0] == '.' || !it->is_regular_file(statError)) continue;
        if (isTiffName(name)) return true;
        otherFiles = true;
    }
    return !otherFiles;
}

Result<std::unique_ptr<InputSource>> openTiff(const std::string& path, const InputOptions& options) {
    Result<Listing> listing = listFiles(path);
    if (!listing) return listing.status();
    auto source = std::make_unique<TiffSource>(path, std::move(*listing), options);
    if (Status s = source->scan(); !s) return s;
    return std::unique_ptr<InputSource>(std::move(source));
}

} // namespace inputs

std::string sliceListName(const std::vector<std::string>& files) {
    if (files.empty()) return "(no slices)";
    if (files.size() == 1) return files[0];
    const std::string& first = files.front();
    const std::string& last = files.back();
    const size_t a = first.find_last_of('/'), b = last.find_last_of('/');
    const std::string firstDir = a == std::string::npos ? "" : first.substr(0, a);
    const std::string lastDir = b == std::string::npos ? "" : last.substr(0, b);
    return first + " .. " + (firstDir == lastDir ? inputs::lastComponent(last) : last);
}

Result<std::unique_ptr<InputSource>> openTiffSlices(const std::vector<std::string>& files, const InputOptions& options) {
    const std::string name = sliceListName(files);
    Result<inputs::Listing> listing = inputs::listGiven(files, name);
    if (!listing) return listing.status();
    auto source = std::make_unique<inputs::TiffSource>(name, std::move(*listing), options);
    if (Status s = source->scan(); !s) return s;
    if (Status s = inputs::checkDimensions(source->info(), name); !s) return s;
    return std::unique_ptr<InputSource>(std::move(source));
}

} // namespace csgv
