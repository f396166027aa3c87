// SPDX-License-Identifier: MIT
/// @file FuzzCsv.cpp
/// @brief Fuzz entry point over the attribute table's text import (Attributes.h parseCsv: CSV,
/// TSV, semicolons and blank-separated tables), and what a layer then does with a table: ranges,
/// dense float columns, text of values, a merge, a derived attribute (SQLite in memory).
///
/// Input framing, by the first byte: bits 0-2 the delimiter (detected, ',', ';', tab, blanks, or
/// an unsupported one), bits 3-4 the header (auto, present, absent), bit 5 names the label column
/// `id`, bit 6 gives three column names. The rest is the text. A failure must name the source;
/// a table must keep AttributeTable's invariants.

#include "FuzzFiles.h"

#include "csgv/attributes/Attributes.h"

#include <algorithm>
#include <cmath>

using namespace csgv;

namespace {

void checkTable(const AttributeTable& t) {
    fuzz::require(!t.columns().empty() && t.columns()[0].name == "label" && t.columns()[0].numeric);
    fuzz::require(std::is_sorted(t.labels().begin(), t.labels().end()));
    fuzz::require(std::adjacent_find(t.labels().begin(), t.labels().end()) == t.labels().end());
    const std::vector<std::string> names = t.columnNames();
    for (size_t c = 0; c < names.size(); ++c) {
        const AttributeColumn& col = t.columns()[c];
        if (c > 0) fuzz::require((col.numeric ? col.values.size() : col.text.size()) == t.rowCount());
        fuzz::require(t.column(names[c]) == &col);
        Result<std::array<double, 2>> range = t.range(names[c]);
        if (range && !std::isnan((*range)[0])) fuzz::require((*range)[0] <= (*range)[1]);
        Result<std::vector<float>> dense = t.denseFloatColumn(names[c], 64);
        fuzz::require(dense.isOk() ? dense->size() == 64 : !col.numeric);
    }
    for (size_t r = 0; r < t.rowCount() && r < 64; ++r) {
        fuzz::require(t.rowOf(t.labels()[r]) == int64_t(r));
        for (const std::string& n : names) (void)t.text(n, t.labels()[r]);
    }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    const uint8_t mode = data[0];
    static const char kDelimiters[] = {0, ',', ';', '\t', ' ', '|', ',', 0};
    CsvOptions options;
    options.delimiter = kDelimiters[mode & 7];
    options.header = CsvOptions::Header((mode >> 3) % 3);
    if (mode & 32) options.labelColumn = "id";
    if (mode & 64) options.columnNames = {"id", "name", "volume"};
    const std::string source = "fuzz.csv";
    const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);

    Result<AttributeTable> table = parseCsv(text, options, source);
    if (!table) {
        fuzz::require(table.message().compare(0, source.size(), source) == 0 && table.message().size() > source.size() + 2);
        return 0;
    }
    checkTable(*table);
    if (table->rowCount() > 256) return 0; // keep each input fast

    // Joined with itself: same labels; every column but `label` taken from one side.
    AttributeTable merged = *table;
    fuzz::require(merged.merge(*table, AttributeTable::OnConflict::Replace).isOk());
    fuzz::require(merged.labels() == table->labels() && merged.columns().size() == table->columns().size());
    checkTable(merged);

    // A derived attribute over every column.
    std::string expression = "label";
    for (size_t c = 1; c < table->columns().size() && c < 8; ++c) {
        std::string quoted = "\"";
        for (char ch : table->columns()[c].name) quoted += ch == '"' ? std::string("\"\"") : std::string(1, ch);
        expression += " || " + quoted + "\"";
    }
    AttributeTable derived = *table;
    Status s = addDerivedAttribute(derived, "fuzz_derived", expression, true);
    if (s) {
        fuzz::require(derived.rowCount() == table->rowCount() && derived.hasColumn("fuzz_derived"));
        checkTable(derived);
    } else {
        fuzz::require(!s.message().empty());
    }
    return 0;
}
