// SPDX-License-Identifier: MIT
// The attribute store: CSV and whitespace tables, SQLite tables and Volcanite's database,
// derived attributes, merging, dense GPU columns, and computed attributes against a brute-force
// count over the decoded volume (synthetic volumes and the AAL atlas, 1 and 2 threads).
#include "TestData.h"

#include "csgv/attributes/Attributes.h"
#include "csgv/base/Cancel.h"
#include "csgv/inputs/Compress.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Encoder.h"
#include "csgv/inputs/Inputs.h"
#include "csgv/materials/Materials.h"
#include "csgv/inputs/Procedural.h"
#include "csgv/inputs/Relabel.h"
#include "csgv/codec/Partition.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unordered_map>

using namespace csgv;
using namespace csgvtest;

namespace {

const char* const kAalTable = "/usr/share/mricron/templates/aal.nii.txt";
const char* const kAalVolume = "/usr/share/mricron/templates/aal.nii.gz";
const char* const kJhuTable = "/usr/share/mricron/templates/JHU-WhiteMatter-labels-1mm.nii.txt";

bool contains(const std::string& message, const std::vector<std::string>& parts) {
    for (const auto& p : parts)
        if (message.find(p) == std::string::npos) return false;
    return true;
}

#define EXPECT_ERROR(result, ...)                                                                            \
    do {                                                                                                     \
        const auto& r_ = (result);                                                                           \
        EXPECT_FALSE(r_.isOk());                                                                             \
        EXPECT_TRUE(contains(r_.message(), {__VA_ARGS__})) << "message: " << r_.message();                 \
    } while (0)

std::string freshDir(const std::string& name) {
    const std::string d = tempDir() + "/" + name;
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
}

void sqlExec(sqlite3* db, const std::string& sql) {
    char* err = nullptr;
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err), SQLITE_OK) << (err ? err : "") << " in " << sql;
}

void expectSameTable(const AttributeTable& a, const AttributeTable& b) {
    ASSERT_EQ(a.labels(), b.labels());
    ASSERT_EQ(a.columnNames(), b.columnNames());
    for (size_t c = 0; c < a.columns().size(); ++c) {
        const AttributeColumn& x = a.columns()[c];
        const AttributeColumn& y = b.columns()[c];
        SCOPED_TRACE(x.name);
        ASSERT_EQ(x.numeric, y.numeric);
        EXPECT_EQ(x.text, y.text);
        ASSERT_EQ(x.values.size(), y.values.size());
        for (size_t i = 0; i < x.values.size(); ++i)
            if (!(std::isnan(x.values[i]) && std::isnan(y.values[i]))) {
                EXPECT_EQ(x.values[i], y.values[i]) << i;
            }
    }
}

// ---- brute-force reference of the computed attributes, written without Core's code ----------

struct Ref {
    uint64_t count = 0, faces = 0;
    uint64_t sum[3] = {0, 0, 0};
    uint32_t min[3] = {~0u, ~0u, ~0u}, max[3] = {0, 0, 0};
};

std::unordered_map<uint32_t, Ref> bruteForce(const LabelVolume& v, bool boundary) {
    std::unordered_map<uint32_t, Ref> out;
    const int64_t d[3] = {v.dim[0], v.dim[1], v.dim[2]};
    for (int64_t z = 0; z < d[2]; ++z)
        for (int64_t y = 0; y < d[1]; ++y)
            for (int64_t x = 0; x < d[0]; ++x) {
                const uint32_t l = v.at(uint32_t(x), uint32_t(y), uint32_t(z));
                Ref& r = out[l];
                ++r.count;
                const int64_t p[3] = {x, y, z};
                for (int a = 0; a < 3; ++a) {
                    r.sum[a] += uint64_t(p[a]);
                    r.min[a] = std::min(r.min[a], uint32_t(p[a]));
                    r.max[a] = std::max(r.max[a], uint32_t(p[a]));
                    for (int s = -1; s <= 1; s += 2) {
                        int64_t q[3] = {x, y, z};
                        q[a] += s;
                        if (q[a] < 0 || q[a] >= d[a]) r.faces += boundary ? 1 : 0;
                        else r.faces += v.at(uint32_t(q[0]), uint32_t(q[1]), uint32_t(q[2])) != l ? 1 : 0;
                    }
                }
            }
    return out;
}

/// Compares a computed table with the reference; `labelOf` maps reference keys to table labels.
void expectMatchesReference(const AttributeTable& t, const std::unordered_map<uint32_t, Ref>& ref) {
    ASSERT_EQ(t.rowCount(), ref.size());
    for (const auto& [label, r] : ref) {
        SCOPED_TRACE("label " + std::to_string(label));
        ASSERT_GE(t.rowOf(label), 0);
        EXPECT_EQ(t.value("voxel_count", label), double(r.count));
        EXPECT_EQ(t.value("surface_area", label), double(r.faces));
        const char* axes = "xyz";
        for (int a = 0; a < 3; ++a) {
            EXPECT_EQ(t.value(std::string("bbox_min_") + axes[a], label), double(r.min[a]));
            EXPECT_EQ(t.value(std::string("bbox_max_") + axes[a], label), double(r.max[a]));
            EXPECT_NEAR(t.value(std::string("centroid_") + axes[a], label), double(r.sum[a]) / double(r.count) + 0.5,
                        1e-9);
        }
    }
}

LabelVolume synthVolume(uint32_t w, uint32_t h, uint32_t d, uint64_t seed, uint32_t cell) {
    SynthSpec s;
    s.dim = {{w, h, d}};
    s.seed = seed;
    s.cellSize = cell;
    return *generateVolume(s);
}

CompressedVolume compress(const LabelVolume& v, uint32_t brickSize) {
    EncodeOptions o;
    o.brickSize = brickSize;
    o.threads = 2;
    Result<CompressedVolume> c = encodeVolume(v, o);
    EXPECT_TRUE(c.isOk()) << c.message();
    return c.isOk() ? *c : CompressedVolume{};
}

Result<AttributeTable> computeWith(const CompressedVolume& c, int threads, bool boundary = true,
                                   const std::vector<int64_t>* idToLabel = nullptr) {
    ComputeAttributesOptions o;
    o.threads = threads;
    o.countBoundaryFaces = boundary;
    o.idToLabel = idToLabel;
    return computeAttributes(c, o);
}

} // namespace

