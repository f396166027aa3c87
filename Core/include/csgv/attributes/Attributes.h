// SPDX-License-Identifier: MIT
#pragma once
/// @file Attributes.h
/// @brief The attribute store: per-label attributes from CSV and SQLite tables (Volcanite's
/// `_csgv.db3` included), derived attributes from SQL expressions, and attributes computed from
/// the compressed volume brick by brick (voxel count, surface area, bounding box, centroid).
///
/// Decisions (tested in Testing/Core/test_attributes.cpp):
/// - A table is keyed by **original label** (int64; unsigned 64-bit labels as their int64 bits),
///   rows sorted by ascending label, each label once. Its first column is always `label` (the
///   label as a double). The GPU indexes by the value the volume stores: denseFloatColumn() for
///   volumes that store labels, denseFloatColumnForIds() for relabelled ones (id -> label from
///   the attribute database).
/// - Numeric columns hold doubles, NaN where a value is missing; text columns hold strings, ""
///   where missing. Column names are unique ignoring ASCII case (they become SQLite columns).
/// - The source's label column is renamed `label`; when its name was something else (`id`), a
///   numeric copy under that name is kept too, so documents that name it still work.
/// - Computed attributes: `voxel_count`, `surface_area` (exposed voxel faces: a face between a
///   voxel and a 6-neighbour of another label, and by default a face on the volume boundary),
///   `bbox_min_x/y/z`, `bbox_max_x/y/z` (inclusive voxel indices), `centroid_x/y/z` (mean voxel
///   centre in voxel units, voxel i spanning [i, i+1] so its centre is i + 0.5; world position is
///   origin + centroid * spacing, through the direction matrix). Label 0 is reported like any
///   other label.

#include "csgv/attributes/AttributeDb.h"
#include "csgv/codec/Container.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/base/Status.h"

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

namespace csgv {

/// @brief Per-label attributes: sorted labels and one column per attribute, `label` first.
class AttributeTable {
public:
    /// What merge() does when both tables have a column of the same name.
    enum class OnConflict { Fail, Replace, Keep };

    /// An empty table (no rows, the `label` column only).
    AttributeTable();
    /// A table with these labels (any order; sorted here) and the `label` column only; an
    /// error names a label that repeats.
    static Result<AttributeTable> fromLabels(std::vector<int64_t> labels);

    size_t rowCount() const { return m_labels.size(); }
    /// Labels in ascending order; row i holds label labels()[i].
    const std::vector<int64_t>& labels() const { return m_labels; }
    /// Row of a label, or -1.
    int64_t rowOf(int64_t label) const;

    /// Every column, `label` first; values indexed by row.
    const std::vector<AttributeColumn>& columns() const { return m_columns; }
    std::vector<std::string> columnNames() const;
    /// The column of that name (exact, then ignoring ASCII case), or nullptr.
    const AttributeColumn* column(const std::string& name) const;
    bool hasColumn(const std::string& name) const { return column(name) != nullptr; }

    /// Adds a column of rowCount() values; an error when the name is empty, taken (ignoring
    /// case) or the size is wrong. replace: an existing column (not `label`) of that name is
    /// replaced instead.
    Status addColumn(AttributeColumn column, bool replace = false);
    /// Removes a column (not `label`); false when absent.
    bool removeColumn(const std::string& name);

    /// Joins another table on the label: the result has the union of both label sets (missing
    /// values NaN or ""), and the other table's columns added; `label` is never duplicated.
    Status merge(const AttributeTable& other, OnConflict onConflict = OnConflict::Fail);

    /// A numeric value by label; NaN when the label, the column or the value is missing or the
    /// column is text. "label" gives the label itself even for labels without a row.
    double value(const std::string& name, int64_t label) const;
    /// The text of a value for display (numbers printed shortest round-trip); "" when missing.
    std::string text(const std::string& name, int64_t label) const;
    /// Smallest and largest non-NaN value of a numeric column (NaN, NaN when it has none).
    Result<std::array<double, 2>> range(const std::string& name) const;

    /// The column as floats indexed by label value: entry v holds label v's value for v in
    /// [0, labelCount), `missing` where the label has no row (NaN: no material filter takes it).
    /// Labels outside that range are ignored. Text columns are an error.
    Result<std::vector<float>> denseFloatColumn(const std::string& name, uint64_t labelCount,
                                                float missing = std::numeric_limits<float>::quiet_NaN()) const;
    /// The column as floats indexed by id of a relabelled volume: entry i holds the value of
    /// label idToLabel[i] (AttributeDatabase::labels).
    Result<std::vector<float>> denseFloatColumnForIds(const std::string& name, const std::vector<int64_t>& idToLabel,
                                                      float missing = std::numeric_limits<float>::quiet_NaN()) const;

    /// An attribute function for MaterialEvaluator (value(name, label)). The table must outlive it.
    std::function<double(const std::string&, uint32_t)> attributeFunction() const;

private:
    /// Rebuilds m_byName after columns were removed (indices shift).
    void reindex();

