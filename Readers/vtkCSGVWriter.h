// SPDX-License-Identifier: MIT
/**
 * @class vtkCSGVWriter
 * @brief Writes one integer label array of image data as a CSGV volume: `<file>.csgv`, its
 * `<file>.csgv.json` metadata and, when labels were relabelled, `<file>_csgv.db3`.
 *
 * The label array (LabelArrayName, or by default the first one-component integer array of the
 * cell data, then of the point data, then the first float array) may be any integer type of 8 to
 * 64 bits, signed or not, or a float array holding integers (the first non-integer value is
 * named in the error). Labels that do not fit the format (negative, wider than 32 bits, the
 * reserved 0xFFFFFFFF) or all labels when Relabel is on become dense ids as Core relabels them,
 * with the mapping in the attribute database, so readers show the original labels.
 *
 * Geometry: cell data is written as it is (voxel = cell; origin = corner of the first cell);
 * point data is taken as voxels centred on their points and converted with Core's
 * cellGeometryFromPointGeometry. Direction is kept. Image extents need not start at 0.
 *
 * The files are published all or nothing (Core's csgv::publishVolumeFiles, as `csgv compress`):
 * every new file is written complete under a temporary name before any is renamed over the old
 * set, sidecars first and the volume last, so a failure (a full disk) leaves the old volume and
 * its sidecars as they were, and a reader never pairs a `.csgv` with another's sidecars. Encoding
 * runs in parallel (OpenMP) with progress per slab of bricks.
 *
 * Under MPI (NumberOfPieces = the processes of the global controller, Piece = this process, as
 * ParaView's writer proxy sets them): every process asks its input for the whole bricks
 * csgv::brickPartition gives it with this writer's BrickSize, encodes them with frequency tables
 * of the symbol counts summed over all processes, and process 0 joins the pieces and writes the
 * files: the same bytes as one process writes. Labels are relabelled when any piece's labels do
 * not fit (or Relabel is on), with the ids one process would choose (process 0 merges every
 * piece's first visits). Errors anywhere reach every process; nothing is left behind.
 */
#ifndef vtkCSGVWriter_h
#define vtkCSGVWriter_h

#include "CSGVReadersModule.h"
#include "vtkWriter.h"

class vtkImageData;

class CSGVREADERS_EXPORT vtkCSGVWriter : public vtkWriter
{
public:
  static vtkCSGVWriter* New();
  vtkTypeMacro(vtkCSGVWriter, vtkWriter);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /// Output path; must end in `.csgv`.
  vtkSetStringMacro(FileName);
  vtkGetStringMacro(FileName);

  /// Name of the label array; empty (default) picks the first integer array.
  vtkSetStringMacro(LabelArrayName);
  vtkGetStringMacro(LabelArrayName);

  /// Brick edge length: 8, 16, 32 (default), 64 or 128.
  vtkSetMacro(BrickSize, int);
  vtkGetMacro(BrickSize, int);

  /// 0 nibble, 1 rANS with one table, 2 rANS with two tables (default); another value is an
  /// error naming it when writing (not another encoding written).
  vtkSetMacro(Encoding, int);
  vtkGetMacro(Encoding, int);

  /// Operation letters as `csgv compress --ops` takes them: "default" (pnls), "all" (pnlds) or
  /// letters of pxyznlds.
  vtkSetStringMacro(Operations);
  vtkGetStringMacro(Operations);

  /// Relabel to dense ids even when the labels fit the format (default off).
  vtkSetMacro(Relabel, vtkTypeBool);
  vtkGetMacro(Relabel, vtkTypeBool);
  vtkBooleanMacro(Relabel, vtkTypeBool);

  /// Encoder threads; 0 (default) lets OpenMP choose.
  void SetNumberOfThreads(int value); ///< held to [0, 1024], with a warning (CSGVHeldValue.h)
  vtkGetMacro(NumberOfThreads, int);

  /// The process count and this process's index under MPI (ParaView's writer proxy sets them);
  /// 1 and 0 (default) write from this process alone.
  void SetNumberOfPieces(int value); ///< held to [1, VTK_INT_MAX], with a warning (CSGVHeldValue.h)
  vtkGetMacro(NumberOfPieces, int);
  void SetPiece(int value); ///< held to [0, VTK_INT_MAX], with a warning (CSGVHeldValue.h)
  vtkGetMacro(Piece, int);

  vtkImageData* GetInput();

  /// Asks the input for this piece's bricks when writing in pieces.
  vtkTypeBool ProcessRequest(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

protected:
  vtkCSGVWriter();
  ~vtkCSGVWriter() override;

  void WriteData() override;
  int FillInputPortInformation(int port, vtkInformation* info) override;

  char* FileName = nullptr;
  char* LabelArrayName = nullptr;
  int BrickSize = 32;
  int Encoding = 2;
  char* Operations = nullptr;
  vtkTypeBool Relabel = 0;
  int NumberOfThreads = 0;
  int NumberOfPieces = 1;
  int Piece = 0;

private:
  vtkCSGVWriter(const vtkCSGVWriter&) = delete;
  void operator=(const vtkCSGVWriter&) = delete;
};

#endif
