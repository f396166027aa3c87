// SPDX-License-Identifier: MIT
#pragma once
/// @file SqliteUtil.h
/// @brief Internal to Core's attribute store: owning handles and small helpers around SQLite,
/// shared by AttributeDb.cpp (Volcanite's db3) and AttributesSqlite.cpp (tables, derived columns).

#include "csgv/base/Status.h"

#include "csgv/base/Cancel.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <sys/stat.h>
#include <sqlite3.h>
#include <string>

namespace csgv::sqlite {

struct DbCloser {
    void operator()(sqlite3* db) const { sqlite3_close(db); }
};
struct StmtCloser {
    void operator()(sqlite3_stmt* s) const { sqlite3_finalize(s); }
};
using DbPtr = std::unique_ptr<sqlite3, DbCloser>;
using StmtPtr = std::unique_ptr<sqlite3_stmt, StmtCloser>;

/// Opens a database we only read (sidecars, attribute files) as an immutable URI: SQLite then
/// takes no locks and writes nothing beside it, where a plain read-only open of a WAL-mode file
/// creates `-shm` and `-wal` files next to the user's data. The path is percent-escaped, so `?`,
/// `#` and `%` in names stay part of the name. `what` names the file in the message
/// ("attribute database 'x_csgv.db3'"); a path that is not a regular file is refused first (a
/// FIFO would block, a directory gives SQLite's vaguer message).
inline Result<DbPtr> openReadOnly(const std::string& path, const std::string& what) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return Status::error("cannot open " + what + ": " + std::strerror(errno));
    if (!S_ISREG(st.st_mode)) return Status::error("cannot open " + what + ": not a regular file");
    // "file:" + "//x" would make "x" an authority: absolute paths get an empty one ("file:///x").
    std::string uri = !path.empty() && path[0] == '/' ? "file://" : "file:";
    static const char* hex = "0123456789ABCDEF";
    for (unsigned char c : path) {
        if (c == '%' || c == '?' || c == '#' || c < 0x20 || c >= 0x7f) {
            uri += '%';
            uri += hex[c >> 4];
            uri += hex[c & 15];
        } else {
            uri += char(c);
        }
    }
    uri += "?immutable=1";
    sqlite3* raw = nullptr;
    const int rc = sqlite3_open_v2(uri.c_str(), &raw, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
    DbPtr db(raw);
    if (rc != SQLITE_OK) return Status::error("cannot open " + what + ": " + (raw ? sqlite3_errmsg(raw) : "out of memory"));
    return db;
}

/// @brief A time budget for statements on one connection, through SQLite's progress handler:
/// a derived expression (`t a, t b, t c` joins) stops at the deadline
/// or at cancelRequested() (Cancel.h) instead of running for hours. Must outlive the statements.
struct Deadline {
    std::chrono::steady_clock::time_point end;
    const char* why = nullptr; ///< "time" or "cancelled" once a statement was stopped

    Deadline(sqlite3* db, double seconds)
        : end(std::chrono::steady_clock::now() + std::chrono::microseconds(int64_t(std::max(0.0, seconds) * 1e6))) {
        sqlite3_progress_handler(db, 10000, &Deadline::check, this); // about 0.1 ms of work between checks
    }
    Deadline(const Deadline&) = delete;
    Deadline& operator=(const Deadline&) = delete;

    static int check(void* arg) {
        Deadline& d = *static_cast<Deadline*>(arg);
        if (cancelRequested()) d.why = "cancelled";
        else if (std::chrono::steady_clock::now() > d.end) d.why = "time";
        return d.why ? 1 : 0;
    }
};

/// A prepared statement, or SQLite's message.
inline Result<StmtPtr> prepare(sqlite3* db, const std::string& sql) {
    sqlite3_stmt* stmt = nullptr;
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt, nullptr) != SQLITE_OK)
        return Status::error(std::string(sqlite3_errmsg(db)));
    return StmtPtr(stmt);
}

/// "name" with embedded quotes doubled: any column name is a valid identifier.
inline std::string quoteIdentifier(const std::string& name) {
    std::string q = "\"";
    for (char c : name) q += (c == '"') ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
}

/// @brief What reading a database from a file may cost, bounded by the file's size. A small file
/// can make SQLite produce far more than it holds: a view over a recursive query yields rows
/// without end (or loops without yielding any), a view's expression builds values of any size
/// (zeroblob, printf), and a column added with ALTER TABLE ... DEFAULT gives every older row a
/// value stored once in the schema. So: no single value longer than the file (SQLITE_LIMIT_LENGTH;
/// a stored value cannot be), at most 10 million plus 100 per byte of the file of SQLite's
/// virtual-machine steps (a progress handler interrupts the statement), and at most 64 MiB plus
/// 64 bytes per byte of the file of values copied out by the caller (take()); a real table stays
/// far below all three. Construct it right after opening, before preparing anything.
class ReadBudget {
public:
    ReadBudget(sqlite3* db, const std::string& path) : m_db(db) {
        std::error_code ec;
        const uint64_t fileBytes = std::filesystem::file_size(path, ec);
        const uint64_t bytes = ec ? 0 : fileBytes;
        m_maxSteps = uint64_t(10000000) + 100 * bytes;
        m_maxBytes = (uint64_t(64) << 20) + 64 * bytes;
        sqlite3_limit(db, SQLITE_LIMIT_LENGTH, int(std::min<uint64_t>(std::max<uint64_t>(bytes, 1 << 20), 1 << 30)));
        sqlite3_progress_handler(db, kStepsPerCall, onProgress, this);
    }
    ~ReadBudget() { sqlite3_progress_handler(m_db, 0, nullptr, nullptr); }
    ReadBudget(const ReadBudget&) = delete;
    ReadBudget& operator=(const ReadBudget&) = delete;

    /// Counts `bytes` of values the caller keeps; false once they exceed the bound.
    bool take(uint64_t bytes) {
        m_bytes += bytes;
        return m_bytes <= m_maxBytes;
    }
    /// Counts one value of this column of the current row (its text, or a number).
    bool takeValue(sqlite3_stmt* st, int column) {
        return take(32 + uint64_t(sqlite3_column_bytes(st, column)));
    }
    /// Why reading stopped, when a bound did (else empty).
    std::string exceeded() const {
        if (m_cancelled) return "reading it was cancelled";
        if (m_steps * kStepsPerCall > m_maxSteps)
            return "reading it took more than " + std::to_string(m_maxSteps) +
                   " SQLite steps, far more than a table of its size needs (a view that does not end?)";
        if (m_bytes > m_maxBytes)
            return "its values take more than " + std::to_string(m_maxBytes) +
                   " bytes, far more than a table of its size holds (a view, or column defaults?)";
        return {};
    }

private:
    static constexpr int kStepsPerCall = 10000;
    static int onProgress(void* self) {
        auto* b = static_cast<ReadBudget*>(self);
        if (cancelRequested()) b->m_cancelled = true;
        return b->m_cancelled || ++b->m_steps * kStepsPerCall > b->m_maxSteps ? 1 : 0;
    }
    sqlite3* m_db;
    uint64_t m_steps = 0, m_maxSteps = 0;
    uint64_t m_bytes = 0, m_maxBytes = 0;
    bool m_cancelled = false;
};

} // namespace csgv::sqlite
