// SPDX-License-Identifier: MIT
#include "csgv/base/FileUtil.h"
#include "csgv/base/Cancel.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <mutex>
#include <csignal>
#include <dlfcn.h>
#include <pthread.h>
#include <ctime>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

namespace csgv {

std::string errnoText() { return std::strerror(errno); }

std::string mebibytes(uint64_t bytes) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f MiB", double(bytes) / (1 << 20));
    return text;
}

bool seekTo(std::FILE* f, uint64_t offset) { return fseeko(f, off_t(offset), SEEK_SET) == 0; }

namespace {
std::atomic<unsigned> g_tmpCounter{0};
std::atomic<bool> g_cancel{false};
static_assert(std::atomic<bool>::is_always_lock_free, "requestCancel must be async-signal-safe");

/// The temporaries of this process (a few per command: the list is never trimmed).
struct Temporaries {
    std::mutex mutex;
    std::vector<std::string> paths;
};
Temporaries& temporaries() {
    static Temporaries* t = new Temporaries; // never destroyed: a watchdog may use it at exit
    return *t;
}
} // namespace

void requestCancel() noexcept { g_cancel.store(true, std::memory_order_relaxed); }
bool cancelRequested() noexcept { return g_cancel.load(std::memory_order_relaxed); }
void resetCancel() noexcept { g_cancel.store(false, std::memory_order_relaxed); }

void registerTemporary(const std::string& path) {
    Temporaries& t = temporaries();
    std::lock_guard<std::mutex> lock(t.mutex);
    t.paths.push_back(path);
}

namespace {
/// Unlinks each remembered temporary and SQLite's `-journal` beside it; the caller holds the
/// list's lock. Nothing here allocates: a signal handler calls it too (the signal may have come
/// inside malloc).
void unlinkTemporaries(const Temporaries& t) {
    for (const std::string& p : t.paths) {
        ::unlink(p.c_str());
        char journal[4096];
        if (p.size() + sizeof "-journal" <= sizeof journal) {
            std::memcpy(journal, p.data(), p.size());
            std::memcpy(journal + p.size(), "-journal", sizeof "-journal");
            ::unlink(journal);
        }
    }
}
} // namespace

void removeTemporaries() {
    Temporaries& t = temporaries();
    // The interrupted thread may hold the lock for a moment; never wait on it for long.
    std::unique_lock<std::mutex> lock(t.mutex, std::defer_lock);
    for (int i = 0; i < 100 && !lock.try_lock(); ++i) ::usleep(1000);
    if (lock.owns_lock()) unlinkTemporaries(t);
}