// ---- CSV ----------------------------------------------------------------------------------

TEST(AttributesCsv, HeaderQuotedFieldsAndTypes) {
    const std::string csv = "\xEF\xBB\xBF"
                            "id, name ,volume,kind\r\n"
                            "7,\"Left, upper\",1.5,3\r\n"
                            "# a comment line\r\n"
                            "\r\n"
                            "2,\"say \"\"hi\"\"\",NA,x\r\n"
                            "0,\"multi\nline\",,4\r\n";
    Result<AttributeTable> t = parseCsv(csv);
    ASSERT_TRUE(t.isOk()) << t.message();
    EXPECT_EQ(t->labels(), (std::vector<int64_t>{0, 2, 7}));
    EXPECT_EQ(t->columnNames(), (std::vector<std::string>{"label", "id", "name", "volume", "kind"}));
    EXPECT_TRUE(t->column("volume")->numeric);
    EXPECT_FALSE(t->column("name")->numeric);
    EXPECT_FALSE(t->column("kind")->numeric); // "x" makes it text
    EXPECT_EQ(t->text("name", 7), "Left, upper");
    EXPECT_EQ(t->text("name", 2), "say \"hi\"");
    EXPECT_EQ(t->text("name", 0), "multi\nline");
    EXPECT_EQ(t->value("volume", 7), 1.5);
    EXPECT_TRUE(std::isnan(t->value("volume", 2)));
    EXPECT_TRUE(std::isnan(t->value("volume", 0)));
    EXPECT_EQ(t->value("id", 7), 7.0);
    EXPECT_EQ(t->value("label", 12345), 12345.0); // the label always exists
    EXPECT_TRUE(std::isnan(t->value("volume", 12345)));
    EXPECT_EQ(t->column("VOLUME"), t->column("volume")); // names ignore case
    EXPECT_EQ(t->text("volume", 7), "1.5");

    // Semicolons and tabs are detected; the label column may be named.
    Result<AttributeTable> semi = parseCsv("a;b;c\n1;2;x\n3;4;y\n", CsvOptions{"b", 0, CsvOptions::Header::Auto, {}});
    ASSERT_TRUE(semi.isOk()) << semi.message();
    EXPECT_EQ(semi->labels(), (std::vector<int64_t>{2, 4}));
    EXPECT_EQ(semi->value("a", 4), 3.0);
    EXPECT_EQ(semi->text("c", 2), "x");
    Result<AttributeTable> tabs = parseCsv("1\t\tfoo bar\n2\t5\tbaz\n");
    ASSERT_TRUE(tabs.isOk()) << tabs.message();
    EXPECT_EQ(tabs->columnNames(), (std::vector<std::string>{"label", "col2", "name"}));
    EXPECT_TRUE(std::isnan(tabs->value("col2", 1)));
    EXPECT_EQ(tabs->text("name", 1), "foo bar");

    // Header detection: a numeric column whose first field is not a number.
    Result<AttributeTable> h = parseCsv("segment,2019\n4,1\n5,2\n");
    ASSERT_TRUE(h.isOk()) << h.message();
    EXPECT_EQ(h->columnNames(), (std::vector<std::string>{"label", "segment", "2019"}));
    // Integral floats and large unsigned labels are labels too.
    Result<AttributeTable> f = parseCsv("label,v\n3.0,1\n18446744073709551615,2\n");
    ASSERT_TRUE(f.isOk()) << f.message();
    EXPECT_EQ(f->labels(), (std::vector<int64_t>{-1, 3}));
}

TEST(AttributesCsv, WhitespaceTablesWithoutHeader) {
    if (!std::filesystem::exists(kAalTable)) GTEST_SKIP() << kAalTable << " not found; install mricron-data";
    Result<AttributeTable> aal = readCsv(kAalTable);
    ASSERT_TRUE(aal.isOk()) << aal.message();
    EXPECT_EQ(aal->columnNames(), (std::vector<std::string>{"label", "name", "code"}));
    ASSERT_EQ(aal->rowCount(), 116u);
    EXPECT_EQ(aal->labels().front(), 1);
    EXPECT_EQ(aal->labels().back(), 116);
    EXPECT_EQ(aal->text("name", 1), "Precentral_L");
    EXPECT_EQ(aal->text("name", 2), "Precentral_R");
    EXPECT_EQ(aal->value("code", 1), 2001.0);
    EXPECT_EQ(aal->text("name", 116), "Vermis_10");
    EXPECT_EQ(aal->value("code", 116), 9170.0);
    Result<std::array<double, 2>> range = aal->range("code");
    ASSERT_TRUE(range.isOk());
    EXPECT_EQ((*range)[0], 2001.0);
    EXPECT_EQ((*range)[1], 9170.0);

    Result<AttributeTable> spaces = parseCsv("  1 \"two words\"   7\n2 other 8\n");
    ASSERT_TRUE(spaces.isOk()) << spaces.message();
    EXPECT_EQ(spaces->text("name", 1), "two words");
    CsvOptions named;
    named.columnNames = {"id", "region", "score"};
    named.header = CsvOptions::Header::Absent;
    Result<AttributeTable> n = parseCsv("1 a 7\n2 b 8\n", named);
    ASSERT_TRUE(n.isOk()) << n.message();
    EXPECT_EQ(n->columnNames(), (std::vector<std::string>{"label", "id", "region", "score"}));

    if (std::filesystem::exists(kJhuTable)) { // tab-separated, two columns, label 0 present
        Result<AttributeTable> jhu = readCsv(kJhuTable);
        ASSERT_TRUE(jhu.isOk()) << jhu.message();
        EXPECT_EQ(jhu->columnNames(), (std::vector<std::string>{"label", "name"}));
        EXPECT_EQ(jhu->text("name", 0), "Unclassified");
        EXPECT_EQ(jhu->text("name", 2), "Pontine_crossing_tract_(a_part_of_MCP)");
    }
}

