// SPDX-License-Identifier: MIT
#include "csgv/base/MappedFile.h"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <algorithm>
#include <new>
#include <vector>

namespace csgv {

namespace {

std::string why() { return std::strerror(errno); }

/// Closes a descriptor when it goes out of scope (a mapping outlives its descriptor).
struct Descriptor {
    int fd = -1;
    ~Descriptor() {
        if (fd >= 0) ::close(fd);
    }
};

/// Reads exactly `size` bytes (a regular file that could not be mapped); an error when the file
/// ends early or a read fails.
Status readExactly(int fd, uint8_t* out, size_t size, const std::string& path) {
    size_t got = 0;
    while (got < size) {
        const ssize_t n = ::read(fd, out + got, size - got);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) return Status::error("cannot read '" + path + "': " + why());
        if (n == 0)
            return Status::error("'" + path + "' ended after " + std::to_string(got) + " of " + std::to_string(size) +
                                 " bytes while it was read");
        got += size_t(n);
    }
    return Status::ok();
}

/// Reads a stream to its end in growing chunks, refusing more than `limit` bytes.
Result<std::vector<uint8_t>> readToEnd(int fd, uint64_t limit, const std::string& path) {
    std::vector<uint8_t> bytes;
    size_t got = 0;
    for (;;) {
        if (got == bytes.size()) {
            if (got > limit) break;
            try {
                bytes.resize(std::max<size_t>(size_t(1) << 16, bytes.size() * 2));
            } catch (const std::bad_alloc&) {
                return Status::error("cannot read '" + path + "': no memory for more than " + std::to_string(got) + " bytes");
            }
        }
        const ssize_t n = ::read(fd, bytes.data() + got, bytes.size() - got);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) return Status::error("cannot read '" + path + "': " + why());
        if (n == 0) break;
        got += size_t(n);
    }
    if (got > limit)
        return Status::error("'" + path + "' holds more than the limit of " + std::to_string(limit) + " bytes");
    bytes.resize(got);
    return bytes;
}

} // namespace

MappedFile::~MappedFile() {
    if (m_mapped) ::munmap(const_cast<uint8_t*>(m_data), m_size);
}

Result<std::shared_ptr<const MappedFile>> MappedFile::open(const std::string& path, const Options& options) {
    Descriptor d;
    do d.fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    while (d.fd < 0 && errno == EINTR);
    if (d.fd < 0) return Status::error("cannot open '" + path + "': " + why());
    struct stat st {};
    if (::fstat(d.fd, &st) != 0) return Status::error("cannot open '" + path + "': " + why());

    std::shared_ptr<MappedFile> f(new MappedFile());
    f->m_path = path;
    if (S_ISREG(st.st_mode)) {
        if (uint64_t(st.st_size) > SIZE_MAX)
            return Status::error("'" + path + "' is " + std::to_string(st.st_size) + " bytes, more than this system addresses");
        const size_t size = size_t(st.st_size);
        if (size == 0) return std::shared_ptr<const MappedFile>(std::move(f)); // nothing to map
        if (!options.read) {
            void* p = ::mmap(nullptr, size, PROT_READ, MAP_SHARED, d.fd, 0);
            if (p != MAP_FAILED) {
                f->m_data = static_cast<const uint8_t*>(p);
                f->m_size = size;
                f->m_mapped = true;
                return std::shared_ptr<const MappedFile>(std::move(f));
            }
            // Some file systems cannot map (ENODEV); reading still works.
        }
        if (size > options.maxReadBytes)
            return Status::error("'" + path + "' is " + std::to_string(size) + " bytes, more than the limit of " +
                                 std::to_string(options.maxReadBytes) + " to read into memory");
        try {
            f->m_read.resize(size);
        } catch (const std::bad_alloc&) {
            return Status::error("cannot read '" + path + "': no memory for its " + std::to_string(size) + " bytes");
        }
        Status s = readExactly(d.fd, f->m_read.data(), size, path);
        if (!s) return s;
        f->m_data = f->m_read.data();
        f->m_size = size;
        return std::shared_ptr<const MappedFile>(std::move(f));
    }
    if (S_ISFIFO(st.st_mode) || S_ISCHR(st.st_mode) || S_ISSOCK(st.st_mode)) {
        Result<std::vector<uint8_t>> bytes = readToEnd(d.fd, options.maxReadBytes, path);
        if (!bytes) return bytes.status();
        f->m_read = std::move(*bytes);
        f->m_size = f->m_read.size();
        if (f->m_size) f->m_data = f->m_read.data();
        return std::shared_ptr<const MappedFile>(std::move(f));
    }
    return Status::error("'" + path + "' is not a regular file");
}

} // namespace csgv
