// SPDX-License-Identifier: MIT
/**
 * @class vtkCSGVReader
 * @brief Reads a CSGV segmentation volume (`.csgv`, Volcanite's `.vraw`, `.vraw.gz`) as image
 * data whose labels are cell data and whose encoding travels along in the FieldData.
 *
 * Geometry (DESIGN.md "Where voxels are"): voxel (i,j,k) is cell (i,j,k) of an image with
 * dims + 1 points, spanning origin + direction * ([i, i+1] * spacing). Spacing, origin (the
 * corner of voxel 0) and direction come from `<file>.csgv.json` when present (spacing 1, origin 0
 * otherwise). At Level k > 0 the image has the level's (dim - 1) / 2^k + 1 cells per axis with
 * spacing * 2^k, so the last cell may reach past the full-resolution bounds by less than one
 * coarse cell.
 *
 * Cell array "Labels" (only when decoded): the original labels (through `<file>_csgv.db3` when
 * the file was relabelled) in the original type named by the metadata (uint8 ... int64, float32,
 * float64), or uint32 without metadata (int64/uint64 for relabelled 64-bit labels). Labels are
 * decoded when DecodeLabels is on and the level has at most DecodeThreshold voxels; otherwise the
 * output carries only the geometry and the FieldData below, so a huge volume costs about its file
 * size in memory ("Labels stay compressed"); vtkCSGVExtract decodes a sub-box or coarser level.
 *
 * FieldData layout (read by vtkCSGVExtract and the representation, which need no decoding):
 * - `CSGVEncoding` (vtkUnsignedCharArray, 1 component): a complete CSGV container, byte for byte
 *   the `.csgv` file (version 0015 or 0016; for `.vraw` input the container the reader encoded,
 *   brick size 32, rANS with two tables). Parse it with csgv::parseCsgv.
 * - `CSGVGeometry` (vtkDoubleArray, 15 values): spacing[3], origin[3] (corner of voxel (0,0,0)),
 *   direction[9] row-major, all at full resolution (level 0) whatever Level is.
 * - `CSGVLabelMap` (only for relabelled files): id -> original label, a 64-bit integer array,
 *   unsigned (vtkTypeUInt64Array) for uint64 labels, signed (vtkTypeInt64Array) otherwise.
 * - `CSGVOriginalType` (vtkStringArray, 1 value): "uint8" ... "float64", the label type to show.
 * - `CSGVLabelRange` (2 values, the type of "Labels"): the smallest and largest original label
 *   over all brick palettes, computed without decoding.
 * - `CSGVAttribute:<column>` (only with a `_csgv.db3`): one array per attribute column of the
 *   database, indexed by the id the volume stores (CSGVLabelMap gives its original label):
 *   vtkDoubleArray for numeric columns (NaN where missing), vtkStringArray for text columns.
 *   The Segmentation Volume representation offers them to materials and picking.
 *
 * Pieces (MPI ranks: pvbatch, pvserver): when the pipeline asks for piece p of n, the reader
 * hands over whole bricks, piece p of csgv::brickPartition of the brick grid, reading only those
 * bricks' bytes of the file (RequestInformation reads the header, brick starts and sidecars
 * only): the output's extent is the piece's (cut at multiples of the brick size), and the
 * FieldData's `CSGVEncoding` is a container of the piece's bricks alone (a volume of its own)
 * with `CSGVGeometry` at the piece's corner, `CSGVLabelRange` over its palettes and
 * `CSGVPieceOffset` (6 ints: its first voxel in the volume, level 0, and the volume's
 * dimensions; the representation draws the piece in the volume's index space). One piece
 * honours the update extent as before.
 *
 * File series (FileNames; CSGVFileSeries.h says why): several files are a time series, step i
 * the i-th file (time values 0, 1, ..., N - 1; each step may have its own dimensions), read
 * one at a time as FileName would be, pieces included. FileName stays for scripts and state
 * files: beside a FileNames of one file it is read, beside several it is an error.
 *
 * Errors (missing, truncated or malformed files, bad sidecars) are reported with vtkErrorMacro
 * carrying Core's message, and the output is empty.
 */