TEST(AttributesCsv, ErrorsNameTheLine) {
    EXPECT_ERROR(parseCsv("label,a\n1,2\n2,3,4\n", {}, "t.csv"), "t.csv:3", "3 fields, expected 2");
    EXPECT_ERROR(parseCsv("label,a\n1,\"open\n2,3\n", {}, "t.csv"), "t.csv:2", "unterminated quoted field");
    EXPECT_ERROR(parseCsv("label,a\n1,\"x\"y\n", {}, "t.csv"), "t.csv:2", "after the closing quote");
    EXPECT_ERROR(parseCsv("label,a\n1,2\nabc,3\n", {}, "t.csv"), "t.csv:3", "label 'abc'", "not an integer");
    EXPECT_ERROR(parseCsv("label,a\n1,2\n1.5,3\n", {}, "t.csv"), "t.csv:3", "'1.5'");
    EXPECT_ERROR(parseCsv("label,a\n1,2\n,3\n", {}, "t.csv"), "t.csv:3", "label", "missing");
    EXPECT_ERROR(parseCsv("label,a\n5,2\n6,2\n5,3\n", {}, "t.csv"), "t.csv:4", "label 5 repeats t.csv:2");
    EXPECT_ERROR(parseCsv("label,a,A\n1,2,3\n", {}, "t.csv"), "column name 'A' appears twice");
    EXPECT_ERROR(parseCsv("id,label\n1,2\n", {}, "t.csv"), "'label' is reserved");
    EXPECT_ERROR(parseCsv("a,b\n1,2\n", CsvOptions{"c", 0, CsvOptions::Header::Auto, {}}, "t.csv"),
                 "no column named 'c'", "columns: a, b");
    EXPECT_ERROR(parseCsv("\n# nothing\n", {}, "t.csv"), "t.csv", "no rows");
    EXPECT_ERROR(readCsv("/nonexistent/table.csv"), "/nonexistent/table.csv");
    CsvOptions wrong;
    wrong.columnNames = {"a"};
    EXPECT_ERROR(parseCsv("1 2\n", wrong, "t.txt"), "1 column names given for 2 columns");
}

TEST(AttributesCsv, WideAndRaggedTablesFailEarly) {
    // A row of 60,000 labels is not a table of attributes (SQLite takes 2000 columns); checking
    // the names of so many columns against each other took quadratic time (over 30 s).
    std::string row = "1";
    for (int i = 2; i <= 60000; ++i) row += "," + std::to_string(i);
    EXPECT_ERROR(parseCsv(row + "\n", {}, "t.csv"), "t.csv:1", "more than 2000 fields", "at most 2000 columns");
    // Any row, not only the first: the tokenizer stops there (a 200 MB line took 1 GB).
    EXPECT_ERROR(parseCsv("label,size\n1,2\n" + row + "\n", {}, "t.csv"), "t.csv:3", "more than 2000 fields");
    // 2000 columns, then many one-field rows: header detection looked down every column of every
    // row (60 s for a million rows) before the field counts were compared.
    std::string ragged = "1";
    for (int i = 1; i < 2000; ++i) ragged += ",a";
    ragged += "\n";
    for (int i = 0; i < 200000; ++i) ragged += "x\n";
    EXPECT_ERROR(parseCsv(ragged, {}, "t.csv"), "t.csv:2", "1 fields, expected 2000");
}

// ---- the table ----------------------------------------------------------------------------

TEST(AttributeTable, MergeDenseColumnsAndMaterials) {
    Result<AttributeTable> a = parseCsv("label,size\n1,10\n3,30\n5,50\n");
    Result<AttributeTable> b = parseCsv("label,name,size\n3,c,33\n4,d,44\n");
    ASSERT_TRUE(a.isOk() && b.isOk());
    AttributeTable m = *a;
    EXPECT_ERROR(m.merge(*b), "both tables have a column 'size'");
    expectSameTable(m, *a); // unchanged on failure
    ASSERT_TRUE(m.merge(*b, AttributeTable::OnConflict::Keep).isOk());
    EXPECT_EQ(m.labels(), (std::vector<int64_t>{1, 3, 4, 5}));
    EXPECT_EQ(m.columnNames(), (std::vector<std::string>{"label", "size", "name"}));
    EXPECT_EQ(m.value("size", 3), 30.0);
    EXPECT_TRUE(std::isnan(m.value("size", 4)));
    EXPECT_EQ(m.text("name", 4), "d");
    EXPECT_EQ(m.text("name", 1), "");
    AttributeTable r = *a;
    ASSERT_TRUE(r.merge(*b, AttributeTable::OnConflict::Replace).isOk());
    EXPECT_EQ(r.value("size", 3), 33.0);
    EXPECT_TRUE(std::isnan(r.value("size", 1)));

    Result<std::vector<float>> dense = m.denseFloatColumn("size", 7);
    ASSERT_TRUE(dense.isOk());
    ASSERT_EQ(dense->size(), 7u);
    EXPECT_EQ((*dense)[1], 10.f);
    EXPECT_EQ((*dense)[5], 50.f);
    EXPECT_TRUE(std::isnan((*dense)[0]));
    EXPECT_TRUE(std::isnan((*dense)[4])); // a row without a value
    EXPECT_TRUE(std::isnan((*dense)[6])); // no row
    EXPECT_EQ((*m.denseFloatColumn("label", 3))[2], 2.f);
    EXPECT_EQ((*m.denseFloatColumn("size", 2, -1.f))[0], -1.f);
    EXPECT_ERROR(m.denseFloatColumn("name", 7), "'name' holds text");
    EXPECT_ERROR(m.denseFloatColumn("nope", 7), "no attribute 'nope'", "label, size, name");
    Result<std::vector<float>> ids = m.denseFloatColumnForIds("size", {0, 5, 1, 3});
    ASSERT_TRUE(ids.isOk());
    EXPECT_TRUE(std::isnan((*ids)[0]));
    EXPECT_EQ((*ids)[1], 50.f);
    EXPECT_EQ((*ids)[2], 10.f);
    EXPECT_EQ((*ids)[3], 30.f);

    // The CPU material reference reads attributes through the table.
    Result<MaterialDocument> doc = parseMaterials(
        R"({"version": 1, "materials": [{"filter": {"attribute": "size", "min": 20, "max": 60}}]})");
    ASSERT_TRUE(doc.isOk()) << doc.message();
    MaterialEvaluator eval(*doc, m.attributeFunction());
    EXPECT_EQ(eval.materialOf(1), -1);
    EXPECT_EQ(eval.materialOf(3), 0);
    EXPECT_EQ(eval.materialOf(4), -1); // NaN is in no interval
    EXPECT_EQ(eval.materialOf(5), 0);

    AttributeColumn bad{"x", true, {1.0}, {}};
    EXPECT_ERROR(m.addColumn(bad), "1 values for 4 labels");
    EXPECT_ERROR(m.addColumn(AttributeColumn{"Label", true, {1, 2, 3, 4}, {}}, true), "cannot be replaced");
    EXPECT_TRUE(m.removeColumn("NAME"));
    EXPECT_FALSE(m.removeColumn("label"));
    EXPECT_ERROR(AttributeTable::fromLabels({4, 2, 4}), "label 4 appears twice");
}

