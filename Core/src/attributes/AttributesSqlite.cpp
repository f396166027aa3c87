// SPDX-License-Identifier: MIT
// The attribute store's SQLite part: tables from databases (Volcanite's included) and derived
// attributes evaluated by SQLite in memory.
#include "csgv/attributes/Attributes.h"
#include "csgv/base/FileUtil.h"
#include "AttributesInternal.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <sqlite3.h>

#include "SqliteUtil.h"

namespace csgv {

using namespace detail;

namespace {

using sqlite::DbPtr;
using sqlite::Deadline;
using sqlite::openReadOnly;
using sqlite::prepare;
using sqlite::quoteIdentifier;
using sqlite::StmtPtr;

Status exec(sqlite3* db, const std::string& sql) {
    char* err = nullptr;
    if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
        Status s = Status::error(err ? err : sqlite3_errmsg(db));
        sqlite3_free(err);
        return s;
    }
    return Status::ok();
}

/// A value as the text a CSV would hold: integers exactly, reals shortest round-trip, NULL "".
std::string cellText(sqlite3_stmt* st, int c) {
    switch (sqlite3_column_type(st, c)) {
    case SQLITE_NULL: return "";
    case SQLITE_INTEGER: return std::to_string(sqlite3_column_int64(st, c));
    case SQLITE_FLOAT: {
        const double d = sqlite3_column_double(st, c);
        return std::isnan(d) ? std::string() : formatNumber(d);
    }
    default: {
        const unsigned char* t = sqlite3_column_text(st, c);
        return t ? std::string(reinterpret_cast<const char*>(t), size_t(sqlite3_column_bytes(st, c))) : std::string();
    }
    }
}

/// Only reading the table and calling functions: a derived expression cannot change anything.
/// Allows reading only; what it refuses is named in `*denied` (a std::string), so that the error
/// says what is not allowed, not SQLite's bare "not authorized".
int readOnlyAuthorizer(void* denied, int action, const char* a, const char*, const char*, const char*) {
    if (action == SQLITE_SELECT || action == SQLITE_READ || action == SQLITE_FUNCTION) return SQLITE_OK;
    if (denied && static_cast<std::string*>(denied)->empty()) {
        std::string& why = *static_cast<std::string*>(denied);
        switch (action) {
        case SQLITE_PRAGMA: why = std::string("pragma ") + (a ? a : ""); break;
        case SQLITE_RECURSIVE: why = "a recursive query (WITH RECURSIVE)"; break;
        case SQLITE_ATTACH: case SQLITE_DETACH: why = "attaching a database"; break;
        case SQLITE_INSERT: case SQLITE_UPDATE: case SQLITE_DELETE:
            // pragma_table_info() and the like are asked as an update of sqlite_master
            why = a && std::strncmp(a, "sqlite_", 7) == 0 ? "the database schema (" + std::string(a) + ")" : "writing to a table";
            break;
        case SQLITE_TRANSACTION: case SQLITE_SAVEPOINT: why = "a transaction"; break;
        default: why = "changing the database (action " + std::to_string(action) + ")"; break;
        }
    }
    return SQLITE_DENY;
}

} // namespace

Result<AttributeTable> attributesFromDatabase(const AttributeDatabase& db) {
    const std::string source = "attribute database '" + db.path + "'";
    Result<AttributeTable> table = AttributeTable::fromLabels(db.labels);
    if (!table) return Status::error(source + ": " + table.message());
    // Rows are sorted by label; row r holds id ids[r].
    std::vector<size_t> idOfRow(db.labels.size());
    {
        std::vector<std::pair<int64_t, size_t>> keyed(db.labels.size());
        for (size_t i = 0; i < db.labels.size(); ++i) keyed[i] = {db.labels[i], i};
        std::sort(keyed.begin(), keyed.end());
        for (size_t r = 0; r < keyed.size(); ++r) idOfRow[r] = keyed[r].second;
    }
    std::vector<AttributeColumn> cols;
    AttributeColumn ids{"csgv_id", true, {}, {}};
    for (size_t r = 0; r < idOfRow.size(); ++r) ids.values.push_back(double(idOfRow[r]));
    cols.push_back(std::move(ids));
    if (!iequals(db.labelColumn, "label")) {
        AttributeColumn copy{db.labelColumn, true, {}, {}};
        for (int64_t l : table->labels()) copy.values.push_back(double(l));
        cols.push_back(std::move(copy));
    }
    for (const AttributeColumn& c : db.columns) {
        if (iequals(c.name, "label"))
            return Status::error(source + ": column '" + c.name + "' is not the label column (" + db.labelColumn +
                                 ") but 'label' is reserved for it");
        AttributeColumn out{c.name, c.numeric, {}, {}};
        for (size_t r = 0; r < idOfRow.size(); ++r) {
            if (c.numeric) out.values.push_back(c.values[idOfRow[r]]);
            else out.text.push_back(c.text[idOfRow[r]]);
        }
        cols.push_back(std::move(out));
    }
    for (AttributeColumn& c : cols) {
        Status s = table->addColumn(std::move(c));
        if (!s) return Status::error(source + ": " + s.message());
    }
    return table;
}

