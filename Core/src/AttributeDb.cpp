// SPDX-License-Identifier: MIT
#include "csgv/AttributeDb.h"

#include <cmath>
#include <limits>
#include <memory>
#include <sqlite3.h>

namespace csgv {

namespace {

struct DbCloser {
    void operator()(sqlite3* db) const { sqlite3_close(db); }
};
struct StmtCloser {
    void operator()(sqlite3_stmt* s) const { sqlite3_finalize(s); }
};
using DbPtr = std::unique_ptr<sqlite3, DbCloser>;
using StmtPtr = std::unique_ptr<sqlite3_stmt, StmtCloser>;

Result<StmtPtr> prepare(sqlite3* db, const std::string& sql) {
    sqlite3_stmt* stmt = nullptr;
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt, nullptr) != SQLITE_OK)
        return Status::error(std::string(sqlite3_errmsg(db)) + " (in: " + sql + ")");
    return StmtPtr(stmt);
}

std::string quoteIdentifier(const std::string& name) {
    std::string q = "\"";
    for (char c : name) q += (c == '"') ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
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
        if (labels[i] < 0 || labels[i] >= int64_t(0xFFFFFFFFll))
            return Status::error(path + ": id " + std::to_string(i) + " maps to label " + std::to_string(labels[i]) +
                                 ", which does not fit an unsigned 32-bit label");
        out[i] = uint32_t(labels[i]);
    }
    return out;
}

Result<AttributeDatabase> readAttributeDb(const std::string& path) {
    sqlite3* raw = nullptr;
    const int rc = sqlite3_open_v2(path.c_str(), &raw, SQLITE_OPEN_READONLY, nullptr);
    DbPtr db(raw);
    if (rc != SQLITE_OK)
        return Status::error("cannot open attribute database '" + path + "': " +
                             (raw ? sqlite3_errmsg(raw) : "out of memory"));
    AttributeDatabase out;
    out.path = path;
    auto fail = [&](const std::string& what) { return Status::error("attribute database '" + path + "': " + what); };

    Result<StmtPtr> info = prepare(db.get(), "SELECT volume_width, volume_height, volume_depth, label_column FROM csgv_info");
    if (!info) return fail(info.message());
    if (sqlite3_step(info->get()) != SQLITE_ROW) return fail("table csgv_info is empty");
    for (int a = 0; a < 3; ++a) out.volumeDim[a] = uint32_t(sqlite3_column_int64(info->get(), a));
    const unsigned char* lc = sqlite3_column_text(info->get(), 3);
    if (!lc || !*lc) return fail("csgv_info.label_column is empty");
    out.labelColumn = reinterpret_cast<const char*>(lc);

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
        out.labels.push_back(sqlite3_column_int64(st, labelCol));
        for (size_t k = 0; k < attrCols.size(); ++k) {
            const int c = attrCols[k];
            AttributeColumn& col = out.columns[k];
            const int type = sqlite3_column_type(st, c);
            const char* t = reinterpret_cast<const char*>(sqlite3_column_text(st, c));
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

} // namespace csgv