namespace {
std::mutex& publishingMutex() {
    static std::mutex* publishing = new std::mutex; // never destroyed: a watchdog may hold it at exit
    return *publishing;
}

/// SIGHUP too: a terminal closed under pvpython (or an ssh session lost) ends it by default, and
/// that left the writer's temporaries as an interrupt did.
constexpr int kCleanedSignals[] = {SIGINT, SIGTERM, SIGHUP};
constexpr int kCleaned = int(std::size(kCleanedSignals));
const char* const kCleanedNames[kCleaned] = {"SIGINT", "SIGTERM", "SIGHUP"};
struct sigaction g_previousActions[kCleaned];
/// Whether the previous handler lies in a library named after loguru (VTK's logger, ParaView
/// 5.11's SIGINT and SIGTERM handler): it prints a stack trace, and its symbols come from malloc
/// inside the handler, which hung pvpython for good when the signal came inside malloc or free
/// (an attack pass: 4 of 42 interrupts about a SaveData's end, 1 of 16 without the plugin).
bool g_previousPrintsStacks[kCleaned] = {};

/// The signal's place in kCleanedSignals (only those reach cleanOnSignal).
int cleanedIndex(int sig) {
    int i = 0;
    while (i + 1 < kCleaned && kCleanedSignals[i] != sig) ++i;
    return i;
}

/// Ends the process by the signal's default action, here and now (it is blocked in its handler:
/// raised, it is pending until unblocked), so the caller's locks are held until the end.
void endByDefaultAction(int sig) {
    ::signal(sig, SIG_DFL);
    ::raise(sig);
    sigset_t only;
    sigemptyset(&only);
    sigaddset(&only, sig);
    ::pthread_sigmask(SIG_UNBLOCK, &only, nullptr);
}

/// removeTemporaries from a signal handler, then the host's own handling of the signal. A set
/// being published is given up to 500 ms (its renames take microseconds, on a slow file system
/// longer; the thread publishing takes no such signal: PublishingHold), and the list is read
/// only when its lock is free at once. Nothing here allocates (unlinkTemporaries).
void cleanOnSignal(int sig, siginfo_t* info, void* context) {
    std::unique_lock<std::mutex> publishing(publishingMutex(), std::defer_lock);
    for (int i = 0; i < 500 && !publishing.try_lock(); ++i) {
        const struct timespec ms {0, 1000000};
        ::nanosleep(&ms, nullptr);
    }
    if (publishing.owns_lock()) {
        Temporaries& t = temporaries();
        std::unique_lock<std::mutex> lock(t.mutex, std::try_to_lock);
        if (lock.owns_lock()) unlinkTemporaries(t);
    }
    // The host's handling, with the publishing lock still held: no set starts its renames while
    // the process ends. A handler that returns (Python's, which raises KeyboardInterrupt later)
    // lets the process go on, and the lock is given back.
    const int which = cleanedIndex(sig);
    const struct sigaction& previous = g_previousActions[which];
    if (g_previousPrintsStacks[which]) { // its stack trace could hang the process: ended as it would end it
        // One line in three writes (nothing allocates here).
        static const char kRest[] = ": ended (temporary files removed; no stack trace: it can hang in a signal handler)\n";
        for (const char* part : {"CSGV: ", kCleanedNames[which], kRest})
            if (::write(2, part, std::strlen(part)) < 0) break; // nothing more to be done about stderr
        endByDefaultAction(sig);
    } else if ((previous.sa_flags & SA_SIGINFO) != 0) {
        if (previous.sa_sigaction) previous.sa_sigaction(sig, info, context);
    } else if (previous.sa_handler == SIG_DFL) {
        endByDefaultAction(sig);
    } else if (previous.sa_handler != SIG_IGN) {
        previous.sa_handler(sig);
    }
}
} // namespace

bool signalIgnored(int sig) {
    struct sigaction current {};
    return ::sigaction(sig, nullptr, &current) == 0 && (current.sa_flags & SA_SIGINFO) == 0 &&
           current.sa_handler == SIG_IGN;
}

void removeTemporariesOnSignals() {
    static std::once_flag once;
    std::call_once(once, [] {
        for (int i = 0; i < kCleaned; ++i) {
            struct sigaction current {};
            // An ignored signal stays ignored (a background job's SIGINT): nothing ends the process.
            if (signalIgnored(kCleanedSignals[i]) || ::sigaction(kCleanedSignals[i], nullptr, &current) != 0) continue;
            Dl_info where {};
            void* const handler = (current.sa_flags & SA_SIGINFO) != 0 ? reinterpret_cast<void*>(current.sa_sigaction)
                                                                       : reinterpret_cast<void*>(current.sa_handler);
            g_previousPrintsStacks[i] = handler != nullptr && handler != reinterpret_cast<void*>(SIG_DFL) &&
                                        ::dladdr(handler, &where) != 0 && where.dli_fname != nullptr &&
                                        std::strstr(where.dli_fname, "loguru") != nullptr;
            struct sigaction ours {};
            ours.sa_sigaction = cleanOnSignal;
            ours.sa_flags = SA_SIGINFO | SA_RESTART;
            sigemptyset(&ours.sa_mask); // one cleaning at a time: SIGTERM during SIGINT's waits for it
            for (int sig : kCleanedSignals) sigaddset(&ours.sa_mask, sig);
            ::sigaction(kCleanedSignals[i], &ours, &g_previousActions[i]);
        }
    });
}

PublishingHold::SignalBlock::SignalBlock() {
    sigset_t block, before;
    sigemptyset(&block);
    sigemptyset(&added);
    for (int sig : kCleanedSignals) sigaddset(&block, sig);
    ::pthread_sigmask(SIG_BLOCK, &block, &before);
    for (int sig : kCleanedSignals)
        if (!sigismember(&before, sig)) sigaddset(&added, sig);
}

