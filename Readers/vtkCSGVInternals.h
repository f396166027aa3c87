// SPDX-License-Identifier: MIT
/**
 * @file vtkCSGVInternals.h
 * @brief Private glue between Core (namespace csgv) and VTK shared by the reader, the Extract
 * filter and the writer: label type choice, decoding a box of a level into a VTK array with
 * progress, the palette label range, and the FieldData layout documented in vtkCSGVReader.h.
 *
 * Not a wrapped header: Core types may appear here and nowhere in the CLASSES headers.
 */
#ifndef vtkCSGVInternals_h
#define vtkCSGVInternals_h

#include "csgv/attributes/AttributeDb.h"
#include "csgv/codec/Container.h"
#include "csgv/codec/Decoder.h"
#include "csgv/base/Geometry.h"

#include <vtkSmartPointer.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

class vtkDataArray;
class vtkFieldData;
class vtkImageData;
class vtkUnsignedCharArray;

namespace csgvvtk
{

/// Names of the FieldData arrays (see vtkCSGVReader.h for their meaning).
constexpr const char* kEncodingName = "CSGVEncoding";
constexpr const char* kGeometryName = "CSGVGeometry";
constexpr const char* kLabelMapName = "CSGVLabelMap";
constexpr const char* kOriginalTypeName = "CSGVOriginalType";
constexpr const char* kLabelRangeName = "CSGVLabelRange";
/// Prefix of the per-id attribute arrays of a `_csgv.db3` (vtkDoubleArray for numeric columns,
/// vtkStringArray for text columns), indexed by the id the volume stores.
constexpr const char* kAttributePrefix = "CSGVAttribute:";
/// Name of the decoded label array.
constexpr const char* kLabelsName = "Labels";

/// @brief How decoded palette values become the labels users see.
struct LabelInfo
{
  /// The file's original label type ("uint8" ... "float64"), from the metadata.
  std::string originalType = "uint32";
  /// Palette values are dense ids into `map` (a relabelled file with its attribute database).
  bool relabelled = false;
  std::vector<int64_t> map;  ///< id -> original label bits
  bool unsigned64 = false;   ///< map holds uint64 bits; otherwise int64
};

/// VTK type (VTK_TYPE_UINT8 ...) of a type name, or -1.
int vtkTypeOfName(const std::string& name);

/// Decoded labels of one box of a level, as a VTK array of the original type when every label
/// fits it (otherwise uint32, or int64/uint64 for wide relabelled labels).
struct DecodedLabels
{
  vtkSmartPointer<vtkDataArray> array;
  std::string warning; ///< non-empty when the original type could not be used
};

/// Decodes `box` (half-open, in the level image of `lod`) z-slab by z-slab of bricks, calling
/// `progress` with the fraction done after each slab. Returns Core's message on failure.
std::string decodeBox(const csgv::CompressedVolume& vol, uint32_t lod, const csgv::Box& box,
  const LabelInfo& info, const std::function<void(double)>& progress, DecodedLabels& out);

/// The range of original labels over every brick palette, without decoding; written as a
/// 2-value array of the type decodeBox would produce.
vtkSmartPointer<vtkDataArray> paletteRange(const csgv::CompressedVolume& vol, const LabelInfo& info);

/// Fills `fd` with the arrays of vtkCSGVReader.h's layout.
void addEncodingArrays(vtkFieldData* fd, vtkUnsignedCharArray* encoding,
  const csgv::Geometry& cornerGeometry, const LabelInfo& info, vtkDataArray* range);

/// Adds one `CSGVAttribute:<name>` array per column (indexed by id).
void addAttributeArrays(vtkFieldData* fd, const std::vector<csgv::AttributeColumn>& columns);

/// @brief What a consumer of the FieldData layout gets back.
struct EncodedInput
{
  csgv::CompressedVolume volume;
  csgv::Geometry geometry; ///< level 0, origin at the corner of voxel (0,0,0)
  LabelInfo info;
};
/// Parses the arrays of vtkCSGVReader.h's layout; returns an error message or "".
std::string readEncodingArrays(vtkFieldData* fd, EncodedInput& out);

/// Sets spacing, origin and direction of `image` for level `lod` of a corner-origin geometry.
void applyGeometry(vtkImageData* image, const csgv::Geometry& corner, uint32_t lod);

} // namespace csgvvtk

#endif
