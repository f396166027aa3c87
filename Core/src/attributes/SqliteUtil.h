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
#include <cstring>
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
/// a view of a hostile file (`t a, t b, t c` joins) or a derived expression stops at the deadline
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

/// Seconds a file's tables or views may take to read before it is refused as hostile.
constexpr double kReadSeconds = 30;

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

} // namespace csgv::sqlite