// ---- SQLite --------------------------------------------------------------------------------

TEST(AttributesSqlite, AnyTableWithALabelColumn) {
    const std::string dir = freshDir("attr-sqlite");
    const std::string path = dir + "/cells.sqlite";
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    sqlExec(db, "CREATE TABLE cells (segment_id INTEGER, kind TEXT, nutrient REAL, stage)");
    sqlExec(db, "INSERT INTO cells VALUES (12, 'tumour', 2.25, 1), (4, 'vessel', NULL, '2'), (900, 'tumour', 0.5, 3)");
    sqlite3_close(db);

    Result<AttributeTable> t = readSqliteTable(path);
    ASSERT_TRUE(t.isOk()) << t.message();
    EXPECT_EQ(t->labels(), (std::vector<int64_t>{4, 12, 900}));
    EXPECT_EQ(t->columnNames(), (std::vector<std::string>{"label", "segment_id", "kind", "nutrient", "stage"}));
    EXPECT_EQ(t->text("kind", 4), "vessel");
    EXPECT_EQ(t->value("nutrient", 12), 2.25);
    EXPECT_TRUE(std::isnan(t->value("nutrient", 4)));
    EXPECT_TRUE(t->column("stage")->numeric); // text '2' reads as a number
    EXPECT_EQ(t->value("stage", 4), 2.0);

    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    sqlExec(db, "CREATE TABLE other (label INTEGER, x REAL)");
    sqlExec(db, "INSERT INTO other VALUES (1, 0.5), (1, 0.25)");
    sqlExec(db, "CREATE TABLE words (label TEXT)");
    sqlExec(db, "INSERT INTO words VALUES ('one')");
    sqlite3_close(db);
    EXPECT_ERROR(readSqliteTable(path), "several tables", "cells, other, words");
    {
        // Found by an attack pass: a database of 2000 tables listed every name in the message.
        const std::string many = dir + "/many.sqlite";
        ASSERT_EQ(sqlite3_open(many.c_str(), &db), SQLITE_OK);
        for (int i = 0; i < 30; ++i) sqlExec(db, "CREATE TABLE t" + std::to_string(i) + " (label INTEGER)");
        sqlite3_close(db);
        Result<AttributeTable> r = readSqliteTable(many);
        ASSERT_FALSE(r.isOk());
        EXPECT_NE(r.message().find("and 10 more"), std::string::npos) << r.message();
        EXPECT_EQ(r.message().find("t29"), std::string::npos) << r.message();
    }
    Result<AttributeTable> byName = readSqliteTable(path, "cells", "stage");
    ASSERT_TRUE(byName.isOk()) << byName.message();
    EXPECT_EQ(byName->labels(), (std::vector<int64_t>{1, 2, 3}));
    EXPECT_ERROR(readSqliteTable(path, "other"), "table 'other'", "row 2", "label 1 repeats");
    EXPECT_ERROR(readSqliteTable(path, "words"), "table 'words'", "row 1", "label 'one'");
    {
        // Found by an attack pass: a BLOB label was echoed raw and its NUL cut the message short.
        ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
        sqlExec(db, "CREATE TABLE blobs (label, x)");
        sqlExec(db, "INSERT INTO blobs VALUES (x'6162001b6364', 1)");
        sqlite3_close(db);
        EXPECT_ERROR(readSqliteTable(path, "blobs"), "row 1: label 'ab\\x00\\x1bcd' (column 'label') is not an integer");
    }
    EXPECT_ERROR(readSqliteTable(path, "missing"), "no table 'missing'");
    EXPECT_ERROR(readSqliteTable(path, "cells", "nope"), "no column named 'nope'");
    EXPECT_ERROR(readSqliteTable(dir + "/absent.sqlite"), "absent.sqlite");
}

TEST(AttributesSqlite, VolcaniteDatabaseRoundTrip) {
    // Volcanite wrote synthA_attributes.csv into its database: both sources agree.
    Result<AttributeTable> csv = readCsv(fixture("synthA_attributes.csv"));
    ASSERT_TRUE(csv.isOk()) << csv.message();
    Result<AttributeTable> theirs = readSqliteTable(fixture("synthA_b32_rans2_attr_csgv.db3"));
    ASSERT_TRUE(theirs.isOk()) << theirs.message();
    EXPECT_EQ(theirs->labels(), csv->labels());
    EXPECT_TRUE(theirs->hasColumn("csgv_id"));
    for (const char* name : {"voxels", "kind", "score"}) {
        SCOPED_TRACE(name);
        // Volcanite stores its REAL columns as 32-bit floats.
        for (int64_t l : csv->labels()) EXPECT_EQ(float(theirs->value(name, l)), float(csv->value(name, l))) << l;
    }
    Result<AttributeDatabase> db = readAttributeDb(fixture("synthA_b32_rans2_attr_csgv.db3"));
    ASSERT_TRUE(db.isOk()) << db.message();
    for (size_t id = 0; id < db->labels.size(); ++id)
        EXPECT_EQ(theirs->value("csgv_id", db->labels[id]), double(id));

    // Our table (with a text and a derived column) through the writer and back.
    AttributeTable ours = *csv;
    ASSERT_TRUE(addDerivedAttribute(ours, "kind_name", "CASE kind WHEN 0 THEN 'a' WHEN 2 THEN 'c' END").isOk());
    std::vector<uint64_t> bits(db->labels.begin(), db->labels.end());
    const std::string path = freshDir("attr-db3") + "/vol_csgv.db3";
    ASSERT_TRUE(writeAttributeDb(path, db->volumeDim, bits, false, columnsForIds(ours, db->labels)).isOk());
    Result<AttributeTable> back = readSqliteTable(path);
    ASSERT_TRUE(back.isOk()) << back.message();
    ASSERT_TRUE(ours.merge(*theirs, AttributeTable::OnConflict::Keep).isOk()); // adds csgv_id
    AttributeTable expected = *AttributeTable::fromLabels(ours.labels());
    for (const char* name : {"csgv_id", "voxels", "kind", "score", "kind_name"})
        ASSERT_TRUE(expected.addColumn(*ours.column(name)).isOk());
    expectSameTable(*back, expected);
}

