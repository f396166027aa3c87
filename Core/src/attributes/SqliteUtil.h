// SPDX-License-Identifier: MIT
#pragma once
/// @file SqliteUtil.h
/// @brief Internal to Core's attribute store: owning handles and small helpers around SQLite,
/// shared by AttributeDb.cpp (Volcanite's db3) and AttributesSqlite.cpp (tables, derived columns).

#include "csgv/base/Status.h"

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <memory>
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
        return ++b->m_steps * kStepsPerCall > b->m_maxSteps ? 1 : 0;
    }
    sqlite3* m_db;
    uint64_t m_steps = 0, m_maxSteps = 0;
    uint64_t m_bytes = 0, m_maxBytes = 0;
};

} // namespace csgv::sqlite