PublishingHold::SignalBlock::~SignalBlock() { ::pthread_sigmask(SIG_UNBLOCK, &added, nullptr); }

PublishingHold::PublishingHold() : m_lock(publishingMutex()) {}

PublishingHold holdPublishing() { return PublishingHold(); }

FolderLocks::FolderLocks(const std::vector<std::string>& paths) {
    std::vector<std::string> folders;
    for (const std::string& p : paths) {
        const size_t slash = p.find_last_of('/');
        folders.push_back(slash == std::string::npos ? "." : slash == 0 ? "/" : p.substr(0, slash));
    }
    std::sort(folders.begin(), folders.end()); // one order for every process: no deadlock
    folders.erase(std::unique(folders.begin(), folders.end()), folders.end());
    for (const std::string& folder : folders) {
        const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (fd < 0) continue;
        bool locked = false;
        for (int i = 0; i < 2000; ++i) { // another process's renames take microseconds
            if (::flock(fd, LOCK_EX | LOCK_NB) == 0) {
                locked = true;
                break;
            }
            if (errno != EWOULDBLOCK && errno != EINTR) break; // no flock here: on without it
            ::usleep(1000);
        }
        if (locked) m_fds.push_back(fd);
        else ::close(fd);
    }
}

FolderLocks::~FolderLocks() {
    for (auto fd = m_fds.rbegin(); fd != m_fds.rend(); ++fd) ::close(*fd); // closing gives the lock back
}

Status interruptedBeforePublishing() {
    return cancelRequested() ? Status::error("interrupted: nothing written") : Status::ok();
}

std::string temporaryNameFor(const std::string& path) {
    std::string name = path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(g_tmpCounter++);
    registerTemporary(name);
    return name;
}

std::string renamedInMessage(std::string message, const std::string& from, const std::string& to) {
    for (size_t at = message.find(from); at != std::string::npos; at = message.find(from, at + to.size()))
        message.replace(at, from.size(), to);
    return message;
}

Status replaceableOutput(const std::string& path) {
    struct stat st {};
    if (::lstat(path.c_str(), &st) != 0) return Status::ok(); // nothing there (or a folder we cannot see into: the write says so)
    if (S_ISLNK(st.st_mode))
        return Status::error("'" + path + "' is a symbolic link: an output would replace the link, not the file it " +
                             "points to; give the file's own name");
    if (!S_ISREG(st.st_mode))
        return Status::error("'" + path + "' is " + fileKind(st.st_mode) + ", not a file: an output never replaces it");
    // No write bit at all protects a file from root too (as rm asks before removing it).
    if ((st.st_mode & (S_IWUSR | S_IWGRP | S_IWOTH)) == 0 || (::access(path.c_str(), W_OK) != 0 && errno == EACCES))
        return Status::error("'" + path + "' is write-protected: an output does not replace it (make it writable, or " +
                             "choose another name)");
    return Status::ok();
}

