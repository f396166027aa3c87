// SPDX-License-Identifier: MIT
#pragma once
/// @file AttributeDb.h
/// @brief The SQLite attribute database beside a relabelled `.csgv` (CSGV-FORMAT.md section 8):
/// dense ids to original labels, and the other columns as per-label attributes.

#include "csgv/base/Status.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace csgv {

/// @brief One attribute column, indexed by dense id. Text columns keep their strings; numeric
/// columns hold doubles (NULL is NaN).
struct AttributeColumn {
    std::string name;
    bool numeric = true;
    std::vector<double> values;
    std::vector<std::string> text;
};

/// @brief Contents of a `<name>_csgv.db3` file.
struct AttributeDatabase {
    std::string path;
    std::string labelColumn;                 ///< csgv_info.label_column
    std::array<uint32_t, 3> volumeDim{};     ///< csgv_info volume_width/height/depth
    std::vector<int64_t> labels;             ///< id -> original label
    /// The labels are unsigned 64-bit values stored as int64 bits (our table csgv_label_type says
    /// "uint64"); otherwise they are signed.
    bool labelsUnsigned64 = false;
    std::vector<AttributeColumn> columns;    ///< all columns but csgv_id and the label column

    /// id -> label as uint32, or an error naming the first label that does not fit.
    Result<std::vector<uint32_t>> labelsAsUint32() const;
    const AttributeColumn* column(const std::string& name) const;
};

/// `a/vol.csgv` -> `a/vol_csgv.db3`.
std::string attributeDbPathFor(const std::string& csgvPath);
/// Reads the database (read-only). Ids must be exactly 0..n-1.
Result<AttributeDatabase> readAttributeDb(const std::string& path);
/// Writes a database in Volcanite's schema (csgv_info, csgv_attribute with csgv_id, the label
/// column, then `columns`), through a temporary file renamed into place. `labelBits` maps ids to
/// labels, stored as int64 bits; `signedLabels` records how to read them back (table
/// csgv_label_type, which Volcanite ignores).
Status writeAttributeDb(const std::string& path, const std::array<uint32_t, 3>& dim,
                        const std::vector<uint64_t>& labelBits, bool signedLabels,
                        const std::vector<AttributeColumn>& columns = {}, const std::string& labelColumn = "label");

} // namespace csgv
