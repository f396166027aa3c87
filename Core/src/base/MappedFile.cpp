// SPDX-License-Identifier: MIT
#include "csgv/base/MappedFile.h"
#include "csgv/base/FileUtil.h"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <signal.h>
#include <algorithm>
#include <atomic>
#include <mutex>
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


// The SIGBUS guard. Mappings register in a fixed table the handler reads without locks (a signal
// handler may take none); registering and unregistering take a mutex.
constexpr int kSlots = 1024;
struct Slot {
    std::atomic<uintptr_t> begin{0}, end{0};
    std::atomic<bool> damaged{false};
    std::atomic<uintptr_t> firstDamaged{UINTPTR_MAX}; ///< the lowest page replaced by zeros
    std::atomic<int> fd{-1}; ///< the mapped file, open while mapped (cutShortAt asks its size)
    std::atomic<int64_t> modified{0}; ///< its modification time when mapped (ns; rewrittenAt)
};

int64_t modifiedNs(const struct stat& st) { return int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec; }
Slot g_slots[kSlots];
std::mutex g_registry;
struct sigaction g_previous {};
std::atomic<uintptr_t> g_pageSize{4096};

uintptr_t pageSize() { return g_pageSize.load(std::memory_order_relaxed); }

std::atomic<int> g_slotsUsed{0}; ///< slots below this index have been used (a lookup stops there)

int findSlot(uintptr_t a) {
    const int used = g_slotsUsed.load(std::memory_order_acquire);
    for (int i = 0; i < used; ++i) {
        const uintptr_t b = g_slots[i].begin.load(std::memory_order_acquire);
        if (b && a >= b && a < g_slots[i].end.load(std::memory_order_acquire)) return i;
    }
    return -1;
}

void onSigbus(int signal, siginfo_t* info, void* context) {
    const uintptr_t a = reinterpret_cast<uintptr_t>(info->si_addr);
    const int slot = info->si_code > 0 ? findSlot(a) : -1; // a fault, not a kill()
    if (slot >= 0) {
        // The file ended before this page: read zeros from here on (MAP_FIXED replaces the page
        // atomically; mmap is a plain system call, safe in a handler on Linux).
        void* page = reinterpret_cast<void*>(a & ~(pageSize() - 1));
        // Writable, so that a copy-on-write mapping's writers do not fault there either.
        if (::mmap(page, size_t(pageSize()), PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED, -1, 0) != MAP_FAILED) {
            uintptr_t first = g_slots[slot].firstDamaged.load(std::memory_order_relaxed);
            const uintptr_t here = reinterpret_cast<uintptr_t>(page);
            while (here < first && !g_slots[slot].firstDamaged.compare_exchange_weak(first, here)) {
            }
            g_slots[slot].damaged.store(true, std::memory_order_release);
            return; // the access is retried and reads zeros
        }
    }
    // Not ours: whatever handled SIGBUS before us.
    if ((g_previous.sa_flags & SA_SIGINFO) && g_previous.sa_sigaction) {
        g_previous.sa_sigaction(signal, info, context);
        return;
    }
    if (!(g_previous.sa_flags & SA_SIGINFO) && g_previous.sa_handler != SIG_DFL && g_previous.sa_handler != SIG_IGN) {
        g_previous.sa_handler(signal);
        return;
    }
    // The default action: restore it; a fault recurs as the instruction is retried, a kill() is
    // sent again.
    struct sigaction dfl {};
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    ::sigaction(SIGBUS, &dfl, nullptr);
    if (info->si_code <= 0) ::raise(SIGBUS);
}