TEST(AttributesSqlite, WriterNeverTouchesAnotherWritersTemporary) {
    // Two compressions of one input (MPI ranks, two sessions) write the same database at once:
    // each builds its own temporary, so one never removes or publishes the other's half file.
    const std::string dir = freshDir("attr-db3-tmp");
    const std::string path = dir + "/vol_csgv.db3";
    const std::string others = path + ".tmp-db"; // the name every writer used to share
    { std::ofstream(others) << "another writer's half database"; }
    const std::vector<uint64_t> bits = {0, 7, 3};
    ASSERT_TRUE(writeAttributeDb(path, {4, 4, 4}, bits, false).isOk());
    EXPECT_TRUE(std::filesystem::exists(others));
    Result<AttributeDatabase> db = readAttributeDb(path);
    ASSERT_TRUE(db.isOk()) << db.message();
    EXPECT_EQ(db->labels, (std::vector<int64_t>{0, 7, 3}));
    size_t files = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
        (void)e;
        ++files;
    }
    EXPECT_EQ(files, 2u) << "a temporary was left beside the database";
}

// ---- derived attributes ---------------------------------------------------------------------

TEST(AttributesDerived, LabelsWhereAConditionHolds) {
    Result<AttributeTable> t = parseCsv("1 Precentral_L 2001\n2 Precentral_R 2002\n95 Vermis_1_2 9100\n7 Odd 5\n");
    ASSERT_TRUE(t.isOk()) << t.message();
    Result<std::vector<int64_t>> l = labelsWhere(*t, "code > 2001 and name LIKE '%\\_%' ESCAPE '\\'");
    ASSERT_TRUE(l.isOk()) << l.message();
    EXPECT_EQ(*l, (std::vector<int64_t>{2, 95}));
    EXPECT_EQ(*labelsWhere(*t, "name = 'Odd' or label = 1"), (std::vector<int64_t>{1, 7}));
    EXPECT_TRUE(labelsWhere(*t, "0")->empty());
    EXPECT_EQ(t->columnNames().size(), 3u) << "the table is left as it was";
    // A column named like the helper's is no clash.
    AttributeTable u = *t;
    ASSERT_TRUE(addDerivedAttribute(u, "csgv_condition", "label * 0").isOk());
    EXPECT_EQ(*labelsWhere(u, "label > 90"), (std::vector<int64_t>{95}));
    EXPECT_ERROR(labelsWhere(*t, "name"), "gives text");
    EXPECT_ERROR(labelsWhere(*t, "   "), "empty");
    EXPECT_FALSE(labelsWhere(*t, "code >").isOk());
    EXPECT_FALSE(labelsWhere(*t, "nope = 1").isOk());
}

TEST(AttributesDerived, HemisphereFromRegionNames) {
    Result<AttributeTable> t = parseCsv("1 Precentral_L 2001\n2 Precentral_R 2002\n95 Vermis_1_2 9100\n"
                                        "3 Odd_Lx 1\n");
    ASSERT_TRUE(t.isOk()) << t.message();
    const std::string hemi =
        "CASE WHEN name LIKE '%\\_L' ESCAPE '\\' THEN 0 WHEN name LIKE '%\\_R' ESCAPE '\\' THEN 1 END";
    ASSERT_TRUE(addDerivedAttribute(*t, "hemisphere", hemi).isOk());
    EXPECT_EQ(t->value("hemisphere", 1), 0.0);
    EXPECT_EQ(t->value("hemisphere", 2), 1.0);
    EXPECT_TRUE(std::isnan(t->value("hemisphere", 95)));
    EXPECT_TRUE(std::isnan(t->value("hemisphere", 3)));
    ASSERT_TRUE(addDerivedAttribute(*t, "lobe", "substr(name, 1, instr(name, '_') - 1)").isOk());
    EXPECT_FALSE(t->column("lobe")->numeric);
    EXPECT_EQ(t->text("lobe", 95), "Vermis");
    ASSERT_TRUE(addDerivedAttribute(*t, "group", "CAST(code / 1000 AS INTEGER) + label * 0").isOk());
    EXPECT_EQ(t->value("group", 95), 9.0);
    ASSERT_TRUE(addDerivedAttribute(*t, "group", "code * 2", true).isOk());
    EXPECT_EQ(t->value("group", 2), 4004.0);
    // Sub-queries over the table `t` see every label (normalisation, ranks).
    ASSERT_TRUE(addDerivedAttribute(*t, "relative", "code / (SELECT max(code) FROM t)").isOk());
    EXPECT_EQ(t->value("relative", 95), 1.0);

    // A column named rowid does not reorder the results.
    Result<AttributeTable> r = parseCsv("label,rowid\n1,30\n2,20\n3,10\n");
    ASSERT_TRUE(r.isOk()) << r.message();
    ASSERT_TRUE(addDerivedAttribute(*r, "twice", "label * 2 + 0 * rowid").isOk());
    EXPECT_EQ(r->column("twice")->values, (std::vector<double>{2, 4, 6}));

    EXPECT_ERROR(addDerivedAttribute(*t, "h", "CASE WHEN nme LIKE 'x' THEN 1 END"), "derived attribute 'h'",
                 "no such column: nme", "(expression: CASE WHEN nme LIKE 'x' THEN 1 END)");
    EXPECT_ERROR(addDerivedAttribute(*t, "h", "1 +"), "syntax error", "(expression: 1 +)");
    EXPECT_ERROR(addDerivedAttribute(*t, "h", "1) FROM t; DROP TABLE t; SELECT (1"), "single SQL expression");
    EXPECT_ERROR(addDerivedAttribute(*t, "hemisphere", "1"), "already exists");
    EXPECT_ERROR(addDerivedAttribute(*t, "label", "1"), "'label' is the label itself");
    EXPECT_FALSE(t->hasColumn("h"));

    if (std::filesystem::exists(kAalTable)) { // 54 regions end in _L, 54 in _R, 8 vermis
        Result<AttributeTable> aal = readCsv(kAalTable);
        ASSERT_TRUE(aal.isOk());
        ASSERT_TRUE(addDerivedAttribute(*aal, "hemisphere", hemi).isOk());
        int left = 0, right = 0;
        for (double v : aal->column("hemisphere")->values) {
            left += v == 0;
            right += v == 1;
        }
        EXPECT_EQ(left, 54);
        EXPECT_EQ(right, 54);
    }
}