    std::vector<int64_t> m_labels;
    std::vector<AttributeColumn> m_columns;
    /// Lower-case column name -> index: names are unique ignoring case (addColumn), and a lookup
    /// per added column keeps a table of 100k columns linear to build, not quadratic.
    std::unordered_map<std::string, size_t> m_byName;
};

/// Label column names recognised (ignoring case) when none is named: the first column whose name
/// is one of these, else the first column.
const std::vector<std::string>& labelColumnCandidates();

/// @brief How to read a delimited text table.
struct CsvOptions {
    enum class Header { Auto, Present, Absent };
    /// The label column by name; "" picks one (labelColumnCandidates()).
    std::string labelColumn;
    /// ',', ';', '\t', or ' ' for runs of blanks; 0 detects: the most frequent of ',', '\t', ';'
    /// on the first line outside quotes, blanks when none occurs.
    char delimiter = 0;
    /// Auto: the first row is a header when none of its fields is a number, or when a column that
    /// is numeric in every later row is not numeric in the first.
    Header header = Header::Auto;
    /// Names for a table without a header (else generated: column 1 `label`, the first text
    /// column `name`, in MRIcron's 3-column layout number/text/number the third `code`,
    /// others `colN` by 1-based position).
    std::vector<std::string> columnNames;
};

/// The largest attribute text file readCsv reads (parsing holds a few times its size).
constexpr uint64_t kMaxAttributeTextBytes = uint64_t(512) << 20;

/// Parses a delimited table: quoted fields ("a ""b""", delimiters and newlines inside quotes),
/// unquoted fields trimmed, CR LF or LF, a UTF-8 BOM, blank lines and lines starting with '#'
/// skipped. Columns whose non-empty fields are all numbers are numeric (empty and `NA` count as
/// missing); others are text. Labels are integers (integral floats such as `3.0` too). Errors
/// name `source`, the line and what is wrong: field counts, unterminated quotes, non-integer,
/// missing or repeated labels, more than 2000 columns (SQLite's limit: tables end up there).
Result<AttributeTable> parseCsv(const std::string& text, const CsvOptions& options = {},
                                const std::string& source = "CSV");
/// Reads a file and parses it with parseCsv() (errors name the path).
Result<AttributeTable> readCsv(const std::string& path, const CsvOptions& options = {});

/// Reads one table of an SQLite database (read-only). table "": `csgv_attribute` when present,
/// else the only table (several are an error listing them). labelColumn "": as for CSV.
/// Values stored as numbers (or text that parses as one) give numeric columns; NULL is missing.
/// A Volcanite database (table `csgv_attribute`) is read through readAttributeDb(), keyed by its
/// original labels, with `csgv_id` as a numeric column.
Result<AttributeTable> readSqliteTable(const std::string& path, const std::string& table = "",
                                       const std::string& labelColumn = "");

/// The attributes of a Volcanite database, keyed by original label, with `csgv_id` as a column.
Result<AttributeTable> attributesFromDatabase(const AttributeDatabase& db);
/// A table from a file chosen by its extension: SQLite (`.db3`, `.db`, `.sqlite`, `.sqlite3`:
/// readSqliteTable) or text (anything else: readCsv). Errors name the file.
Result<AttributeTable> readAttributeFile(const std::string& path);
/// Columns indexed by id for writeAttributeDb(): row i of each column is the value of label
/// idToLabel[i] (NaN/"" when the table lacks it); `label` and `csgv_id` are left out.
std::vector<AttributeColumn> columnsForIds(const AttributeTable& table, const std::vector<int64_t>& idToLabel);

/// Adds (or with replace, replaces) the column `name` holding the value of an SQL expression
/// over the table's columns for each row, evaluated by SQLite in memory (for example
/// `CASE WHEN name LIKE '%\_L' ESCAPE '\' THEN 0 WHEN name LIKE '%\_R' ESCAPE '\' THEN 1 END`).
/// The expression sees one row per label of a table `t` (so sub-queries such as
/// `code / (SELECT max(code) FROM t)` work): `label` as INTEGER, numeric columns as REAL (use
/// CAST(... AS INTEGER) for integer arithmetic), missing values as NULL, text columns as TEXT.
/// Only a single expression is accepted and it may only read. Results that are all numbers or
/// NULL give a numeric column, otherwise text. SQLite's errors come back with the expression.
///
/// A hostile expression cannot hold a session: it runs under a budget (DerivedBudget) of time,
/// of a value's size and of the result's bytes, and stops at cancelRequested() (Cancel.h); each
/// ends it with an error naming the budget.
struct DerivedBudget {
    double seconds = 10;                      ///< wall-clock time of the whole evaluation
    int64_t valueBytes = int64_t(1) << 20;    ///< the largest string or blob the expression makes
    uint64_t resultBytes = uint64_t(256) << 20; ///< all result values together, as text
};
Status addDerivedAttribute(AttributeTable& table, const std::string& name, const std::string& expression,
                           bool replace = false, const DerivedBudget& budget = {});
/// The labels (ascending) of the table's rows for which the SQL condition `condition` over its
/// columns is true (non-zero, not NULL), e.g. `voxels > 1000 and region = 'hippocampus'`: an
/// addDerivedAttribute() on a copy, with its rules and budget. An error when the condition is not
/// valid SQL or gives text.
Result<std::vector<int64_t>> labelsWhere(const AttributeTable& table, const std::string& condition,
                                         const DerivedBudget& budget = {});

/// @brief Options of computeAttributes().
struct ComputeAttributesOptions {
    int threads = 0;                 ///< 0: OpenMP's default
    bool countBoundaryFaces = true;  ///< faces on the volume's boundary count as exposed
    /// When set, the volume stores ids into this table (AttributeDatabase::labels): results are
    /// keyed by original label; an id past its end is an error.
    const std::vector<int64_t>* idToLabel = nullptr;
    /// Called now and then with the fraction done (0..1), on the calling thread; false stops the
    /// work with the error "cancelled" (within a brick's decode per thread).
    std::function<bool(double)> progress;
};

/// Names of the computed columns, in table order.
const std::vector<std::string>& computedAttributeNames();

/// Computes the attributes of every label that occurs in the volume at full resolution, decoding
/// one brick at a time per thread, never the whole volume. Bricks are visited one z-layer of
/// bricks at a time; each brick leaves its six boundary faces behind so faces across brick
/// borders are compared after its neighbours are decoded. Memory: the faces of two brick layers
/// (about 28 bytes per voxel of a W x H slice) plus, per thread, about 100 bytes per label it
/// meets; per-thread statistics are integers merged at the end, so results do not depend on the
/// thread count.
Result<AttributeTable> computeAttributes(const CompressedVolume& volume, const ComputeAttributesOptions& options = {});
/// The same for an opened file: ids are mapped to original labels when it was relabelled.
Result<AttributeTable> computeAttributes(const CsgvFile& file, int threads = 0);

/// @brief The exact integer statistics behind computeAttributes(), per stored label, for a
/// volume held in whole-brick pieces (MPI ranks): every piece gives its sums
/// (computeAttributeSums with its offset), the sums add up, addFacesBetween adds the faces across
/// the pieces' touching sides from their outer voxel layers, and attributeTable() of the total
/// equals computeAttributes() of the whole volume, bit for bit.
struct AttributeSums {
    /// Values per label: count, faces, sum x, y, z, min x, y, z, max x, y, z (voxel indices of
    /// the volume).
    static constexpr size_t kValues = 11;
    std::vector<uint32_t> keys;   ///< stored labels, ascending
    std::vector<uint64_t> values; ///< kValues per key
    /// Merges another piece's sums.
    void add(const AttributeSums& other);
    /// Faces between two touching layers of n voxels (a[i] faces b[i]): one face more for each
    /// side of every pair of different labels.
    void addFacesBetween(const uint32_t* a, const uint32_t* b, size_t n);
};
/// The sums of `volume`, which is the piece of a volume of `volumeDims` voxels (zero: the piece is
/// the volume) whose voxel (0,0,0) is voxel `offset`: voxel indices are the volume's, and the
/// faces on the piece's sides inside the volume are left out (its neighbours' layers settle them).
Result<AttributeSums> computeAttributeSums(const CompressedVolume& volume, const ComputeAttributesOptions& options = {},
                                           const std::array<uint32_t, 3>& offset = {},
                                           const std::array<uint32_t, 3>& volumeDims = {});
/// @brief A piece's outer voxel layers on its sides inside the volume, which settle the faces
/// between pieces (addFacesBetweenPieces).
struct PieceLayers {
    std::array<uint32_t, 3> lo{}, hi{}; ///< the piece's voxels [lo, hi) in the volume
    /// Sides -x, +x, -y, +y, -z, +z: the voxels of the piece's first or last plane across that
    /// axis, the other two axes in order (the lower one fastest); empty on the volume's boundary.
    std::array<std::vector<uint32_t>, 6> layers;
};
/// The layers of the piece [lo, hi) of `volume` (the whole volume, or a piece placed in its index
/// space: embedPiece), decoded from the bricks they touch.
Result<PieceLayers> pieceLayers(const CompressedVolume& volume, const std::array<uint32_t, 3>& lo,
                                const std::array<uint32_t, 3>& hi);
/// The labels just outside a piece's box [lo, hi) on each side (-x, +x, -y, +y, -z, +z; laid out
/// as PieceLayers::layers, over the box's face), from the layers of the pieces beside it; sides on
/// the volume's boundary are empty, voxels no piece holds are kInvalidLabel. A renderer of the
/// piece starts a ray that enters from outside with the label it leaves (ghost faces).
std::array<std::vector<uint32_t>, 6> ghostFaces(const std::array<uint32_t, 3>& lo, const std::array<uint32_t, 3>& hi,
                                                const std::array<uint32_t, 3>& volumeDims,
                                                const std::vector<PieceLayers>& pieces);
/// Adds the faces across every pair of touching pieces (disjoint boxes) to `sums`.
void addFacesBetweenPieces(AttributeSums& sums, const std::vector<PieceLayers>& pieces);
/// The table computeAttributes() gives for these sums (options.idToLabel maps stored ids).
Result<AttributeTable> attributeTable(const AttributeSums& sums, const ComputeAttributesOptions& options = {});

} // namespace csgv
