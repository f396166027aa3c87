// SPDX-License-Identifier: MIT
/**
 * @class vtkCSGVExtract
 * @brief Decodes a sub-box and/or a coarser level of the CSGV encoding carried by its input
 * (the FieldData of vtkCSGVReader's output) into ordinary cell data.
 *
 * For volumes too big to decode whole ("Labels stay compressed"): the reader keeps only the
 * encoding, and this filter makes the labels of a chosen box and level visible to ParaView's
 * filters. Decoding touches only the bricks under the box.
 *
 * VOI: voxel indices at full resolution (level 0), inclusive min/max per axis as in
 * vtkExtractVOI, clamped to the volume; the default covers everything. Level k decodes the level
 * image whose cell (i,j,k) covers voxels [2^k i, 2^k (i+1)) per axis; the output holds the cells
 * covering the VOI, with extent in that level's cell indices (so a box keeps its place), spacing
 * * 2^k, the file's origin and direction. The "Labels" cell array has the reader's type; the
 * input's FieldData (the encoding) is passed on, so extracts can be chained.
 *
 * The input must come directly from vtkCSGVReader (its output information says how big the
 * volume is before any data exists), or be image data that already carries the encoding.
 */
#ifndef vtkCSGVExtract_h
#define vtkCSGVExtract_h

#include "CSGVReadersModule.h"
#include "vtkImageAlgorithm.h"

class CSGVREADERS_EXPORT vtkCSGVExtract : public vtkImageAlgorithm
{
public:
  static vtkCSGVExtract* New();
  vtkTypeMacro(vtkCSGVExtract, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /// Inclusive voxel box at full resolution: xmin, xmax, ymin, ymax, zmin, zmax.
  vtkSetVector6Macro(VOI, int);
  vtkGetVector6Macro(VOI, int);

  /// Level of detail, 0 (full resolution) to the file's coarsest level (clamped).
  void SetLevel(int value); ///< held to [0, 7], with a warning (CSGVHeldValue.h)
  vtkGetMacro(Level, int);

protected:
  vtkCSGVExtract();
  ~vtkCSGVExtract() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  int VOI[6] = { 0, VTK_INT_MAX, 0, VTK_INT_MAX, 0, VTK_INT_MAX };
  int Level = 0;

private:
  vtkCSGVExtract(const vtkCSGVExtract&) = delete;
  void operator=(const vtkCSGVExtract&) = delete;

  /// Full-resolution dims, levels and geometry of the input; false when unknown.
  bool InputVolumeInfo(vtkInformation* inInfo, int dims[3], int& levels, double geometry[15]);
  /// The level image's cell box covering the VOI (half-open), for the given input info.
  void LevelBox(const int dims[3], int lod, int box[6]) const;

  class vtkInternals; ///< the input's encoding, parsed once per encoding array and time
  vtkInternals* Internals;
};

#endif