// A hostile expression ends with an error naming its budget, not after hours or gigabytes; a
// Ctrl-C (cancelRequested) stops it too. The time ceiling is far above what the budget allows:
// without it this statement runs for hours.
TEST(AttributesDerived, HostileExpressionsStopAtTheirBudget) {
    std::string csv = "label,code\n";
    for (int i = 1; i <= 400; ++i) csv += std::to_string(i) + "," + std::to_string(i * 7) + "\n";
    Result<AttributeTable> t = parseCsv(csv);
    ASSERT_TRUE(t.isOk()) << t.message();
    DerivedBudget quick;
    quick.seconds = 0.3;
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_ERROR(addDerivedAttribute(*t, "d", "(SELECT count(*) FROM t a, t b, t c, t d2)", false, quick),
                 "derived attribute 'd'", "time budget of 0.3 s");
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 20.0);
    EXPECT_ERROR(addDerivedAttribute(*t, "d", "length(zeroblob(2000000000))"), "larger than the budget of 1048576 bytes");
    EXPECT_ERROR(addDerivedAttribute(*t, "d", "hex(zeroblob(1000000))"), "larger than the budget");
    DerivedBudget small;
    small.resultBytes = 4096;
    EXPECT_ERROR(addDerivedAttribute(*t, "d", "hex(zeroblob(20))", false, small),
                 "exceed the budget of 4096 bytes");
    requestCancel();
    EXPECT_ERROR(addDerivedAttribute(*t, "d", "(SELECT count(*) FROM t a, t b, t c, t d2)"), "cancelled");
    resetCancel();
    EXPECT_FALSE(t->hasColumn("d"));
    ASSERT_TRUE(addDerivedAttribute(*t, "d", "(SELECT count(*) FROM t a, t b)").isOk()); // 160000 rows: fine
    EXPECT_EQ(t->value("d", 3), 160000.0);
    // What is refused is named (found by an attack pass: SQLite's bare "not authorized").
    EXPECT_ERROR(addDerivedAttribute(*t, "q", "(SELECT 1 FROM pragma_page_count())"), "is not allowed", "may only read");
    EXPECT_ERROR(addDerivedAttribute(*t, "p", "(SELECT * FROM pragma_table_info('t'))"), "the database schema (sqlite_master) is not allowed",
                 "may only read");
    EXPECT_ERROR(addDerivedAttribute(*t, "r", "(WITH RECURSIVE c(x) AS (SELECT 1 UNION ALL SELECT x + 1 FROM c WHERE x < 5) SELECT max(x) FROM c)"),
                 "a recursive query (WITH RECURSIVE) is not allowed");
}

// Columns are found by a name index: a table of the most columns a table may have (2000) builds
// in linear time, lookups ignore case, and duplicates (ignoring case) are still refused.
TEST(AttributesCsv, ColumnsAreFoundByName) {
    const int columns = 2000;
    std::string header = "label", row = "1";
    for (int c = 1; c < columns; ++c) {
        header += ",c" + std::to_string(c);
        row += "," + std::to_string(c);
    }
    Result<AttributeTable> t = parseCsv(header + "\n" + row + "\n2" + row.substr(1) + "\n");
    ASSERT_TRUE(t.isOk()) << t.message();
    EXPECT_EQ(t->columns().size(), size_t(columns));
    EXPECT_EQ(t->value("c1999", 2), 1999.0);
    EXPECT_EQ(t->value("C5", 1), 5.0) << "lookups ignore case";
    EXPECT_ERROR(parseCsv("label,a,A\n1,2,3\n"), "'A' appears twice");
    ASSERT_TRUE(t->removeColumn("c7"));
    EXPECT_FALSE(t->hasColumn("C7"));
    EXPECT_EQ(t->value("c1999", 2), 1999.0) << "the index follows a removal";
}

// ---- computed attributes --------------------------------------------------------------------

TEST(AttributesComputed, EqualBruteForceOnSyntheticVolumes) {
    struct Case {
        uint32_t w, h, d, cell, brick;
    };
    for (const Case& c : {Case{37, 29, 23, 5, 8}, Case{37, 29, 23, 5, 16}, Case{70, 45, 33, 9, 32},
                          Case{64, 64, 32, 7, 16}, Case{5, 3, 130, 4, 64}, Case{48, 40, 36, 2, 16}}) {
        SCOPED_TRACE(std::to_string(c.w) + "x" + std::to_string(c.h) + "x" + std::to_string(c.d) + " brick " +
                     std::to_string(c.brick));
        const LabelVolume src = synthVolume(c.w, c.h, c.d, 7, c.cell);
        const CompressedVolume vol = compress(src, c.brick);
        Result<LabelVolume> decoded = decodeVolume(vol, 0);
        ASSERT_TRUE(decoded.isOk()) << decoded.message();
        ASSERT_EQ(decoded->labels, src.labels);
        Result<AttributeTable> one = computeWith(vol, 1);
        Result<AttributeTable> two = computeWith(vol, 2);
        ASSERT_TRUE(one.isOk()) << one.message();
        ASSERT_TRUE(two.isOk()) << two.message();
        EXPECT_EQ(one->columnNames().size(), 1 + computedAttributeNames().size());
        expectMatchesReference(*one, bruteForce(*decoded, true));
        expectSameTable(*one, *two);
        Result<AttributeTable> inner = computeWith(vol, 2, false);
        ASSERT_TRUE(inner.isOk()) << inner.message();
        expectMatchesReference(*inner, bruteForce(*decoded, false));
    }
}