/// Installs the handler unless it is in place (again, when someone replaced it since: chained to
/// theirs). Called with g_registry held.
void installGuard() {
    g_pageSize.store(uintptr_t(::sysconf(_SC_PAGESIZE)), std::memory_order_relaxed);
    struct sigaction current {};
    if (::sigaction(SIGBUS, nullptr, &current) != 0) return;
    if ((current.sa_flags & SA_SIGINFO) && current.sa_sigaction == onSigbus) return;
    struct sigaction mine {};
    mine.sa_sigaction = onSigbus;
    mine.sa_flags = SA_SIGINFO | SA_NODEFER | SA_ONSTACK;
    sigemptyset(&mine.sa_mask);
    g_previous = current;
    ::sigaction(SIGBUS, &mine, nullptr);
}

int registerMapping(const uint8_t* data, size_t size, int fd, int64_t modified) {
    std::lock_guard<std::mutex> lock(g_registry);
    installGuard();
    for (int i = 0; i < kSlots; ++i) {
        if (g_slots[i].begin.load(std::memory_order_relaxed)) continue;
        g_slots[i].damaged.store(false, std::memory_order_relaxed);
        g_slots[i].modified.store(modified, std::memory_order_relaxed);
        g_slots[i].firstDamaged.store(UINTPTR_MAX, std::memory_order_relaxed);
        g_slots[i].fd.store(fd, std::memory_order_relaxed);
        g_slots[i].end.store(reinterpret_cast<uintptr_t>(data) + size, std::memory_order_release);
        g_slots[i].begin.store(reinterpret_cast<uintptr_t>(data), std::memory_order_release);
        if (g_slotsUsed.load(std::memory_order_relaxed) <= i) g_slotsUsed.store(i + 1, std::memory_order_release);
        return i;
    }
    return -1; // more than kSlots live mappings: this one is unguarded
}

void unregisterMapping(int slot) {
    if (slot < 0) return;
    std::lock_guard<std::mutex> lock(g_registry);
    g_slots[slot].begin.store(0, std::memory_order_release);
    g_slots[slot].end.store(0, std::memory_order_release);
    g_slots[slot].fd.store(-1, std::memory_order_release);
}

/// [address, address + size) widened to whole pages and clipped to the mapping of `slot`.
bool pageRange(int slot, const void* address, size_t size, uintptr_t& begin, size_t& length) {
    if (slot < 0 || size == 0) return false;
    const uintptr_t lo = g_slots[slot].begin.load(std::memory_order_acquire), hi = g_slots[slot].end.load(std::memory_order_acquire);
    uintptr_t a = std::max(reinterpret_cast<uintptr_t>(address), lo);
    uintptr_t e = std::min(reinterpret_cast<uintptr_t>(address) + size, hi);
    if (!lo || a >= e) return false;
    a &= ~(pageSize() - 1);
    e = (e + pageSize() - 1) & ~(pageSize() - 1);
    begin = a;
    length = size_t(e - a);
    return true;
}

void adviseAt(const void* address, size_t size, int advice) {
    uintptr_t b = 0;
    size_t n = 0;
    // A range widened past the mapping's start is found by its end.
    int slot = findSlot(reinterpret_cast<uintptr_t>(address));
    if (slot < 0 && size) slot = findSlot(reinterpret_cast<uintptr_t>(address) + size - 1);
    if (pageRange(slot, address, size, b, n))
        ::madvise(reinterpret_cast<void*>(b), n, advice);
}

} // namespace

MappedFile::~MappedFile() {
    if (!m_mapped) return;
    unregisterMapping(m_slot);
    ::munmap(const_cast<uint8_t*>(m_data), m_size);
    if (m_fd >= 0) ::close(m_fd);
}

bool MappedFile::cutShortAt(const void* address, size_t size) {
    const uintptr_t a = reinterpret_cast<uintptr_t>(address);
    const int slot = findSlot(a);
    if (slot < 0) return false;
    if (damagedAt(address, size)) return true;
    const int fd = g_slots[slot].fd.load(std::memory_order_acquire);
    struct stat st {};
    if (fd < 0 || ::fstat(fd, &st) != 0) return false;
    const uintptr_t offset = a - g_slots[slot].begin.load(std::memory_order_acquire);
    return uint64_t(st.st_size) < uint64_t(offset) + size;
}

