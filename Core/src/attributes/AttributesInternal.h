// SPDX-License-Identifier: MIT
#pragma once
/// @file AttributesInternal.h
/// @brief Helpers shared by the attribute store's sources (not installed).

#include "csgv/attributes/Attributes.h"

#include <functional>
#include <string>
#include <vector>

namespace csgv {
namespace detail {

bool iequals(const std::string& a, const std::string& b);
/// A complete decimal number (leading '+' allowed, "inf" and "nan" too), locale-independent.
bool parseNumber(const std::string& text, double& value);
/// Empty or "NA": a missing value in a numeric column.
bool isMissing(const std::string& text);
/// An integer label (int64, uint64 as its bits, or an integral float up to 2^53).
bool parseLabel(const std::string& text, int64_t& label);
/// Shortest text that reads back as the same double ("" for NaN).
std::string formatNumber(double v);
std::string joinNames(const std::vector<std::string>& names);
/// Index of the label column: `wanted` by name, else the first candidate name, else 0.
Result<size_t> chooseLabelColumn(const std::vector<std::string>& names, const std::string& wanted,
                                 const std::string& source);
/// A table from text cells (rows[r][c]; "" missing); where(r) names row r in errors.
Result<AttributeTable> buildTable(const std::vector<std::string>& names, const std::vector<std::vector<std::string>>& rows,
                                  const std::string& labelColumn, const std::string& source,
                                  const std::function<std::string(size_t)>& where);

} // namespace detail
} // namespace csgv
