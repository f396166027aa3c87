// SPDX-License-Identifier: MIT
/// @file PathGuard.cpp
/// @brief Where a path that a dataset names lies (resolveInside) and opening it without blocking
/// (openRegularFile); see PathGuard.h for why.
#include "csgv/inputs/PathGuard.h"

#include "csgv/base/FileUtil.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>

namespace csgv {
namespace inputs {

namespace fs = std::filesystem;

namespace {

/// `path` made absolute, with `.`, `..` and the symbolic links of its existing part resolved.
fs::path resolved(const fs::path& path) {
    std::error_code ec;
    fs::path absolute = fs::absolute(path, ec);
    if (ec) absolute = path;
    fs::path real = fs::weakly_canonical(absolute, ec);
    // What is left after the existing part is only normalised: `missing/../..` climbs lexically.
    return (ec ? absolute : real).lexically_normal();
}

} // namespace

bool liesInside(const fs::path& inner, const fs::path& outer) {
    auto i = inner.begin();
    for (auto o = outer.begin(); o != outer.end(); ++o, ++i) {
        if (o->empty()) continue; // the empty last element of a path ending in '/'
        if (i == inner.end() || *i != *o) return false;
    }
    return true;
}

Result<std::string> resolveInside(const NamedPath& p, bool allowOutside) {
    const std::string folder = p.folder.empty() ? "." : p.folder;
    const fs::path named(p.named);
    const std::string open = named.is_absolute() || p.folder.empty() ? p.named : (fs::path(p.folder) / named).string();
    if (allowOutside) return open;
    const fs::path realFolder = resolved(folder);
    if (liesInside(resolved(open), realFolder)) return open;
    return Status::error(p.what + " '" + p.named + "' lies outside " + p.folderRole + " '" + realFolder.string() +
                         "' (" + kAllowOutsideHint + ")");
}

Result<int> openRegularFile(const std::string& path) {
    // O_NONBLOCK: opening a FIFO without a writer would otherwise wait forever; it is cleared
    // again for a regular file, where it means nothing for reads anyway.
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
    if (fd < 0) return Status::error(errnoText());
    struct stat st {};
    const bool statted = ::fstat(fd, &st) == 0;
    if (!statted || !S_ISREG(st.st_mode)) {
        const std::string why = !statted ? errnoText() : "is " + fileKind(st.st_mode) + ", not a regular file";
        ::close(fd);
        return Status::error(why);
    }
    const int flags = ::fcntl(fd, F_GETFL);
    if (flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
    return fd;
}

} // namespace inputs
} // namespace csgv
