// SPDX-License-Identifier: MIT
#include "csgv/base/FileUtil.h"

#include <cctype>
#include <cstring>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

namespace csgv {

namespace {
std::string errnoText() { return std::strerror(errno); }
std::atomic<unsigned> g_tmpCounter{0};
} // namespace

AtomicFile::~AtomicFile() { discard(); }

Status AtomicFile::open(const std::string& path) {
    discard();
    m_path = path;
    m_tmp = path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(g_tmpCounter++);
    m_file = std::fopen(m_tmp.c_str(), "wb");
    if (!m_file) {
        Status s = Status::error("cannot create '" + m_tmp + "': " + errnoText());
        m_tmp.clear();
        return s;
    }
    return Status::ok();
}

Status AtomicFile::write(const void* data, size_t bytes) {
    if (!m_file) return Status::error("write to a file that is not open");
    if (bytes && std::fwrite(data, 1, bytes, m_file) != bytes)
        return Status::error("cannot write '" + m_tmp + "': " + errnoText());
    return Status::ok();
}

Status AtomicFile::commit() {
    if (!m_file) return Status::error("commit of a file that is not open");
    bool good = std::fflush(m_file) == 0 && ::fsync(fileno(m_file)) == 0;
    std::string why = good ? "" : errnoText();
    good = (std::fclose(m_file) == 0) && good;
    m_file = nullptr;
    if (!good) {
        std::remove(m_tmp.c_str());
        m_tmp.clear();
        return Status::error("cannot write '" + m_path + "': " + (why.empty() ? errnoText() : why));
    }
    if (std::rename(m_tmp.c_str(), m_path.c_str()) != 0) {
        Status s = Status::error("cannot rename '" + m_tmp + "' to '" + m_path + "': " + errnoText());
        std::remove(m_tmp.c_str());
        m_tmp.clear();
        return s;
    }
    m_tmp.clear();
    return Status::ok();
}

void AtomicFile::discard() {
    if (m_file) {
        std::fclose(m_file);
        m_file = nullptr;
    }
    if (!m_tmp.empty()) {
        std::remove(m_tmp.c_str());
        m_tmp.clear();
    }
}

bool fileExists(const std::string& path) {
    struct stat st {};
    return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

Result<uint64_t> fileSize(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return Status::error("cannot open '" + path + "': " + errnoText());
    if (!S_ISREG(st.st_mode)) return Status::error("'" + path + "' is not a regular file");
    return uint64_t(st.st_size);
}

Result<std::vector<uint8_t>> readFile(const std::string& path, uint64_t maxBytes) {
    Result<uint64_t> size = fileSize(path);
    if (!size) return size.status();
    if (*size > maxBytes)
        return Status::error("'" + path + "' is " + std::to_string(*size) + " bytes, more than the limit of " +
                             std::to_string(maxBytes));
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return Status::error("cannot open '" + path + "': " + errnoText());
    std::vector<uint8_t> data(static_cast<size_t>(size.value()));
    const size_t got = data.empty() ? 0 : std::fread(data.data(), 1, data.size(), f);
    std::fclose(f);
    if (got != data.size()) return Status::error("cannot read '" + path + "': short read");
    return data;
}

Result<std::vector<uint8_t>> readFileMaybeGz(const std::string& path, uint64_t maxBytes) {
    const bool gz = path.size() > 3 && path[path.size() - 3] == '.' && (path[path.size() - 2] | 0x20) == 'g' &&
                    (path[path.size() - 1] | 0x20) == 'z';
    if (!gz) return readFile(path, maxBytes);
    if (!fileExists(path)) return Status::error("cannot open '" + path + "': no such file");
    gzFile f = gzopen(path.c_str(), "rb");
    if (!f) return Status::error("cannot open '" + path + "'");
    std::vector<uint8_t> data;
    std::vector<uint8_t> chunk(1 << 20);
    for (;;) {
        const int n = gzread(f, chunk.data(), unsigned(chunk.size()));
        if (n < 0) {
            int code = 0;
            std::string why = gzerror(f, &code);
            gzclose(f);
            return Status::error("cannot inflate '" + path + "': " + why);
        }
        if (n == 0) break;
        if (data.size() + size_t(n) > maxBytes) {
            gzclose(f);
            return Status::error("'" + path + "' inflates to more than the limit of " + std::to_string(maxBytes) +
                                 " bytes");
        }
        data.insert(data.end(), chunk.begin(), chunk.begin() + n);
    }
    gzclose(f);
    return data;
}

bool endsWithNoCase(const std::string& s, const char* suffix) {
    const size_t n = std::strlen(suffix);
    if (s.size() < n) return false;
    for (size_t i = 0; i < n; ++i)
        if (std::tolower(static_cast<unsigned char>(s[s.size() - n + i])) != suffix[i]) return false;
    return true;
}

} // namespace csgv