#ifndef vtkCSGVReader_h
#define vtkCSGVReader_h

#include "CSGVReadersModule.h"
#include "vtkImageAlgorithm.h"

class vtkInformationDoubleVectorKey;
class vtkInformationIntegerKey;
class vtkInformationIntegerVectorKey;

class CSGVREADERS_EXPORT vtkCSGVReader : public vtkImageAlgorithm
{
public:
  static vtkCSGVReader* New();
  vtkTypeMacro(vtkCSGVReader, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetStringMacro(FileName);
  vtkGetStringMacro(FileName);

  /// The files of a time series, in order (ParaView's repeatable FileNames property). Empty by
  /// default; when it holds several, FileName must be empty.
  void AddFileName(const char* fileName);
  void RemoveAllFileNames();
  int GetNumberOfFileNames();
  /// Entry `index` of FileNames (null outside [0, GetNumberOfFileNames())).
  const char* GetFileNameAt(int index);

  /// Decode labels into the "Labels" cell array when the level holds at most DecodeThreshold
  /// voxels (default on).
  vtkSetMacro(DecodeLabels, vtkTypeBool);
  vtkGetMacro(DecodeLabels, vtkTypeBool);
  vtkBooleanMacro(DecodeLabels, vtkTypeBool);

  /// Largest voxel count decoded (default 512 Mi voxels, 2 GiB of uint32 labels).
  void SetDecodeThreshold(vtkIdType value); ///< held to [0, VTK_ID_MAX], with a warning (CSGVHeldValue.h)
  vtkGetMacro(DecodeThreshold, vtkIdType);

  /// Level of detail to decode: 0 full resolution, k: 2^k voxels per cell and axis; clamped to
  /// the file's coarsest level.
  void SetLevel(int value); ///< held to [0, 7], with a warning (CSGVHeldValue.h)
  vtkGetMacro(Level, int);

  /// 1 for a `.csgv` with the right magic and version, a `.vraw` with a valid header or a
  /// `.vraw.gz`, else 0 (ParaView's reader factory asks this on the server).
  virtual int CanReadFile(const char* fileName);

  /// Levels of the last file read (0 before a successful RequestInformation).
  int GetNumberOfLevels();

  /// Output-information keys set in RequestInformation, so that vtkCSGVExtract (directly
  /// downstream) knows the full-resolution volume before any data exists: voxel dimensions at
  /// level 0, the number of levels, and the 15 values of `CSGVGeometry`.
  static vtkInformationIntegerVectorKey* CSGV_DIMENSIONS();
  static vtkInformationIntegerKey* CSGV_LEVELS();
  static vtkInformationDoubleVectorKey* CSGV_GEOMETRY();

protected:
  vtkCSGVReader();
  ~vtkCSGVReader() override;

  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  /// A time series declares time-dependent information: the pipeline asks for it
  /// (REQUEST_TIME_DEPENDENT_INFORMATION) once the requested time is known, before any consumer
  /// computes its update extent, and the reader switches to that step's file and announces its
  /// extent there (SwitchStep). RequestUpdateExtent switches too, for requests without that pass.
  vtkTypeBool ProcessRequest(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  void SwitchStep(vtkInformation* outInfo);
  /// Reads the current file's header and sidecars and announces its extent and geometry.
  void DescribeFile(vtkInformation* outInfo);

  char* FileName = nullptr;
  vtkTypeBool DecodeLabels = 1;
  vtkIdType DecodeThreshold = vtkIdType(512) * 1024 * 1024;
  int Level = 0;

private:
  vtkCSGVReader(const vtkCSGVReader&) = delete;
  void operator=(const vtkCSGVReader&) = delete;

  class vtkInternals;
  vtkInternals* Internals;
};

#endif
