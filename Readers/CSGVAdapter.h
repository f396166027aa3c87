// SPDX-License-Identifier: MIT
/**
 * @file CSGVAdapter.h
 * @brief The one adapter between VTK image data and Core's compressed volumes, public to the
 * modules that depend on CSGV::Readers (the representation uses it as the reader and the writer
 * do):
 * - the FieldData contract (names and layout of the encoding, geometry, label map, original type
 *   and label range arrays; documented in vtkCSGVReader.h), written by addEncodingArrays and read
 *   by readEncodingArrays;
 * - which array of an image holds labels (findLabelArray) and where its voxels lie
 *   (imageGeometry);
 * - one streaming "VTK array to compressed volume" encoder (encodeLabelArray): z-slab by z-slab
 *   with progress, without a full-size copy when the labels fit the format;
 * - decoding a box of a level back into a VTK array (decodeBox) and the palette label range.
 *
 * Not a wrapped header (NOWRAP_HEADERS): Core types appear here and nowhere in the CLASSES
 * headers, which ParaView's client-server wrapper parses.
 */
#ifndef CSGVAdapter_h
#define CSGVAdapter_h

#include "csgv/base/MappedFile.h"
#include "csgv/codec/CsgvFile.h"
#include "csgv/attributes/AttributeDb.h"
#include "csgv/base/Geometry.h"
#include "csgv/codec/Container.h"
#include "csgv/codec/Palettes.h"
#include "csgv/codec/Decoder.h"
#include "csgv/codec/Encoder.h"
#include "csgv/codec/Metadata.h"
#include "csgv/inputs/Relabel.h"

#include <vtkSmartPointer.h>
#include <vtkType.h>

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

class vtkAbstractArray;
class vtkDataArray;
class vtkFieldData;
class vtkImageData;
class vtkInformation;
class vtkUnsignedCharArray;