TEST(AttributesComputed, PiecesSummedWithTheirLayersEqualTheWholeVolume) {
    // MPI ranks: each computes the sums of its whole-brick piece, the sums are added, faces
    // between touching pieces come from their outer layers; the table equals the whole volume's.
    const LabelVolume src = synthVolume(70, 45, 33, 7, 6);
    for (uint32_t brick : {8u, 16u}) {
        const CompressedVolume vol = compress(src, brick);
        for (bool boundary : {true, false}) {
            ComputeAttributesOptions o;
            o.countBoundaryFaces = boundary;
            Result<AttributeTable> whole = computeAttributes(vol, o);
            ASSERT_TRUE(whole.isOk()) << whole.message();
            for (uint32_t n : {2u, 3u, 5u, 8u}) {
                SCOPED_TRACE("brick " + std::to_string(brick) + ", " + std::to_string(n) + " pieces");
                AttributeSums total;
                std::vector<PieceLayers> layers;
                for (uint32_t p = 0; p < n; ++p) {
                    const BrickBox box = brickPartition(vol.brickGrid(), n, p);
                    if (box.empty()) continue;
                    Result<CompressedVolume> piece = extractPiece(vol, box);
                    ASSERT_TRUE(piece.isOk()) << piece.message();
                    const std::array<uint32_t, 3> offset = {box.lo[0] * brick, box.lo[1] * brick, box.lo[2] * brick};
                    Result<AttributeSums> sums = computeAttributeSums(*piece, o, offset, vol.dim);
                    ASSERT_TRUE(sums.isOk()) << sums.message();
                    total.add(*sums);
                    const std::array<uint32_t, 3> end = {offset[0] + piece->dim[0], offset[1] + piece->dim[1],
                                                         offset[2] + piece->dim[2]};
                    Result<PieceLayers> l = pieceLayers(vol, offset, end);
                    ASSERT_TRUE(l.isOk()) << l.message();
                    layers.push_back(std::move(*l));
                }
                AttributeSums withoutFaces = total;
                addFacesBetweenPieces(total, layers);
                Result<AttributeTable> joined = attributeTable(total, o);
                ASSERT_TRUE(joined.isOk()) << joined.message();
                expectSameTable(*whole, *joined);
                // Without the faces between pieces the surface areas are short.
                Result<AttributeTable> short_ = attributeTable(withoutFaces, o);
                ASSERT_TRUE(short_.isOk());
                auto faces = [](const AttributeTable& t) {
                    double sum = 0;
                    for (double v : t.column("surface_area")->values) sum += v;
                    return sum;
                };
                EXPECT_LT(faces(*short_), faces(*whole));
            }
        }
    }
    // Ghost faces: the labels just outside each piece, from its neighbours' layers.
    {
        const CompressedVolume v16 = compress(src, 16);
        std::vector<PieceLayers> layers;
        std::vector<BrickBox> boxes;
        for (uint32_t p = 0; p < 5; ++p) {
            const BrickBox box = brickPartition(v16.brickGrid(), 5, p);
            const std::array<uint32_t, 3> offset = {box.lo[0] * 16, box.lo[1] * 16, box.lo[2] * 16};
            const CompressedVolume piece = *extractPiece(v16, box);
            const std::array<uint32_t, 3> end = {offset[0] + piece.dim[0], offset[1] + piece.dim[1],
                                                 offset[2] + piece.dim[2]};
            layers.push_back(*pieceLayers(v16, offset, end));
            boxes.push_back(box);
        }
        for (const PieceLayers& mine : layers) {
            const auto ghosts = ghostFaces(mine.lo, mine.hi, v16.dim, layers);
            for (int side = 0; side < 6; ++side) {
                const int a = side / 2, u = a == 0 ? 1 : 0, v = a == 2 ? 1 : 2;
                const bool plus = side % 2 == 1;
                const bool boundary = plus ? mine.hi[a] == v16.dim[a] : mine.lo[a] == 0;
                ASSERT_EQ(ghosts[size_t(side)].empty(), boundary);
                if (boundary) continue;
                bool same = true;
                for (uint32_t y = mine.lo[v]; y < mine.hi[v]; ++y)
                    for (uint32_t x = mine.lo[u]; x < mine.hi[u]; ++x) {
                        std::array<uint32_t, 3> p{};
                        p[size_t(a)] = plus ? mine.hi[a] : mine.lo[a] - 1;
                        p[size_t(u)] = x;
                        p[size_t(v)] = y;
                        same &= ghosts[size_t(side)][(x - mine.lo[u]) + size_t(mine.hi[u] - mine.lo[u]) * (y - mine.lo[v])] ==
                                src.at(p[0], p[1], p[2]);
                    }
                EXPECT_TRUE(same) << "side " << side;
            }
        }
    }
    // A piece that does not fit its volume is an error.
    const CompressedVolume vol = compress(src, 16);
    EXPECT_FALSE(computeAttributeSums(vol, {}, {1, 0, 0}, vol.dim).isOk());
    EXPECT_FALSE(pieceLayers(vol, {0, 0, 1}, {vol.dim[0], vol.dim[1], vol.dim[2] + 1}).isOk());
    EXPECT_FALSE(pieceLayers(vol, {0, 5, 0}, {4, 5, 4}).isOk()) << "empty";
}

