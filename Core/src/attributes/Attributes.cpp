// SPDX-License-Identifier: MIT
// The attribute table and its text import (CSV, whitespace-separated tables).
#include "csgv/attributes/Attributes.h"
#include "AttributesInternal.h"
#include "csgv/base/FileUtil.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

namespace csgv {

namespace detail {

bool iequals(const std::string& a, const std::string& b) {
    if (a.size() != b.size()) return false;
    for (size_t i = 0; i < a.size(); ++i) {
        char x = a[i], y = b[i];
        if (x >= 'A' && x <= 'Z') x = char(x - 'A' + 'a');
        if (y >= 'A' && y <= 'Z') y = char(y - 'A' + 'a');
        if (x != y) return false;
    }
    return true;
}

bool parseNumber(const std::string& text, double& value) {
    const char* b = text.data();
    const char* e = b + text.size();
    if (b != e && *b == '+') ++b;
    if (b == e) return false;
    const auto r = std::from_chars(b, e, value);
    return r.ec == std::errc() && r.ptr == e;
}

bool isMissing(const std::string& text) { return text.empty() || text == "NA"; }

bool parseLabel(const std::string& text, int64_t& label) {
    const char* b = text.data();
    const char* e = b + text.size();
    if (b != e && *b == '+') ++b;
    if (b == e) return false;
    auto r = std::from_chars(b, e, label);
    if (r.ec == std::errc() && r.ptr == e) return true;
    uint64_t u = 0; // unsigned 64-bit labels beyond int64: kept as their bits
    r = std::from_chars(b, e, u);
    if (r.ec == std::errc() && r.ptr == e && b == text.data()) {
        label = int64_t(u);
        return true;
    }
    double d = 0;
    if (!parseNumber(text, d) || !std::isfinite(d) || d != std::floor(d) || std::fabs(d) > 9007199254740992.0)
        return false;
    label = int64_t(d);
    return true;
}

std::string formatNumber(double v) {
    if (std::isnan(v)) return "";
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof(buf), v);
    return std::string(buf, r.ptr);
}

std::string joinNames(const std::vector<std::string>& names) {
    // A message names a few (found by an attack pass: a database of 2000 tables listed them all);
    // a name longer than a line is cut.
    constexpr size_t kShown = 20, kLongest = 80;
    std::string s;
    for (size_t i = 0; i < names.size() && i < kShown; ++i)
        s += (s.empty() ? "" : ", ") +
             (names[i].size() > kLongest ? names[i].substr(0, kLongest) + "..." : names[i]);
    if (names.size() > kShown) s += " and " + std::to_string(names.size() - kShown) + " more";
    return s;
}

Result<size_t> chooseLabelColumn(const std::vector<std::string>& names, const std::string& wanted,
                                 const std::string& source) {
    if (!wanted.empty()) {
        for (size_t c = 0; c < names.size(); ++c)
            if (names[c] == wanted) return c;
        for (size_t c = 0; c < names.size(); ++c)
            if (iequals(names[c], wanted)) return c;
        return Status::error(source + ": no column named '" + wanted + "' for the labels (columns: " +
                             joinNames(names) + ")");
    }
    for (size_t c = 0; c < names.size(); ++c)
        for (const auto& cand : labelColumnCandidates())
            if (iequals(names[c], cand)) return c;
    if (names.empty()) return Status::error(source + ": the table has no columns");
    return size_t(0);
}

Result<AttributeTable> buildTable(const std::vector<std::string>& names, const std::vector<std::vector<std::string>>& rows,
                                  const std::string& labelColumn, const std::string& source,
                                  const std::function<std::string(size_t)>& where) {
    for (size_t c = 0; c < names.size(); ++c)
        for (size_t d = 0; d < c; ++d)
            if (iequals(names[c], names[d]))
                return Status::error(source + ": column name '" + names[c] + "' appears twice (names are compared "
                                     "ignoring case)");
    Result<size_t> lc = chooseLabelColumn(names, labelColumn, source);
    if (!lc) return lc.status();
    const size_t labelCol = *lc;
    for (size_t c = 0; c < names.size(); ++c)
        if (c != labelCol && iequals(names[c], "label"))
            return Status::error(source + ": column '" + names[c] + "' is not the label column but 'label' is "
                                 "reserved for it; choose it as the label column or rename it");

    std::vector<std::pair<int64_t, size_t>> keyed(rows.size());
    for (size_t r = 0; r < rows.size(); ++r) {
        const std::string& f = rows[r][labelCol];
        if (f.empty()) return Status::error(where(r) + ": the label (column '" + names[labelCol] + "') is missing");
        if (!parseLabel(f, keyed[r].first))
            return Status::error(where(r) + ": label " + quotedText(f) + " (column '" + names[labelCol] + "') is not an integer");
        keyed[r].second = r;
    }
    std::stable_sort(keyed.begin(), keyed.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (size_t i = 1; i < keyed.size(); ++i)
        if (keyed[i].first == keyed[i - 1].first)
            return Status::error(where(keyed[i].second) + ": label " + std::to_string(keyed[i].first) + " repeats " +
                                 where(keyed[i - 1].second));
    std::vector<int64_t> labels(keyed.size());
    for (size_t i = 0; i < keyed.size(); ++i) labels[i] = keyed[i].first;
    Result<AttributeTable> table = AttributeTable::fromLabels(std::move(labels));
    if (!table) return table.status();

    for (size_t c = 0; c < names.size(); ++c) {
        AttributeColumn col;
        col.name = names[c];
        if (c == labelCol) {
            if (iequals(names[c], "label")) continue;
            col.values.resize(keyed.size());
            for (size_t i = 0; i < keyed.size(); ++i) col.values[i] = double(keyed[i].first);
        } else {
            col.numeric = true;
            col.values.resize(keyed.size());
            for (size_t i = 0; i < keyed.size() && col.numeric; ++i) {
                const std::string& f = rows[keyed[i].second][c];
                if (isMissing(f)) col.values[i] = std::numeric_limits<double>::quiet_NaN();
                else if (!parseNumber(f, col.values[i])) col.numeric = false;
            }
            if (!col.numeric) {
                col.values.clear();
                col.text.resize(keyed.size());
                for (size_t i = 0; i < keyed.size(); ++i) col.text[i] = rows[keyed[i].second][c];
            }
        }
        Status s = table->addColumn(std::move(col));
        if (!s) return s.prefix(source);
    }
    return table;
}

} // namespace detail

using namespace detail;

// ---------------------------------------------------------------------------------------------
// AttributeTable

namespace {
std::string lowerName(const std::string& name) {
    std::string l = name;
    for (char& c : l)
        if (c >= 'A' && c <= 'Z') c = char(c - 'A' + 'a');
    return l;
}
} // namespace

AttributeTable::AttributeTable() {
    m_columns.push_back(AttributeColumn{"label", true, {}, {}});
    reindex();
}

void AttributeTable::reindex() {
    m_byName.clear();
    for (size_t i = 0; i < m_columns.size(); ++i) m_byName.emplace(lowerName(m_columns[i].name), i);
}

Result<AttributeTable> AttributeTable::fromLabels(std::vector<int64_t> labels) {
    std::sort(labels.begin(), labels.end());
    for (size_t i = 1; i < labels.size(); ++i)
        if (labels[i] == labels[i - 1]) return Status::error("label " + std::to_string(labels[i]) + " appears twice");
    AttributeTable t;
    t.m_columns[0].values.resize(labels.size());
    for (size_t i = 0; i < labels.size(); ++i) t.m_columns[0].values[i] = double(labels[i]);
    t.m_labels = std::move(labels);
    return t;
}

int64_t AttributeTable::rowOf(int64_t label) const {
    const auto it = std::lower_bound(m_labels.begin(), m_labels.end(), label);
    return it != m_labels.end() && *it == label ? int64_t(it - m_labels.begin()) : -1;
}

std::vector<std::string> AttributeTable::columnNames() const {
    std::vector<std::string> names;
    for (const auto& c : m_columns) names.push_back(c.name);
    return names;
}

const AttributeColumn* AttributeTable::column(const std::string& name) const {
    const auto it = m_byName.find(lowerName(name));
    return it == m_byName.end() ? nullptr : &m_columns[it->second];
}

Status AttributeTable::addColumn(AttributeColumn col, bool replace) {
    if (col.name.empty()) return Status::error("an attribute column needs a name");
    const size_t n = col.numeric ? col.values.size() : col.text.size();
    if (n != m_labels.size())
        return Status::error("attribute column '" + col.name + "' has " + std::to_string(n) + " values for " +
                             std::to_string(m_labels.size()) + " labels");
    if (col.numeric) col.text.clear();
    else col.values.clear();
    const std::string key = lowerName(col.name);
    if (const auto it = m_byName.find(key); it != m_byName.end()) {
        const size_t i = it->second;
        if (i == 0) return Status::error("attribute column 'label' is the label itself and cannot be replaced");
        if (!replace) return Status::error("attribute column '" + col.name + "' already exists");
        m_columns[i] = std::move(col);
        return Status::ok();
    }
    m_byName.emplace(key, m_columns.size());
    m_columns.push_back(std::move(col));
    return Status::ok();
}

bool AttributeTable::removeColumn(const std::string& name) {
    for (size_t i = 1; i < m_columns.size(); ++i)
        if (iequals(m_columns[i].name, name)) {
            m_columns.erase(m_columns.begin() + std::ptrdiff_t(i));
            reindex();
            return true;
        }
    return false;
}

Status AttributeTable::merge(const AttributeTable& other, OnConflict onConflict) {
    std::vector<const AttributeColumn*> incoming;
    for (size_t c = 1; c < other.m_columns.size(); ++c) {
        const AttributeColumn& oc = other.m_columns[c];
        if (iequals(oc.name, "label")) continue;
        if (hasColumn(oc.name)) {
            if (onConflict == OnConflict::Fail)
                return Status::error("merging attributes: both tables have a column '" + oc.name + "'");
            if (onConflict == OnConflict::Keep) continue;
        }
        incoming.push_back(&oc);
    }
    // Rows of the union: index into this table and into the other, -1 where absent.
    std::vector<int64_t> merged;
    std::vector<int64_t> mine, theirs;
    const bool same = m_labels == other.m_labels;
    if (!same) {
        merged.reserve(m_labels.size() + other.m_labels.size());
        size_t i = 0, j = 0;
        while (i < m_labels.size() || j < other.m_labels.size()) {
            if (j == other.m_labels.size() || (i < m_labels.size() && m_labels[i] < other.m_labels[j])) {
                merged.push_back(m_labels[i]);
                mine.push_back(int64_t(i++));
                theirs.push_back(-1);
            } else if (i == m_labels.size() || other.m_labels[j] < m_labels[i]) {
                merged.push_back(other.m_labels[j]);
                mine.push_back(-1);
                theirs.push_back(int64_t(j++));
            } else {
                merged.push_back(m_labels[i]);
                mine.push_back(int64_t(i++));
                theirs.push_back(int64_t(j++));
            }
        }
    }
    auto remap = [&](const AttributeColumn& src, const std::vector<int64_t>& rows) {
        AttributeColumn out;
        out.name = src.name;
        out.numeric = src.numeric;
        if (src.numeric) {
            out.values.resize(rows.size());
            for (size_t r = 0; r < rows.size(); ++r)
                out.values[r] = rows[r] < 0 ? std::numeric_limits<double>::quiet_NaN() : src.values[size_t(rows[r])];
        } else {
            out.text.resize(rows.size());
            for (size_t r = 0; r < rows.size(); ++r)
                if (rows[r] >= 0) out.text[r] = src.text[size_t(rows[r])];
        }
        return out;
    };
    std::vector<AttributeColumn> added;
    for (const AttributeColumn* oc : incoming) added.push_back(same ? *oc : remap(*oc, theirs));
    if (!same) {
        for (size_t c = 1; c < m_columns.size(); ++c) m_columns[c] = remap(m_columns[c], mine);
        m_labels = std::move(merged);
        m_columns[0].values.resize(m_labels.size());
        for (size_t i = 0; i < m_labels.size(); ++i) m_columns[0].values[i] = double(m_labels[i]);
    }
    for (AttributeColumn& c : added) {
        Status s = addColumn(std::move(c), true);
        if (!s) return s;
    }
    return Status::ok();
}

double AttributeTable::value(const std::string& name, int64_t label) const {
    if (iequals(name, "label")) return double(label);
    const AttributeColumn* c = column(name);
    if (!c || !c->numeric) return std::numeric_limits<double>::quiet_NaN();
    const int64_t r = rowOf(label);
    return r < 0 ? std::numeric_limits<double>::quiet_NaN() : c->values[size_t(r)];
}

std::string AttributeTable::text(const std::string& name, int64_t label) const {
    if (iequals(name, "label")) return std::to_string(label);
    const AttributeColumn* c = column(name);
    const int64_t r = rowOf(label);
    if (!c || r < 0) return "";
    return c->numeric ? formatNumber(c->values[size_t(r)]) : c->text[size_t(r)];
}

Result<std::array<double, 2>> AttributeTable::range(const std::string& name) const {
    const AttributeColumn* c = column(name);
    if (!c) return Status::error("no attribute '" + name + "' (attributes: " + joinNames(columnNames()) + ")");
    if (!c->numeric) return Status::error("attribute '" + c->name + "' holds text, not numbers");
    std::array<double, 2> r{{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()}};
    for (double v : c->values) {
        if (std::isnan(v)) continue;
        if (std::isnan(r[0]) || v < r[0]) r[0] = v;
        if (std::isnan(r[1]) || v > r[1]) r[1] = v;
    }
    return r;
}

Result<std::vector<float>> AttributeTable::denseFloatColumn(const std::string& name, uint64_t labelCount,
                                                            float missing) const {
    const AttributeColumn* c = column(name);
    if (!c) return Status::error("no attribute '" + name + "' (attributes: " + joinNames(columnNames()) + ")");
    if (!c->numeric) return Status::error("attribute '" + c->name + "' holds text, not numbers");
    if (labelCount > (uint64_t(1) << 32))
        return Status::error("a dense attribute array of " + std::to_string(labelCount) +
                             " entries is larger than the 2^32 labels of the format");
    std::vector<float> out(size_t(labelCount), missing);
    if (c == &m_columns[0]) {
        for (uint64_t v = 0; v < labelCount; ++v) out[size_t(v)] = float(v);
        return out;
    }
    for (size_t r = 0; r < m_labels.size(); ++r)
        if (m_labels[r] >= 0 && uint64_t(m_labels[r]) < labelCount) out[size_t(m_labels[r])] = float(c->values[r]);
    return out;
}

Result<std::vector<float>> AttributeTable::denseFloatColumnForIds(const std::string& name,
                                                                  const std::vector<int64_t>& idToLabel,
                                                                  float missing) const {
    const AttributeColumn* c = column(name);
    if (!c) return Status::error("no attribute '" + name + "' (attributes: " + joinNames(columnNames()) + ")");
    if (!c->numeric) return Status::error("attribute '" + c->name + "' holds text, not numbers");
    std::vector<float> out(idToLabel.size(), missing);
    for (size_t i = 0; i < idToLabel.size(); ++i) {
        if (c == &m_columns[0]) {
            out[i] = float(idToLabel[i]);
            continue;
        }
        const int64_t r = rowOf(idToLabel[i]);
        if (r >= 0) out[i] = float(c->values[size_t(r)]);
    }
    return out;
}

std::function<double(const std::string&, uint32_t)> AttributeTable::attributeFunction() const {
    return [this](const std::string& name, uint32_t label) { return value(name, int64_t(label)); };
}

const std::vector<std::string>& labelColumnCandidates() {
    static const std::vector<std::string> names = {"label",     "labels",     "id",    "label_id", "labelid",
                                                   "segment_id", "segmentid", "segid", "index"};
    return names;
}

// ---------------------------------------------------------------------------------------------
// Delimited text

namespace {

struct Record {
    std::vector<std::string> fields;
    size_t line = 0;
};

// Tables go into SQLite (the attribute database, derived attributes), which takes at most 2000
// columns (SQLITE_MAX_COLUMN). A longer row is not a table of attributes (a row of labels, say):
// the tokenizer stops there, so such a file never costs more than its text (a 200 MB line of
// numbers held as strings took 1 GB), and comparing the names of so many columns took quadratic
// time (60,000: 30 s).
constexpr size_t kMaxColumns = 2000;

bool isBlank(char c) { return c == ' ' || c == '\t'; }

/// Splits text into records. delim ' ' means runs of blanks.
Status tokenize(const std::string& s, char delim, const std::string& source, std::vector<Record>& out) {
    const bool ws = delim == ' ';
    size_t i = 0, line = 1;
    const size_t n = s.size();
    if (n >= 3 && s.compare(0, 3, "\xEF\xBB\xBF") == 0) i = 3;
    auto atEol = [&](size_t k) { return k >= n || s[k] == '\n' || s[k] == '\r'; };
    auto skipEol = [&](size_t& k) {
        if (k < n && s[k] == '\r') ++k;
        if (k < n && s[k] == '\n') ++k;
        ++line;
    };
    while (i < n) {
        size_t j = i;
        while (j < n && isBlank(s[j])) ++j;
        if (atEol(j) || s[j] == '#') { // blank or comment line
            while (!atEol(j)) ++j;
            if (j >= n) break;
            skipEol(j);
            i = j;
            continue;
        }
        Record rec;
        rec.line = line;
        for (;;) {
            while (i < n && isBlank(s[i]) && (ws || s[i] != delim)) ++i;
            std::string field;
            if (i < n && s[i] == '"') {
                const size_t startLine = line;
                ++i;
                for (;;) {
                    if (i >= n)
                        return Status::error(source + ":" + std::to_string(startLine) + ": unterminated quoted field");
                    if (s[i] == '"') {
                        if (i + 1 < n && s[i + 1] == '"') {
                            field += '"';
                            i += 2;
                            continue;
                        }
                        ++i;
                        break;
                    }
                    if (s[i] == '\n') ++line;
                    field += s[i++];
                }
                while (i < n && isBlank(s[i]) && (ws || s[i] != delim)) ++i;
                if (!atEol(i) && !ws && s[i] != delim)
                    return Status::error(source + ":" + std::to_string(line) + ": text after the closing quote of field " +
                                         std::to_string(rec.fields.size() + 1));
            } else {
                const size_t b = i;
                while (!atEol(i) && (ws ? !isBlank(s[i]) : s[i] != delim)) ++i;
                size_t e = i;
                while (e > b && isBlank(s[e - 1])) --e;
                field.assign(s, b, e - b);
            }
            rec.fields.push_back(std::move(field));
            if (rec.fields.size() > kMaxColumns)
                return Status::error(source + ":" + std::to_string(rec.line) + ": more than " +
                                     std::to_string(kMaxColumns) + " fields; an attribute table has at most " +
                                     std::to_string(kMaxColumns) + " columns");
            if (ws) {
                while (i < n && isBlank(s[i])) ++i;
                if (atEol(i)) break;
            } else {
                if (atEol(i)) break;
                ++i; // the delimiter
            }
        }
        out.push_back(std::move(rec));
        if (i >= n) break;
        skipEol(i);
    }
    return Status::ok();
}

char detectDelimiter(const std::string& s) {
    size_t i = 0;
    // The first line that is not blank or a comment.
    for (;;) {
        size_t j = i;
        while (j < s.size() && isBlank(s[j])) ++j;
        if (j < s.size() && s[j] == '#') {
            while (j < s.size() && s[j] != '\n') ++j;
            i = j + 1;
        } else if (j < s.size() && (s[j] == '\n' || s[j] == '\r')) {
            i = j + 1;
        } else {
            break;
        }
        if (i >= s.size()) return ' ';
    }
    size_t comma = 0, tab = 0, semi = 0;
    bool quoted = false;
    for (; i < s.size() && (quoted || (s[i] != '\n' && s[i] != '\r')); ++i) {
        if (s[i] == '"') quoted = !quoted;
        else if (!quoted) {
            comma += s[i] == ',';
            tab += s[i] == '\t';
            semi += s[i] == ';';
        }
    }
    if (comma == 0 && tab == 0 && semi == 0) return ' ';
    if (comma >= tab && comma >= semi) return ',';
    return tab >= semi ? '\t' : ';';
}

bool isNumberField(const std::string& f) {
    double d;
    return parseNumber(f, d);
}

} // namespace

Result<AttributeTable> parseCsv(const std::string& text, const CsvOptions& options, const std::string& source) {
    const char delim = options.delimiter ? options.delimiter : detectDelimiter(text);
    if (delim != ',' && delim != ';' && delim != '\t' && delim != ' ')
        return Status::error(source + ": unsupported delimiter '" + std::string(1, delim) +
                             "' (use ',', ';', tab or ' ' for blanks)");
    std::vector<Record> records;
    Status s = tokenize(text, delim, source, records);
    if (!s) return s;
    if (records.empty()) return Status::error(source + ": no rows");
    bool header = options.header == CsvOptions::Header::Present;
    if (options.header == CsvOptions::Header::Auto) {
        const Record& first = records[0];
        header = std::none_of(first.fields.begin(), first.fields.end(), isNumberField);
        // Rows of another length are an error below whatever the header; looking down each column of
        // such a table cost columns x rows (2000 fields, then a million one-field rows: 60 s).
        const bool ragged = std::any_of(records.begin(), records.end(),
                                        [&](const Record& r) { return r.fields.size() != first.fields.size(); });
        for (size_t c = 0; !header && !ragged && c < first.fields.size() && records.size() > 1; ++c) {
            if (isMissing(first.fields[c]) || isNumberField(first.fields[c])) continue;
            bool numericBelow = true, any = false;
            for (size_t r = 1; r < records.size() && numericBelow; ++r) {
                if (c >= records[r].fields.size()) continue;
                const std::string& f = records[r].fields[c];
                if (isMissing(f)) continue;
                any = true;
                numericBelow = isNumberField(f);
            }
            header = any && numericBelow;
        }
    }
    const size_t ncol = records[0].fields.size();
    std::vector<std::string> names;
    if (header) {
        names = records[0].fields;
        for (size_t c = 0; c < ncol; ++c)
            if (names[c].empty()) names[c] = "col" + std::to_string(c + 1);
    } else if (!options.columnNames.empty()) {
        if (options.columnNames.size() != ncol)
            return Status::error(source + ": " + std::to_string(options.columnNames.size()) + " column names given for " +
                                 std::to_string(ncol) + " columns");
        names = options.columnNames;
    }
    const size_t firstData = header ? 1 : 0;
    for (size_t r = firstData; r < records.size(); ++r)
        if (records[r].fields.size() != ncol)
            return Status::error(source + ":" + std::to_string(records[r].line) + ": " +
                                 std::to_string(records[r].fields.size()) + " fields, expected " + std::to_string(ncol) +
                                 (header ? " as in the header" : " as in the first row"));
    std::vector<std::vector<std::string>> rows;
    std::vector<size_t> lines;
    rows.reserve(records.size() - firstData);
    for (size_t r = firstData; r < records.size(); ++r) {
        rows.push_back(std::move(records[r].fields));
        lines.push_back(records[r].line);
    }
    if (names.empty()) { // generated names
        std::vector<bool> numeric(ncol, true);
        for (size_t c = 0; c < ncol; ++c)
            for (const auto& row : rows)
                if (!isMissing(row[c]) && !isNumberField(row[c])) {
                    numeric[c] = false;
                    break;
                }
        const bool mricron = ncol == 3 && numeric[0] && !numeric[1] && numeric[2];
        bool named = false;
        for (size_t c = 0; c < ncol; ++c) {
            if (c == 0) names.push_back("label");
            else if (!numeric[c] && !named) {
                names.push_back("name");
                named = true;
            } else if (mricron && c == 2) names.push_back("code");
            else names.push_back("col" + std::to_string(c + 1));
        }
    }
    return buildTable(names, rows, options.labelColumn, source,
                      [&](size_t r) { return source + ":" + std::to_string(lines[r]); });
}

Result<AttributeTable> readCsv(const std::string& path, const CsvOptions& options) {
    // Parsing holds a few times the text: the file's size is checked before any of it is read
    // (a FIFO or a device would otherwise be read without end).
    Result<std::vector<uint8_t>> bytes = readFile(path, kMaxAttributeTextBytes);
    if (!bytes) return Status::error("attribute table: " + bytes.message() + " (at most " +
                                     std::to_string(kMaxAttributeTextBytes >> 20) + " MiB of text are read)");
    return parseCsv(std::string(bytes->begin(), bytes->end()), options, path);
}

} // namespace csgv
