// SPDX-License-Identifier: MIT
#include "csgv/attributes/AttributeDb.h"
#include "csgv/base/FileUtil.h"

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <sqlite3.h>

#include "SqliteUtil.h"

namespace csgv {

namespace {

using sqlite::DbPtr;
using sqlite::openReadOnly;
using sqlite::quoteIdentifier;
using sqlite::StmtPtr;

/// A prepared statement; errors quote the statement (the database's own schema is at fault).
Result<StmtPtr> prepare(sqlite3* db, const std::string& sql) {
    Result<StmtPtr> r = sqlite::prepare(db, sql);
    if (!r) return Status::error(r.message() + " (in: " + sql + ")");
    return r;
}

} // namespace

std::string attributeDbPathFor(const std::string& csgvPath) {
    const size_t slash = csgvPath.find_last_of('/');
    const size_t dot = csgvPath.find_last_of('.');
    const std::string stem = (dot != std::string::npos && (slash == std::string::npos || dot > slash))
                                 ? csgvPath.substr(0, dot)
                                 : csgvPath;
    return stem + "_csgv.db3";
}

const AttributeColumn* AttributeDatabase::column(const std::string& name) const {
    for (const auto& c : columns)
        if (c.name == name) return &c;
    return nullptr;
}

Result<std::vector<uint32_t>> AttributeDatabase::labelsAsUint32() const {
    std::vector<uint32_t> out(labels.size());
    for (size_t i = 0; i < labels.size(); ++i) {
        if (labelsUnsigned64 ? uint64_t(labels[i]) >= 0xFFFFFFFFull : (labels[i] < 0 || labels[i] >= int64_t(0xFFFFFFFFll)))
            return Status::error(path + ": id " + std::to_string(i) + " maps to label " +
                                 (labelsUnsigned64 ? std::to_string(uint64_t(labels[i])) : std::to_string(labels[i])) +
                                 ", which does not fit an unsigned 32-bit label");
        out[i] = uint32_t(labels[i]);
    }
    return out;
}

Result<AttributeDatabase> readAttributeDb(const std::string& path) {
    Result<DbPtr> opened = openReadOnly(path, "attribute database '" + path + "'");
    if (!opened) return opened.status();
    DbPtr db = std::move(*opened);
    sqlite::ReadBudget budget(db.get(), path);
    AttributeDatabase out;
    out.path = path;
    auto fail = [&](const std::string& what) {
        const std::string why = budget.exceeded();
        return Status::error("attribute database '" + path + "': " + (why.empty() ? what : why));
    };

    Result<StmtPtr> info = prepare(db.get(), "SELECT volume_width, volume_height, volume_depth, label_column FROM csgv_info");
    if (!info) return fail(info.message());
    if (sqlite3_step(info->get()) != SQLITE_ROW) return fail("table csgv_info is empty");
    for (int a = 0; a < 3; ++a) out.volumeDim[a] = uint32_t(sqlite3_column_int64(info->get(), a));
    const unsigned char* lc = sqlite3_column_text(info->get(), 3);
    if (!lc || !*lc) return fail("csgv_info.label_column is empty");
    out.labelColumn = reinterpret_cast<const char*>(lc);

    // Our own extra table (Volcanite ignores it): unsigned 64-bit labels are stored as their
    // int64 bit pattern, which is exactly what an unsigned reader gets back.
    Result<StmtPtr> type = prepare(db.get(), "SELECT original_type FROM csgv_label_type");
    if (type && sqlite3_step(type->get()) == SQLITE_ROW) {
        const unsigned char* t = sqlite3_column_text(type->get(), 0);
        out.labelsUnsigned64 = t && std::string(reinterpret_cast<const char*>(t)) == "uint64";
    }

    Result<StmtPtr> rows = prepare(db.get(), "SELECT * FROM csgv_attribute ORDER BY csgv_id");
    if (!rows) return fail(rows.message());
    sqlite3_stmt* st = rows->get();
    const int ncol = sqlite3_column_count(st);
    int idCol = -1, labelCol = -1;
    std::vector<int> attrCols;
    for (int c = 0; c < ncol; ++c) {
        const std::string name = sqlite3_column_name(st, c);
        if (name == "csgv_id") idCol = c;
        else if (name == out.labelColumn) labelCol = c;
        else {
            attrCols.push_back(c);
            out.columns.push_back(AttributeColumn{name, true, {}, {}});
        }
    }
    if (idCol < 0) return fail("table csgv_attribute has no column csgv_id");
    if (labelCol < 0) return fail("table csgv_attribute has no label column " + quoteIdentifier(out.labelColumn));
    int step;
    std::vector<std::vector<std::string>> text(attrCols.size());
    while ((step = sqlite3_step(st)) == SQLITE_ROW) {
        const int64_t id = sqlite3_column_int64(st, idCol);
        if (sqlite3_column_type(st, idCol) != SQLITE_INTEGER || id != int64_t(out.labels.size()))
            return fail("csgv_id values are not exactly 0.." + std::to_string(out.labels.size()) + "...: found " +
                        std::to_string(id));
        if (sqlite3_column_type(st, labelCol) != SQLITE_INTEGER)
            return fail("label of id " + std::to_string(id) + " is not an integer");
        if (!budget.take(16)) return fail("");
        out.labels.push_back(sqlite3_column_int64(st, labelCol));
        for (size_t k = 0; k < attrCols.size(); ++k) {
            const int c = attrCols[k];
            AttributeColumn& col = out.columns[k];
            const int type = sqlite3_column_type(st, c);
            const char* t = reinterpret_cast<const char*>(sqlite3_column_text(st, c));
            if (!budget.takeValue(st, c)) return fail("");
            text[k].emplace_back(t ? t : "");
            if (type == SQLITE_INTEGER || type == SQLITE_FLOAT) col.values.push_back(sqlite3_column_double(st, c));
            else if (type == SQLITE_NULL) col.values.push_back(std::numeric_limits<double>::quiet_NaN());
            else col.numeric = false;
        }
    }
    if (step != SQLITE_DONE) return fail(sqlite3_errmsg(db.get()));
    for (size_t k = 0; k < attrCols.size(); ++k) {
        if (!out.columns[k].numeric) {
            out.columns[k].values.clear();
            out.columns[k].text = std::move(text[k]);
        }
    }
    return out;
}

Status writeAttributeDb(const std::string& path, const std::array<uint32_t, 3>& dim,
                        const std::vector<uint64_t>& labelBits, bool signedLabels,
                        const std::vector<AttributeColumn>& columns, const std::string& labelColumn) {
    for (const auto& c : columns)
        if ((c.numeric ? c.values.size() : c.text.size()) != labelBits.size())
            return Status::error("attribute column '" + c.name + "' has " +
                                 std::to_string(c.numeric ? c.values.size() : c.text.size()) + " values for " +
                                 std::to_string(labelBits.size()) + " labels");
    if (Status s = replaceableOutput(path); !s) return s.prefix("cannot write attribute database");
    // SQLite writes its own file: build it under a name unique to this process and call (two
    // compressions of one input, e.g. MPI ranks, never share it) and rename, like AtomicFile.
    const std::string tmp = temporaryNameFor(path);
    sqlite3* raw = nullptr;
    const int rc = sqlite3_open_v2(tmp.c_str(), &raw, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
    DbPtr db(raw);
    auto fail = [&](const std::string& what) {
        db.reset();
        std::remove(tmp.c_str());
        return Status::error("cannot write attribute database '" + path + "': " + what);
    };
    if (rc != SQLITE_OK) return fail(raw ? sqlite3_errmsg(raw) : "out of memory");
    auto exec = [&](const std::string& sql) -> Status {
        char* err = nullptr;
        if (sqlite3_exec(db.get(), sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
            Status s = Status::error(err ? err : "unknown error");
            sqlite3_free(err);
            return s;
        }
        return Status::ok();
    };
    std::string create = "CREATE TABLE csgv_attribute (csgv_id UNSIGNED INT PRIMARY KEY, " +
                         quoteIdentifier(labelColumn) + " UNSIGNED INT UNIQUE";
    for (const auto& c : columns) create += ", " + quoteIdentifier(c.name) + (c.numeric ? " REAL" : " TEXT");
    create += ")";
    const std::string info = "INSERT INTO csgv_info VALUES (" + std::to_string(dim[0]) + ", " + std::to_string(dim[1]) +
                             ", " + std::to_string(dim[2]) + ", " + std::to_string(dim[0]) + ", " +
                             std::to_string(dim[1]) + ", " + std::to_string(dim[2]) + ", ?)";
    for (const std::string& sql :
         {std::string("PRAGMA journal_mode=OFF"), std::string("PRAGMA synchronous=OFF"), std::string("BEGIN"),
          std::string("CREATE TABLE csgv_info (volume_width INTEGER, volume_height INTEGER, volume_depth INTEGER, "
                      "chunk_width INTEGER, chunk_height INTEGER, chunk_depth INTEGER, label_column TEXT)"),
          create, std::string("CREATE TABLE csgv_label_type (original_type TEXT)"),
          std::string("INSERT INTO csgv_label_type VALUES ('") + (signedLabels ? "int64" : "uint64") + "')"}) {
        Status s = exec(sql);
        if (!s) return fail(s.message());
    }
    {
        Result<StmtPtr> st = prepare(db.get(), info);
        if (!st) return fail(st.message());
        sqlite3_bind_text(st->get(), 1, labelColumn.c_str(), -1, SQLITE_TRANSIENT);
        if (sqlite3_step(st->get()) != SQLITE_DONE) return fail(sqlite3_errmsg(db.get()));
    }
    std::string insert = "INSERT INTO csgv_attribute VALUES (?, ?";
    for (size_t k = 0; k < columns.size(); ++k) insert += ", ?";
    insert += ")";
    Result<StmtPtr> st = prepare(db.get(), insert);
    if (!st) return fail(st.message());
    for (size_t id = 0; id < labelBits.size(); ++id) {
        sqlite3_stmt* s = st->get();
        sqlite3_reset(s);
        sqlite3_bind_int64(s, 1, int64_t(id));
        sqlite3_bind_int64(s, 2, int64_t(labelBits[id]));
        for (size_t k = 0; k < columns.size(); ++k) {
            const AttributeColumn& c = columns[k];
            if (c.numeric) {
                if (std::isnan(c.values[id])) sqlite3_bind_null(s, int(k) + 3);
                else sqlite3_bind_double(s, int(k) + 3, c.values[id]);
            } else {
                sqlite3_bind_text(s, int(k) + 3, c.text[id].c_str(), -1, SQLITE_TRANSIENT);
            }
        }
        if (sqlite3_step(s) != SQLITE_DONE) return fail(sqlite3_errmsg(db.get()));
    }
    Status s = exec("COMMIT");
    if (!s) return fail(s.message());
    st = StmtPtr();
    if (sqlite3_close(db.release()) != SQLITE_OK) return fail("close failed");
    return publishTogether({{tmp, path}}); // as every output: in a hold, the temporary gone on failure
}

} // namespace csgv
