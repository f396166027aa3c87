// SPDX-License-Identifier: MIT
#pragma once
/// @file SqliteUtil.h
/// @brief Internal to Core's attribute store: owning handles and small helpers around SQLite,
/// shared by AttributeDb.cpp (Volcanite's db3) and AttributesSqlite.cpp (tables, derived columns).

#include "csgv/base/Status.h"

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

} // namespace csgv::sqlite