void keepModeOf(const std::string& target, const std::string& tmp) {
    struct stat st {};
    if (::lstat(target.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return;
    if (::chown(tmp.c_str(), uid_t(-1), st.st_gid) != 0) {
        // Not a member of the group: the new file keeps the user's own.
    }
    ::chmod(tmp.c_str(), st.st_mode & 07777);
}

Status publishTogether(const std::vector<std::pair<std::string, std::string>>& written) {
    const PublishingHold publishing = holdPublishing();
    std::vector<std::string> targets;
    for (const auto& w : written) targets.push_back(w.second);
    const FolderLocks folders(targets);
    Status s = interruptedBeforePublishing();
    for (const auto& [tmp, target] : written)
        if (s) s = replaceableOutput(target);
    size_t done = 0;
    for (; s && done < written.size(); ++done) {
        const auto& [tmp, target] = written[done];
        keepModeOf(target, tmp);
        if (std::rename(tmp.c_str(), target.c_str()) != 0)
            s = Status::error("cannot rename '" + tmp + "' to '" + target + "': " + errnoText());
    }
    if (s) return s;
    std::string replaced;
    for (size_t i = 0; i < written.size(); ++i) {
        if (i + 1 < done) replaced += (replaced.empty() ? "" : ", ") + ("'" + written[i].second + "'");
        else std::remove(written[i].first.c_str());
    }
    return replaced.empty() ? s : Status::error(s.message() + " (already replaced: " + replaced + ")");
}

AtomicFile::~AtomicFile() { discard(); }

Status AtomicFile::open(const std::string& path) {
    discard();
    if (Status s = replaceableOutput(path); !s) return s;
    m_path = path;
    m_tmp = temporaryNameFor(path);
    m_file = std::fopen(m_tmp.c_str(), "wb");
    if (!m_file) {
        Status s = Status::error("cannot create '" + path + "': " + errnoText() + " (writing its temporary '" + m_tmp + "')");
        m_tmp.clear();
        return s;
    }
    return Status::ok();
}

Status AtomicFile::write(const void* data, size_t bytes) {
    if (!m_file) return Status::error("write to a file that is not open");
    // In pieces: one write() of a whole decoded volume holds the file's inode for its duration,
    // and an interrupt watchdog's unlink of the temporary waits for it (csgv decompress of a
    // 1 GiB volume ended 0.8-3 s after Ctrl-C, the unlink waiting for the write).
    constexpr size_t kPiece = size_t(8) << 20;
    const char* at = static_cast<const char*>(data);
    for (size_t done = 0; done < bytes;) {
        // The tool's Ctrl-C between pieces: the caller gives up (the temporary is removed with the
        // object) in milliseconds, not at the watchdog's deadline.
        if (cancelRequested()) return Status::error("writing '" + m_path + "' cancelled");
        const size_t n = std::min(kPiece, bytes - done);
        if (std::fwrite(at + done, 1, n, m_file) != n) return Status::error("cannot write '" + m_tmp + "': " + errnoText());
        done += n;
    }
    return Status::ok();
}

Status AtomicFile::commit() {
    if (!m_file) return Status::error("commit of a file that is not open");
    if (cancelRequested()) return Status::error("writing '" + m_path + "' cancelled"); // before an fsync of gigabytes
    bool good = std::fflush(m_file) == 0 && ::fsync(fileno(m_file)) == 0;
    std::string why = good ? "" : errnoText();
    good = (std::fclose(m_file) == 0) && good;
    m_file = nullptr;
    if (!good) {
        std::remove(m_tmp.c_str());
        m_tmp.clear();
        return Status::error("cannot write '" + m_path + "': " + (why.empty() ? errnoText() : why));
    }
    // What the name holds may have changed while the file was written (publishTogether checks it
    // again, and removes the temporary where it is not renamed).
    const Status s = publishTogether({{m_tmp, m_path}});
    m_tmp.clear();
    return s;
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

uint64_t availableMemoryBytes() {
    std::FILE* f = std::fopen("/proc/meminfo", "r");
    if (!f) return 0;
    char line[256];
    unsigned long long kib = 0;
    while (std::fgets(line, sizeof line, f))
        if (std::sscanf(line, "MemAvailable: %llu kB", &kib) == 1) break;
    std::fclose(f);
    return uint64_t(kib) * 1024;
}

bool existsButNotRegular(const std::string& path) {
    struct stat st {};
    return ::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode);
}

std::string fileKind(unsigned mode) {
    if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
    if (S_ISDIR(mode)) return "a folder";
    if (S_ISSOCK(mode)) return "a socket";
    if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device";
    return "not a regular file";
}

std::string notRegularFile(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0) return S_ISREG(st.st_mode) ? std::string() : fileKind(st.st_mode);
    if (::lstat(path.c_str(), &st) == 0 && S_ISLNK(st.st_mode)) return "a dangling symbolic link";
    return "missing";
}

Status regularFile(const std::string& path) {
    const std::string kind = notRegularFile(path);
    if (kind.empty()) return Status::ok();
    if (kind == "missing") return Status::error("cannot open '" + path + "': no such file");
    return Status::error("'" + path + "' is " + kind + ", not a file");
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

struct InputStream::Zlib {
    z_stream stream{};
};

InputStream::InputStream() = default;

InputStream::~InputStream() {
    if (m_zlib) inflateEnd(&m_zlib->stream);
    if (m_file && m_ownsFile) std::fclose(m_file);
}

Status InputStream::fail(Failure f, const std::string& why) {
    m_failure = f;
    return Status::error(why);
}

Status InputStream::open(const std::string& path, Mode mode, uint64_t offset) {
    m_path = path;
    m_file = std::fopen(path.c_str(), "rb");
    if (!m_file) return fail(Failure::Open, errnoText());
    m_ownsFile = true;
    if (!seekTo(m_file, offset)) return fail(Failure::Open, errnoText());
    return start(mode);
}

Status InputStream::attach(std::FILE* file, const std::string& path, Mode mode) {
    m_path = path;
    m_file = file;
    m_ownsFile = false;
    return start(mode);
}

Status InputStream::start(Mode mode) {
    struct stat st {};
    if (::fstat(fileno(m_file), &st) == 0 && S_ISREG(st.st_mode)) m_fileBytes = uint64_t(st.st_size);
    m_in.resize(size_t(1) << 18);
    m_autoMode = mode == Mode::Auto;
    if (mode == Mode::Auto) {
        // Like gzopen: the gzip magic decides, anything else is passed through.
        while (m_inEnd - m_inAt < 2) {
            Result<bool> more = fill();
            if (!more) return more.status();
            if (!*more) break;
        }
        m_inflating = m_inEnd - m_inAt >= 2 && m_in[m_inAt] == 0x1f && m_in[m_inAt + 1] == 0x8b;
    } else {
        m_inflating = mode == Mode::Inflate;
    }
    if (!m_inflating) return Status::ok();
    m_zlib = std::make_unique<Zlib>();
    // 15 + 32: a 32 KiB window, gzip or zlib header detected.
    if (inflateInit2(&m_zlib->stream, 15 + 32) != Z_OK) {
        m_zlib.reset();
        return fail(Failure::Open, "cannot start zlib for '" + m_path + "'");
    }
    return Status::ok();
}

Result<bool> InputStream::fill() {
    if (m_inputEnded) return false;
    if (m_inAt > 0) {
        std::memmove(m_in.data(), m_in.data() + m_inAt, m_inEnd - m_inAt);
        m_inEnd -= m_inAt;
        m_inAt = 0;
    }
    const size_t got = std::fread(m_in.data() + m_inEnd, 1, m_in.size() - m_inEnd, m_file);
    if (got == 0) {
        if (std::ferror(m_file)) return fail(Failure::Read, errnoText());
        m_inputEnded = true;
        return false;
    }
    m_inEnd += got;
    return true;
}

Result<size_t> InputStream::inflateSome(uint8_t* out, size_t bytes) {
    z_stream& z = m_zlib->stream;
    size_t got = 0;
    while (got < bytes && !m_finished && !(m_stopAtMemberEnd && m_memberEnded)) {
        if (m_memberEnded) {
            // A further gzip member may follow; in Auto mode, as gzread, anything else after a
            // member is trailing garbage and ends the content.
            while (m_inEnd - m_inAt < 2) {
                Result<bool> more = fill();
                if (!more) return more.status();
                if (!*more) break;
            }
            if (m_inEnd == m_inAt ||
                (m_autoMode && !(m_inEnd - m_inAt >= 2 && m_in[m_inAt] == 0x1f && m_in[m_inAt + 1] == 0x8b))) {
                m_finished = true;
                break;
            }
            inflateReset(&z);
            m_memberEnded = false;
        }
        if (m_inAt == m_inEnd) {
            Result<bool> more = fill();
            if (!more) return more.status();
            // At the end of the file inflate still runs: its bit buffer may hold more output.
        }
        z.next_in = m_in.data() + m_inAt;
        z.avail_in = uInt(m_inEnd - m_inAt);
        const size_t room = std::min<size_t>(bytes - got, size_t(1) << 30);
        z.next_out = out + got;
        z.avail_out = uInt(room);
        const int ret = inflate(&z, Z_NO_FLUSH);
        got += room - z.avail_out;
        m_inAt = m_inEnd - z.avail_in;
        if (ret == Z_STREAM_END) {
            m_memberEnded = true;
            continue;
        }
        if (ret == Z_BUF_ERROR) {
            // No progress without more input: at the end of the file the stream was cut inside a
            // member, and the caller sees a short read (as gzread reports it).
            if (m_inAt == m_inEnd && m_inputEnded) m_finished = true;
            continue;
        }
        if (ret != Z_OK)
            return fail(Failure::Corrupt, z.msg ? std::string(z.msg) : "zlib error " + std::to_string(ret));
    }
    return got;
}

Result<size_t> InputStream::read(void* out, size_t bytes) {
    if (!m_file) return fail(Failure::Read, "stream not open");
    auto* dst = static_cast<uint8_t*>(out);
    size_t got = 0;
    if (m_inflating) {
        Result<size_t> n = inflateSome(dst, bytes);
        if (!n) return n.status();
        got = *n;
    } else {
        const size_t buffered = std::min(bytes, m_inEnd - m_inAt);
        if (buffered) std::memcpy(dst, m_in.data() + m_inAt, buffered);
        m_inAt += buffered;
        got = buffered;
        if (got < bytes && !m_inputEnded) {
            // Large plain reads go straight into the caller's memory.
            got += std::fread(dst + got, 1, bytes - got, m_file);
            if (got < bytes) {
                if (std::ferror(m_file)) return fail(Failure::Read, errnoText());
                m_inputEnded = true;
            }
        }
    }
    m_position += got;
    return got;
}

uint64_t InputStream::remainingBound() const {
    if (!m_file) return 0;
    const int64_t at = int64_t(ftello(m_file));
    const uint64_t consumed = at < 0 ? 0 : uint64_t(at) - (m_inEnd - m_inAt);
    const uint64_t left = m_fileBytes > consumed ? m_fileBytes - consumed : 0;
    if (!m_inflating) return left;
    return left > (UINT64_MAX - 1024) / 1032 ? UINT64_MAX : left * 1032 + 1024;
}

Status InputStream::checkMemberEnd() {
    if (!m_inflating) return Status::ok();
    std::vector<uint8_t> scratch(size_t(1) << 16);
    m_stopAtMemberEnd = true;
    Status status;
    while (!m_memberEnded && !m_finished) {
        Result<size_t> n = inflateSome(scratch.data(), scratch.size());
        if (!n) {
            status = n.status();
            break;
        }
    }
    m_stopAtMemberEnd = false;
    return status; // a member cut before its checksum is not an error, as for gzread
}

Result<uint64_t> InputStream::skip(uint64_t bytes) {
    std::vector<uint8_t> scratch(size_t(std::min<uint64_t>(bytes, 1 << 16)));
    uint64_t skipped = 0;
    while (skipped < bytes) {
        Result<size_t> n = read(scratch.data(), size_t(std::min<uint64_t>(scratch.size(), bytes - skipped)));
        if (!n) return n.status();
        if (*n == 0) break;
        skipped += *n;
    }
    return skipped;
}

Result<std::vector<uint8_t>> readFileMaybeGz(const std::string& path, uint64_t maxBytes) {
    if (!endsWithNoCase(path, ".gz")) return readFile(path, maxBytes);
    if (Status s = regularFile(path); !s) return s;
    InputStream in;
    if (Status s = in.open(path); !s) {
        if (in.failure() == InputStream::Failure::Open) return Status::error("cannot open '" + path + "'");
        return Status::error("cannot inflate '" + path + "': " + path + ": " + s.message());
    }
    std::vector<uint8_t> data;
    for (;;) {
        const size_t old = data.size();
        data.resize(old + (size_t(1) << 20));
        Result<size_t> n = in.read(data.data() + old, size_t(1) << 20);
        if (!n) return Status::error("cannot inflate '" + path + "': " + path + ": " + n.status().message());
        data.resize(old + *n);
        if (*n == 0) break;
        if (data.size() > maxBytes)
            return Status::error("'" + path + "' inflates to more than the limit of " + std::to_string(maxBytes) +
                                 " bytes");
    }
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