bool MappedFile::rewrittenAt(const void* address) {
    const int slot = findSlot(reinterpret_cast<uintptr_t>(address));
    if (slot < 0) return false;
    const int fd = g_slots[slot].fd.load(std::memory_order_acquire);
    struct stat st {};
    if (fd < 0 || ::fstat(fd, &st) != 0) return false;
    return modifiedNs(st) != g_slots[slot].modified.load(std::memory_order_acquire);
}

bool MappedFile::damaged() const { return m_slot >= 0 && g_slots[m_slot].damaged.load(std::memory_order_acquire); }

bool MappedFile::damagedAt(const void* address, size_t size) {
    const int slot = findSlot(reinterpret_cast<uintptr_t>(address));
    return slot >= 0 && g_slots[slot].damaged.load(std::memory_order_acquire) &&
           reinterpret_cast<uintptr_t>(address) + size > g_slots[slot].firstDamaged.load(std::memory_order_acquire);
}

bool MappedFile::mappedAt(const void* address) { return findSlot(reinterpret_cast<uintptr_t>(address)) >= 0; }



void MappedFile::releaseAt(const void* address, size_t size) { adviseAt(address, size, MADV_DONTNEED); }
void MappedFile::willNeedAt(const void* address, size_t size) { adviseAt(address, size, MADV_WILLNEED); }

size_t MappedFile::absentBytesAt(const void* address, size_t size) {
    uintptr_t b = 0;
    size_t n = 0;
    if (!pageRange(findSlot(reinterpret_cast<uintptr_t>(address)), address, size, b, n)) return 0;
    const size_t pages = n / size_t(pageSize());
    size_t absent = 0;
    std::vector<unsigned char> in(std::min<size_t>(pages, size_t(1) << 16));
    for (size_t done = 0; done < pages; done += in.size()) {
        const size_t k = std::min(in.size(), pages - done);
        if (::mincore(reinterpret_cast<void*>(b + done * pageSize()), k * size_t(pageSize()), in.data()) != 0) return 0;
        for (size_t i = 0; i < k; ++i) absent += (in[i] & 1) ? 0 : 1;
    }
    return absent * size_t(pageSize());
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
            void* p = options.copyOnWrite
                          ? ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_NORESERVE, d.fd, 0)
                          : MAP_FAILED;
            // Copy-on-write can be refused where the kernel counts it against memory
            // (overcommit_memory 2): a read-only mapping still beats reading the file.
            if (p == MAP_FAILED) p = ::mmap(nullptr, size, PROT_READ, MAP_SHARED, d.fd, 0);
            if (p != MAP_FAILED) {
                f->m_data = static_cast<const uint8_t*>(p);
                f->m_size = size;
                f->m_mapped = true;
                f->m_fd = d.fd; // kept open: cutShortAt asks the file's size
                d.fd = -1;
                f->m_slot = registerMapping(f->m_data, size, f->m_fd, modifiedNs(st));
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
    // A character device (/dev/zero, a terminal) is no file: it may never end.
    if (S_ISCHR(st.st_mode)) return Status::error("'" + path + "' is a device, not a file");
    if (S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode)) {
        // A stream has no size to check beforehand: without a limit of the caller's, at most half
        // the memory available now (1 GiB where that is unknown).
        uint64_t limit = options.maxReadBytes;
        if (limit == ~uint64_t(0)) {
            const uint64_t available = availableMemoryBytes();
            limit = available ? available / 2 : uint64_t(1) << 30;
        }
        Result<std::vector<uint8_t>> bytes = readToEnd(d.fd, limit, path);
        if (!bytes) return bytes.status();
        f->m_read = std::move(*bytes);
        f->m_size = f->m_read.size();
        if (f->m_size) f->m_data = f->m_read.data();
        return std::shared_ptr<const MappedFile>(std::move(f));
    }
    return Status::error("'" + path + "' is not a regular file");
}

} // namespace csgv
