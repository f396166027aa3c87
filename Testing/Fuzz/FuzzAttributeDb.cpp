// SPDX-License-Identifier: MIT
/// @file FuzzAttributeDb.cpp
/// @brief Fuzz entry point over the SQLite sidecar readers (AttributeDb.h readAttributeDb, the
/// `_csgv.db3` beside a relabelled `.csgv`, and Attributes.h readSqliteTable, any attribute
/// database): the input is the file. SQLite parses the file; what is under test is our reading of
/// it (the schema we expect, ids 0..n-1, label types, text and numeric columns, the table built
/// from it). A failure must name the file; what reads must be consistent.

#include "FuzzFiles.h"

#include "csgv/attributes/Attributes.h"

#include <algorithm>

using namespace csgv;

namespace {

void checkTable(const AttributeTable& t) {
    fuzz::require(!t.columns().empty() && t.columns()[0].name == "label");
    fuzz::require(std::is_sorted(t.labels().begin(), t.labels().end()));
    fuzz::require(std::adjacent_find(t.labels().begin(), t.labels().end()) == t.labels().end());
    for (const AttributeColumn& c : t.columns())
        fuzz::require((c.numeric ? c.values.size() : c.text.size()) == t.rowCount() || (&c == &t.columns()[0]));
    for (size_t r = 0; r < t.rowCount() && r < 64; ++r)
        for (const AttributeColumn& c : t.columns()) (void)t.text(c.name, t.labels()[r]);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string path = fuzz::scratchDir() + "/fuzz_csgv.db3";
    fuzz::writeFile(path, data, size);

    Result<AttributeDatabase> db = readAttributeDb(path);
    if (!db) {
        fuzz::require(fuzz::namesPath(db.message(), path));
    } else {
        fuzz::require(!db->labelColumn.empty());
        for (const AttributeColumn& c : db->columns)
            fuzz::require((c.numeric ? c.values.size() : c.text.size()) == db->labels.size());
        Result<std::vector<uint32_t>> ids = db->labelsAsUint32();
        fuzz::require(ids.isOk() ? ids->size() == db->labels.size() : !ids.message().empty());
        Result<AttributeTable> t = attributesFromDatabase(*db);
        if (t) checkTable(*t);
        else fuzz::require(fuzz::namesPath(t.message(), path));
    }

    Result<AttributeTable> table = readSqliteTable(path);
    if (!table) fuzz::require(fuzz::namesPath(table.message(), path));
    else checkTable(*table);
    return 0;
}