std::vector<AttributeColumn> columnsForIds(const AttributeTable& table, const std::vector<int64_t>& idToLabel) {
    std::vector<int64_t> rows(idToLabel.size());
    for (size_t i = 0; i < idToLabel.size(); ++i) rows[i] = table.rowOf(idToLabel[i]);
    std::vector<AttributeColumn> out;
    for (size_t c = 1; c < table.columns().size(); ++c) {
        const AttributeColumn& src = table.columns()[c];
        if (iequals(src.name, "csgv_id")) continue;
        AttributeColumn col{src.name, src.numeric, {}, {}};
        if (src.numeric) {
            col.values.resize(rows.size(), std::numeric_limits<double>::quiet_NaN());
            for (size_t i = 0; i < rows.size(); ++i)
                if (rows[i] >= 0) col.values[i] = src.values[size_t(rows[i])];
        } else {
            col.text.resize(rows.size());
            for (size_t i = 0; i < rows.size(); ++i)
                if (rows[i] >= 0) col.text[i] = src.text[size_t(rows[i])];
        }
        out.push_back(std::move(col));
    }
    return out;
}

Result<AttributeTable> readSqliteTable(const std::string& path, const std::string& table,
                                       const std::string& labelColumn) {
    std::vector<std::string> tables;
    {
        Result<DbPtr> opened = openReadOnly(path, "SQLite database '" + path + "'");
        if (!opened) return opened.status();
        DbPtr db = std::move(*opened);
        sqlite::ReadBudget budget(db.get(), path);
        Result<StmtPtr> st = prepare(db.get(), "SELECT name FROM sqlite_master WHERE type IN ('table', 'view') "
                                               "AND name NOT LIKE 'sqlite\\_%' ESCAPE '\\' ORDER BY name");
        if (!st) return Status::error("SQLite database '" + path + "': " + st.message());
        int step;
        while ((step = sqlite3_step(st->get())) == SQLITE_ROW) tables.push_back(cellText(st->get(), 0));
        if (step != SQLITE_DONE) return Status::error("SQLite database '" + path + "': " + sqlite3_errmsg(db.get()));
    }
    auto has = [&](const std::string& name) {
        for (const auto& t : tables)
            if (iequals(t, name)) return true;
        return false;
    };
    std::string chosen = table;
    if (chosen.empty()) {
        if (has("csgv_attribute")) chosen = "csgv_attribute";
        else {
            std::vector<std::string> user;
            for (const auto& t : tables)
                if (!iequals(t, "csgv_info") && !iequals(t, "csgv_label_type")) user.push_back(t);
            if (user.empty()) return Status::error("SQLite database '" + path + "' has no tables");
            if (user.size() > 1)
                return Status::error("SQLite database '" + path + "' has several tables (" + joinNames(user) +
                                     "); name the one to read");
            chosen = user[0];
        }
    } else if (!has(chosen)) {
        return Status::error("SQLite database '" + path + "' has no table '" + chosen + "' (tables: " +
                             joinNames(tables) + ")");
    }
    if (iequals(chosen, "csgv_attribute") && has("csgv_info")) {
        Result<AttributeDatabase> db = readAttributeDb(path);
        if (!db) return db.status();
        return attributesFromDatabase(*db);
    }

    Result<DbPtr> opened = openReadOnly(path, "SQLite database '" + path + "'");
    if (!opened) return opened.status();
    DbPtr db = std::move(*opened);
    sqlite::ReadBudget budget(db.get(), path); // a view may be any query
    const std::string source = "SQLite database '" + path + "', table '" + chosen + "'";
    Result<StmtPtr> st = prepare(db.get(), "SELECT * FROM " + quoteIdentifier(chosen));
    if (!st) return Status::error(source + ": " + st.message());
    std::vector<std::string> names;
    const int ncol = sqlite3_column_count(st->get());
    for (int c = 0; c < ncol; ++c) names.emplace_back(sqlite3_column_name(st->get(), c));
    std::vector<std::vector<std::string>> rows;
    int step;
    while ((step = sqlite3_step(st->get())) == SQLITE_ROW) {
        std::vector<std::string> row(static_cast<size_t>(ncol));
        for (int c = 0; c < ncol; ++c) {
            if (!budget.takeValue(st->get(), c)) return Status::error(source + ": " + budget.exceeded());
            row[size_t(c)] = cellText(st->get(), c);
        }
        rows.push_back(std::move(row));
    }
    if (step != SQLITE_DONE) {
        const std::string why = budget.exceeded();
        return Status::error(source + ": " + (why.empty() ? std::string(sqlite3_errmsg(db.get())) : why));
    }
    return buildTable(names, rows, labelColumn, source,
                      [&](size_t r) { return source + ", row " + std::to_string(r + 1); });
}