namespace csgvvtk
{

/// Names of the FieldData arrays (see vtkCSGVReader.h for their meaning).
constexpr const char* kEncodingName = "CSGVEncoding";
constexpr const char* kGeometryName = "CSGVGeometry";
constexpr const char* kLabelMapName = "CSGVLabelMap";
constexpr const char* kOriginalTypeName = "CSGVOriginalType";
constexpr const char* kLabelRangeName = "CSGVLabelRange";
constexpr const char* kPieceOffsetName = "CSGVPieceOffset";
constexpr const char* kBrickPieceName = "CSGVBrickPiece";
/// Prefix of the per-id attribute arrays of a `_csgv.db3` (vtkDoubleArray for numeric columns,
/// vtkStringArray for text columns), indexed by the id the volume stores.
constexpr const char* kAttributePrefix = "CSGVAttribute:";
/// FieldData string: a label table found beside the input (labelTableBeside), which the
/// representation reads as an attribute file before the user's own.
constexpr const char* kAttributeSidecarName = "CSGVAttributeSidecar";
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

/// Core's label type name of a VTK array type ("uint8" ... "float64"); nullptr when the type
/// cannot hold labels. By size and signedness, because 64-bit integers come as long, long long
/// or vtkIdType arrays.
const char* labelTypeNameOf(int vtkType, csgv::LabelType& type);

// ---------------------------------------------------------------------------------------------
// Which array, and where its voxels lie

/// The label array of an image: by name (cell data first), or the first one-component integer
/// array (cell data first; VTK's own arrays such as vtkGhostType skipped), else the first such
/// float array. `isCell` says which attributes it came from; null when there is none.
vtkDataArray* findLabelArray(vtkImageData* image, const std::string& name, bool& isCell);

/// Voxels of a point extent: its cells (`isCell`; at least 1 along an axis, as VTK counts the
/// cells of flat images) or its points; 0 along an empty axis.
std::array<uint32_t, 3> voxelDims(const int extent[6], bool isCell);

/// The voxels [lo, hi) MPI piece `piece` of `pieces` holds of a grid of `dims` voxels: its bricks
/// (csgv::brickPartition) with bricks of `brickSize`; false when the piece has none.
bool pieceVoxels(const std::array<uint32_t, 3>& dims, int brickSize, int pieces, int piece,
  std::array<uint32_t, 3>& lo, std::array<uint32_t, 3>& hi);

/// The point extent `ext` to ask an input of whole extent `whole` for, so that piece `piece` of
/// `pieces` gets its voxels (pieceVoxels) whether its labels are cell or point data; a piece
/// without bricks asks for one point, so that it still sees which arrays there are.
void brickPieceExtent(const int whole[6], int brickSize, int pieces, int piece, int ext[6]);

/// Copies voxels [lo, hi) of the whole grid out of `array`, which lies over the point extent
/// `ext` of an image whose whole extent is `whole`, into a new array of its type; returns an
/// error message or "".
std::string cropVoxels(vtkDataArray* array, const int ext[6], const int whole[6], bool isCell,
  const std::array<uint32_t, 3>& lo, const std::array<uint32_t, 3>& hi,
  vtkSmartPointer<vtkDataArray>& out);

/// Corner geometry (origin at the corner of voxel (0,0,0), DESIGN.md "Where voxels are") of the
/// voxel grid an image's cell (`isCell`) or point array describes, and the grid's dimensions.
/// Extents need not start at 0; the direction matrix is honoured.
csgv::Geometry imageGeometry(vtkImageData* image, bool isCell, std::array<uint32_t, 3>& dims);

/// World-space axis-aligned bounds of a voxel grid of corner geometry `g`.
void worldBounds(const csgv::Geometry& g, const std::array<uint32_t, 3>& dims, double bounds[6]);

// ---------------------------------------------------------------------------------------------
// VTK array -> compressed volume

/// @brief A label array compressed, with what is needed to show its original labels.
struct EncodedArray
{
  csgv::CompressedVolume volume;
  /// Filled when labels were relabelled (they did not fit the format, or relabelling was asked
  /// for): `mapping.originalBits[id]` is the original label of stored id `id`.
  csgv::LabelMapping mapping;
  std::string originalType; ///< Core's name of the array's type ("uint16", "float32", ...)
};

/// @brief What the pieces of one volume encoded in parallel agree on (vtkCSGVWriter under MPI).
/// The calls are collective: every piece makes each once, in this order, passing ok = false when
/// it failed before (the others then fail too); errors from another piece come back as results.
class PieceAgreement
{
public:
  virtual ~PieceAgreement() = default;
  /// Where this piece's voxel (0,0,0) lies in the volume, and the volume's dimensions.
  std::array<uint32_t, 3> offset{};
  std::array<uint32_t, 3> volumeDims{};
  /// True when any piece relabels (`mine`: this one would: its labels do not fit, or asked).
  virtual csgv::Result<bool> anyRelabels(bool ok, bool mine) = 0;
  /// When one relabels: the volume's id table (id -> original bits) from every piece's first
  /// visits (the relabeller's order over the whole volume).
  virtual csgv::Result<std::vector<uint64_t>> ids(bool ok, const csgv::StreamingRelabeller& mine) = 0;
};

/// Compresses a one-component label array of `dims` voxels (x fastest). Labels that fit the
/// format (0 .. 0xFFFFFFFE) stream to the encoder z-slab by z-slab straight from the array (no
/// full-size copy; none at all for uint32); others (negative, wide) or `relabel` go through
/// Core's relabelling to dense ids first. Float arrays must hold integers. `progress` gets the
/// fraction encoded after each slab. With `pieces`, the array is one whole-brick piece of a volume
/// encoded in parallel: whether to relabel and the ids are agreed with the other pieces (the
/// symbol counts through options.shareCounts). Returns an error message or "".
std::string encodeLabelArray(vtkDataArray* array, const std::array<uint32_t, 3>& dims,
  const csgv::EncodeOptions& options, bool relabel, const std::function<void(double)>& progress,
  EncodedArray& out, PieceAgreement* pieces = nullptr);

// ---------------------------------------------------------------------------------------------
// Compressed volume -> VTK

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
/// The same from the volume's palette summary (no sweep unless a relabelled volume has more
/// distinct ids than the summary lists).
vtkSmartPointer<vtkDataArray> paletteRange(
  const csgv::CompressedVolume& vol, const LabelInfo& info, const csgv::PaletteSummary& palettes);

// ---------------------------------------------------------------------------------------------
// The FieldData contract

/// Fills `fd` with the arrays of vtkCSGVReader.h's layout.
void addEncodingArrays(vtkFieldData* fd, vtkUnsignedCharArray* encoding,
  const csgv::Geometry& cornerGeometry, const LabelInfo& info, vtkDataArray* range);

/// Adds one `CSGVAttribute:<name>` array per column (indexed by id).
void addAttributeArrays(vtkFieldData* fd, const std::vector<csgv::AttributeColumn>& columns);

/// A reader's output that failed to read says why in FieldData `CSGVReadError` (one string):
/// under MPI a rank's failure is printed on its own stderr only, while the other ranks' pieces
/// pass for the whole volume; the representation's combined summary names the failed rank.
/// An empty message marks the failure with a generic one (the reader reported its error).
void markReadError(vtkFieldData* fd, const std::string& message);
/// That message, or "".
std::string readErrorOf(vtkFieldData* fd);

/// The label table an atlas keeps beside its NIfTI file (MRIcron's templates: `aal.nii.gz` has
/// `aal.nii.txt`, "index name code" lines): `<input without .gz>.txt` when `input` ends in `.nii`
/// or `.nii.gz` and that is a regular file; "" otherwise.
std::string labelTableBeside(const std::string& input);
/// Names it in `fd` (kAttributeSidecarName), or reads the name back ("" when none).
void setAttributeSidecar(vtkFieldData* fd, const std::string& path);
std::string attributeSidecar(vtkFieldData* fd);

/// A piece of a volume (MPI ranks, vtkCSGVReader): where its voxel (0,0,0) lies in the volume
/// (level 0) and the volume's dimensions, as FieldData `CSGVPieceOffset` (6 ints); (0,0,0) and
/// no dimensions (all 0) for a whole volume.
void addPieceOffset(vtkFieldData* fd, const std::array<uint32_t, 3>& offset, const std::array<uint32_t, 3>& volumeDims);
std::array<long, 3> pieceOffset(vtkFieldData* fd);
std::array<uint32_t, 3> pieceVolumeDims(vtkFieldData* fd);

/// An image a consumer asked for as MPI piece `piece` of `pieces` of its input's whole extent
/// `whole` with bricks of `brick` (brickPieceExtent), as FieldData `CSGVBrickPiece` (9 ints:
/// brick, pieces, piece, whole extent); brickPiece is false when there is none.
void setBrickPiece(vtkFieldData* fd, const std::vector<int>& brickPieceWords);
bool brickPiece(vtkFieldData* fd, int& brick, int& pieces, int& piece, int whole[6]);

/// The encoding array of a FieldData (null when there is none): its pointer and modification
/// time identify the encoding, so consumers look up what they parsed before without parsing.
vtkUnsignedCharArray* encodingArray(vtkFieldData* fd);
/// An encoding array over a file's mapped bytes (csgv::MappedFile: read-only, guarded against the
/// file being cut short), which the array keeps alive: the encoding takes no private memory, the
/// page cache holds what was touched, and a parse of it views the mapping (TieredVolume can then
/// keep the finest level on disk). Null when the size does not fit a VTK array.
vtkSmartPointer<vtkUnsignedCharArray> mappedEncodingArray(std::shared_ptr<const csgv::MappedFile> file);
/// A shared owner that keeps `array`, and so its memory, alive (a reference): the keeper of
/// WordArray views into it. The array must not be changed while views live (FieldData arrays
/// are not: the pipeline passes them on shallowly).
std::shared_ptr<const void> keepArray(vtkAbstractArray* array);
/// Attaches the reader's palette summary (csgv::summarizePalettes, made when it opened the file)
/// to its mapped encoding array (mappedEncodingArray; other arrays are left alone): a parse of
/// that array in this process (readEncodingArrays) takes it instead of reading the palettes again.
void attachPaletteSummary(vtkAbstractArray* mapped, std::shared_ptr<const csgv::PaletteSummary> palettes);
/// The summary attached to this mapped encoding array, or null.
std::shared_ptr<const csgv::PaletteSummary> paletteSummaryOf(vtkAbstractArray* array);

/// @brief What a consumer of the FieldData layout gets back.
struct EncodedInput
{
  csgv::CompressedVolume volume;
  /// What the reader found in its palettes (the same process, the reader's mapped array), or null.
  std::shared_ptr<const csgv::PaletteSummary> palettes;
  csgv::Geometry geometry; ///< level 0, origin at the corner of voxel (0,0,0)
  LabelInfo info;
};
/// Parses the arrays of vtkCSGVReader.h's layout (the whole container: callers parse once per
/// encoding array and modification time); returns an error message or "". The volume's arrays
/// view the encoding array's memory, which they keep alive (the reader's mapping of the file, in
/// the same process: mappedEncodingArray).
std::string readEncodingArrays(vtkFieldData* fd, EncodedInput& out);

/// The opened file a FieldData describes (a parse of it: readEncodingArrays): its encoding
/// (views, no copy), geometry, and for a relabelled file its labels and attribute columns (the
/// CSGVAttribute arrays), as csgv::openCsgv gives them for the file.
csgv::CsgvFile fileOfInput(const EncodedInput& enc, vtkFieldData* fd);

/// @brief The parsed encoding of a FieldData, parsed again only when the encoding array or its
/// modification time changes (one per consumer: a filter's RequestInformation and RequestData
/// then share one parse).
class EncodingMemo
{
public:
  /// The parsed arrays of `fd`, or null with the error message.
  std::shared_ptr<const EncodedInput> get(vtkFieldData* fd, std::string& error);
  /// After a failed get(): what the user of `filter` can do, appended to the message (empty
  /// when the message says it already: the reader's file was written over while open).
  std::string advice(const std::string& filter) const;

private:
  const void* Array = nullptr;
  vtkMTimeType MTime = 0;
  std::shared_ptr<const EncodedInput> Parsed;
  std::string Error;
  bool Rewritten = false; ///< the arrays are a mapping of a file written over since it was opened
};

/// True when an encoding of level-0 corner geometry `g` and dimensions `dims` describes `image`
/// at some level (the reader's output); false for images derived from it (Extract's sub-boxes,
/// resampled data) that still carry the FieldData.
bool encodingDescribes(vtkImageData* image, const csgv::Geometry& g, const std::array<uint32_t, 3>& dims);

/// Asks the input for its whole extent (a filter of the encoding, RequestUpdateExtent), as its
/// representation asks for it, so the reader is not executed again for another extent; it
/// decodes nothing when its labels stay compressed.
void requestWholeInput(vtkInformation* inInfo);

/// Under MPI (the output asked for one of several pieces) a filter of the whole encoding asks its
/// input for the whole volume on every rank (one piece of one: the reader maps the whole file).
/// A piece encoding is a volume of its own: tables, meshes and boxes made from pieces were each
/// piece's (labels twice, bounding boxes in the piece's coordinates, walls where pieces meet).
/// One piece: requestWholeInput.
void requestWholeVolume(vtkInformation* outInfo, vtkInformation* inInfo);
/// Whether this rank makes the output from the whole volume: always with one piece; under MPI
/// each rank its part (`everyPiece`), else piece 0 all of it and the other ranks an empty output
/// (ParaView gathers them).
bool makesWholeOutput(vtkInformation* outInfo, bool everyPiece);

/// Sets spacing, origin and direction of `image` for level `lod` of a corner-origin geometry.
void applyGeometry(vtkImageData* image, const csgv::Geometry& corner, uint32_t lod);

} // namespace csgvvtk

#endif