TEST(AttributesComputed, RelabelledVolumesReportOriginalLabels) {
    const LabelVolume src = synthVolume(50, 40, 30, 3, 6);
    InputVolume in;
    in.dim = src.dim;
    in.values.assign(src.labels.begin(), src.labels.end());
    LabelMapping mapping;
    Result<LabelVolume> ids = prepareLabels(in, 16, true, mapping);
    ASSERT_TRUE(ids.isOk()) << ids.message();
    const CompressedVolume plain = compress(src, 16), relabelled = compress(*ids, 16);
    std::vector<int64_t> idToLabel(mapping.originalBits.begin(), mapping.originalBits.end());
    Result<AttributeTable> a = computeWith(plain, 2);
    Result<AttributeTable> b = computeWith(relabelled, 2, true, &idToLabel);
    ASSERT_TRUE(a.isOk() && b.isOk()) << a.message() << b.message();
    expectSameTable(*a, *b);
    // The GPU view: floats indexed by id.
    Result<std::vector<float>> counts = b->denseFloatColumnForIds("voxel_count", idToLabel);
    ASSERT_TRUE(counts.isOk());
    for (size_t id = 0; id < idToLabel.size(); ++id)
        EXPECT_EQ((*counts)[id], float(a->value("voxel_count", idToLabel[id])));

    // A relabelled file opened with its database reports original labels by itself.
    const std::string dir = freshDir("attr-relabelled");
    CompressOptions co;
    co.relabel = true;
    co.encode.brickSize = 16;
    ASSERT_TRUE(compressToFile("synth:50x40x30:3", dir + "/v.csgv", co).isOk());
    Result<CsgvFile> file = openCsgv(dir + "/v.csgv");
    ASSERT_TRUE(file.isOk()) << file.message();
    ASSERT_TRUE(file->hasAttributes);
    Result<AttributeTable> fromFile = computeAttributes(*file, 2);
    ASSERT_TRUE(fromFile.isOk()) << fromFile.message();
    Result<AttributeTable> synthPlain = computeWith(compress(*generateVolume(*parseSynthSpec("synth:50x40x30:3")), 16), 1);
    ASSERT_TRUE(synthPlain.isOk());
    expectSameTable(*fromFile, *synthPlain);

    std::vector<int64_t> shortMap(idToLabel.begin(), idToLabel.begin() + 3);
    EXPECT_ERROR(computeWith(relabelled, 1, true, &shortMap), "past the end of the id -> label table");
    std::vector<int64_t> collide = idToLabel;
    collide[2] = collide[1];
    EXPECT_ERROR(computeWith(relabelled, 1, true, &collide), "maps two ids");
}

TEST(AttributesComputed, AalAtlasEqualsBruteForceAndJoinsItsTable) {
    if (!std::filesystem::exists(kAalVolume)) GTEST_SKIP() << kAalVolume << " not found; install mricron-data";
    Result<InputVolume> in = readNifti(kAalVolume);
    ASSERT_TRUE(in.isOk()) << in.message();
    LabelMapping mapping;
    Result<LabelVolume> labels = prepareLabels(*in, 32, false, mapping);
    ASSERT_TRUE(labels.isOk()) << labels.message();
    const CompressedVolume vol = compress(*labels, 32);
    Result<AttributeTable> one = computeWith(vol, 1);
    Result<AttributeTable> two = computeWith(vol, 2);
    ASSERT_TRUE(one.isOk()) << one.message();
    ASSERT_TRUE(two.isOk()) << two.message();
    expectSameTable(*one, *two);
    expectMatchesReference(*one, bruteForce(*labels, true));
    EXPECT_EQ(one->rowCount(), 117u);
    EXPECT_EQ(one->value("voxel_count", 0) + 1479969.0, 181.0 * 217 * 181);

    if (!std::filesystem::exists(kAalTable)) return;
    Result<AttributeTable> names = readCsv(kAalTable);
    ASSERT_TRUE(names.isOk());
    AttributeTable joined = *one;
    ASSERT_TRUE(joined.merge(*names).isOk());
    EXPECT_EQ(joined.rowCount(), 117u); // every region of the table occurs in the volume
    EXPECT_EQ(joined.text("name", 0), "");
    EXPECT_EQ(joined.text("name", 1), "Precentral_L");
    EXPECT_GT(joined.value("voxel_count", 1), 1000.0);
}

TEST(AttributesComputed, CorruptStreamsAreErrorsNeverCrashes) {
    // Seeded mutations of the words of a small volume: the attributes succeed exactly when every
    // brick decodes, and then still equal the brute-force count over the decoded volume.
    const CompressedVolume clean = compress(synthVolume(40, 33, 20, 5, 6), 16);
    uint64_t state = 12345;
    auto next = [&] {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        return uint32_t(state >> 33);
    };
    int failures = 0;
    for (int i = 0; i < 60; ++i) {
        CompressedVolume vol = clean;
        std::vector<uint32_t>& words = vol.arrays[0].owned();
        for (int k = 0; k < 3; ++k) words[next() % words.size()] ^= 1u << (next() % 32);
        SCOPED_TRACE("mutation " + std::to_string(i));
        const bool valid = checkContainer(vol).isOk() && validateStreams(vol, 1).isOk();
        Result<AttributeTable> t = computeWith(vol, 2);
        ASSERT_EQ(t.isOk(), valid) << t.message();
        if (!valid) {
            ++failures;
            continue;
        }
        Result<LabelVolume> decoded = decodeVolume(vol, 0);
        ASSERT_TRUE(decoded.isOk());
        expectMatchesReference(*t, bruteForce(*decoded, true));
    }
    EXPECT_GT(failures, 10);
}

TEST(ComputedAttributes, ProgressIsReportedAndCancelStops) {
    const CompressedVolume vol = loadFixture("synthA_b16_rans2_legacydelta.csgv");
    ComputeAttributesOptions o;
    std::vector<double> seen;
    o.progress = [&](double f) {
        seen.push_back(f);
        return true;
    };
    Result<AttributeTable> all = computeAttributes(vol, o);
    ASSERT_TRUE(all.isOk()) << all.message();
    ASSERT_FALSE(seen.empty());
    EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
    EXPECT_GE(seen.front(), 0.0);
    EXPECT_LT(seen.back(), 1.0);
    Result<AttributeTable> plain = computeAttributes(vol);
    ASSERT_TRUE(plain.isOk());
    EXPECT_EQ(all->labels(), plain->labels()) << "progress changes nothing";
    int calls = 0;
    o.progress = [&](double) { return ++calls < 3; };
    Result<AttributeTable> stopped = computeAttributes(vol, o);
    ASSERT_FALSE(stopped.isOk());
    EXPECT_EQ(stopped.message(), "cancelled");
}