Status addDerivedAttribute(AttributeTable& table, const std::string& name, const std::string& expression,
                           bool replace, const DerivedBudget& budget) {
    const std::string what = "derived attribute '" + name + "'";
    auto fail = [&](const std::string& message) {
        return Status::error(what + ": " + message + " (expression: " + expression + ")");
    };
    if (name.empty()) return Status::error("a derived attribute needs a name (expression: " + expression + ")");
    if (iequals(name, "label")) return fail("'label' is the label itself and cannot be derived");
    if (table.hasColumn(name) && !replace) return fail("an attribute of that name already exists");

    sqlite3* raw = nullptr;
    const int rc = sqlite3_open_v2(":memory:", &raw, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
    DbPtr db(raw);
    if (rc != SQLITE_OK) return fail(std::string("cannot open an in-memory database: ") + (raw ? sqlite3_errmsg(raw) : "out of memory"));

    // Only columns the expression may name (its text mentions them, ignoring case) are copied in.
    std::string lowerExpr = expression;
    for (char& ch : lowerExpr)
        if (ch >= 'A' && ch <= 'Z') ch = char(ch - 'A' + 'a');
    std::vector<const AttributeColumn*> used;
    // The label is the key: rows come back in the table's order by it, whatever else is named rowid.
    std::string create = "CREATE TABLE t (label INTEGER PRIMARY KEY";
    for (size_t c = 1; c < table.columns().size(); ++c) {
        const AttributeColumn& col = table.columns()[c];
        std::string lower = col.name;
        for (char& ch : lower)
            if (ch >= 'A' && ch <= 'Z') ch = char(ch - 'A' + 'a');
        if (lowerExpr.find(lower) == std::string::npos && col.name.find('"') == std::string::npos) continue;
        used.push_back(&col);
        create += ", " + quoteIdentifier(col.name) + (col.numeric ? " REAL" : " TEXT");
    }
    create += ")";
    Status s = exec(db.get(), create);
    if (!s) return fail(s.message());
    s = exec(db.get(), "BEGIN");
    if (!s) return fail(s.message());
    {
        std::string insert = "INSERT INTO t VALUES (?";
        for (size_t k = 0; k < used.size(); ++k) insert += ", ?";
        insert += ")";
        Result<StmtPtr> ins = prepare(db.get(), insert);
        if (!ins) return fail(ins.message());
        sqlite3_stmt* st = ins->get();
        for (size_t r = 0; r < table.rowCount(); ++r) {
            sqlite3_reset(st);
            sqlite3_bind_int64(st, 1, table.labels()[r]);
            for (size_t k = 0; k < used.size(); ++k) {
                const AttributeColumn& col = *used[k];
                if (col.numeric) {
                    if (std::isnan(col.values[r])) sqlite3_bind_null(st, int(k) + 2);
                    else sqlite3_bind_double(st, int(k) + 2, col.values[r]);
                } else {
                    sqlite3_bind_text(st, int(k) + 2, col.text[r].c_str(), int(col.text[r].size()), SQLITE_STATIC);
                }
            }
            if (sqlite3_step(st) != SQLITE_DONE) return fail(sqlite3_errmsg(db.get()));
        }
    }
    s = exec(db.get(), "COMMIT");
    if (!s) return fail(s.message());

    std::string denied;
    sqlite3_set_authorizer(db.get(), readOnlyAuthorizer, &denied);
    Deadline deadline(db.get(), budget.seconds);
    // zeroblob(1e9), printf('%.*c', 1e9, 'x') and the like stop at this size, not at 1 GB.
    sqlite3_limit(db.get(), SQLITE_LIMIT_LENGTH, int(std::min<int64_t>(budget.valueBytes, 1 << 30)));
    const auto overBudget = [&]() -> Status {
        if (!deadline.why) return Status::ok();
        if (!std::strcmp(deadline.why, "cancelled")) return fail("cancelled");
        char seconds[32];
        std::snprintf(seconds, sizeof seconds, "%.3g", budget.seconds); // what is left of a shared budget: 9.99999 is 10
        return fail("stopped after its time budget of " + std::string(seconds) +
                    " s (an expression is evaluated once per label; a join of t with itself grows with the "
                    "label count to that power)");
    };
    const std::string sql = "SELECT (" + expression + "\n) FROM t ORDER BY label";
    sqlite3_stmt* rawSt = nullptr;
    const char* tail = nullptr;
    if (sqlite3_prepare_v2(db.get(), sql.c_str(), int(sql.size()), &rawSt, &tail) != SQLITE_OK) {
        sqlite3_finalize(rawSt);
        if (Status b = overBudget(); !b) return b;
        if (!denied.empty()) return fail(denied + " is not allowed: an expression may only read the table t");
        return fail(sqlite3_errmsg(db.get()));
    }
    StmtPtr st(rawSt);
    for (; tail && *tail; ++tail)
        if (!std::isspace(static_cast<unsigned char>(*tail)) && *tail != ';')
            return fail("only a single SQL expression is accepted");
    AttributeColumn col{name, true, {}, {}};
    std::vector<std::string> text;
    text.reserve(table.rowCount());
    col.values.reserve(table.rowCount());
    int step;
    uint64_t resultBytes = 0;
    while ((step = sqlite3_step(st.get())) == SQLITE_ROW) {
        const int type = sqlite3_column_type(st.get(), 0);
        if (type == SQLITE_TEXT || type == SQLITE_BLOB) col.numeric = false;
        if (type == SQLITE_NULL) col.values.push_back(std::numeric_limits<double>::quiet_NaN());
        else col.values.push_back(sqlite3_column_double(st.get(), 0));
        text.push_back(cellText(st.get(), 0));
        resultBytes += text.back().size() + sizeof(std::string);
        if (resultBytes > budget.resultBytes)
            return fail("its values exceed the budget of " +
                        (budget.resultBytes % (1u << 20) ? std::to_string(budget.resultBytes) + " bytes"
                                                         : std::to_string(budget.resultBytes >> 20) + " MiB") +
                        " after " +
                        std::to_string(text.size()) + " of " + std::to_string(table.rowCount()) + " labels");
    }
    if (Status b = overBudget(); !b) return b;
    if (step != SQLITE_DONE) {
        if (sqlite3_errcode(db.get()) == SQLITE_TOOBIG)
            return fail("it makes a value larger than the budget of " + std::to_string(budget.valueBytes) + " bytes");
        return fail(sqlite3_errmsg(db.get()));
    }
    if (text.size() != table.rowCount()) return fail("the expression did not give one value per label");
    if (!col.numeric) {
        col.values.clear();
        col.text = std::move(text);
    }
    s = table.addColumn(std::move(col), replace);
    if (!s) return fail(s.message());
    return Status::ok();
}

Result<AttributeTable> readAttributeFile(const std::string& path) {
    const bool sqlite = endsWithNoCase(path, ".db3") || endsWithNoCase(path, ".db") || endsWithNoCase(path, ".sqlite") ||
                        endsWithNoCase(path, ".sqlite3");
    Result<AttributeTable> t = sqlite ? readSqliteTable(path) : readCsv(path);
    if (!t && t.message().find(path) == std::string::npos) return Status(t.status()).prefix(path);
    return t;
}

Result<std::vector<int64_t>> labelsWhere(const AttributeTable& table, const std::string& condition,
                                         const DerivedBudget& budget) {
    if (condition.find_first_not_of(" \t\r\n") == std::string::npos) return Status::error("the condition is empty");
    AttributeTable t = table;
    // A name no column takes (derived columns replace: the copy's own is the answer).
    std::string name = "csgv_condition";
    while (t.column(name)) name += "_";
    if (Status s = addDerivedAttribute(t, name, condition, false, budget); !s) return s;
    const AttributeColumn* c = t.column(name);
    if (!c) return Status::error("no result column");
    if (!c->numeric) return Status::error("'" + condition + "' gives text, not a condition (true or false per label)");
    std::vector<int64_t> labels;
    for (size_t i = 0; i < t.rowCount(); ++i)
        if (!std::isnan(c->values[i]) && c->values[i] != 0) labels.push_back(t.labels()[i]);
    return labels;
}

} // namespace csgv
