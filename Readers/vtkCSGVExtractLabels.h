// SPDX-License-Identifier: MIT
/**
 * @class vtkCSGVExtractLabels
 * @brief Surface meshes of a selection of labels of the CSGV encoding carried by its input (the
 * FieldData of vtkCSGVReader's output), decoded from only the bricks whose palettes hold a
 * selected label (csgv::extractLabels, issue 41).
 *
 * The selection: Labels (original labels, separated by spaces or commas) or Query (an SQL
 * condition over the attribute columns of a relabelled file, e.g. `voxels > 1000`), within the
 * voxel box VOI (inclusive, full resolution, as vtkCSGVExtract's) at level Level. The output is
 * one closed surface per label around its voxels (discrete flying edges over the voxel centres:
 * every vertex lies on a face between a selected voxel and another), triangles with the label as
 * cell data "Label", in world coordinates that overlay the volume. Memory is bounded by the
 * selection's bounding box, never the volume; MaxLabels (default 1,000,000) and MaxOutputMiB
 * (the label image the meshes are made from, default 4096) refuse larger selections with a
 * message. Up to 256 labels are meshed one by one, each in its own bounding box (scattered
 * labels would otherwise make one box of most of the volume). BricksDecoded and BricksTotal
 * tell what it took. OutputType MASK or LABEL_IMAGE makes one image of the selection's bounding
 * box instead (csgv::extractLabels over all the labels at once), cell data in the volume's
 * geometry at Level, so it overlays the volume cell for cell; it is the one block of a
 * multiblock output (see OutputType).
 */
#ifndef vtkCSGVExtractLabels_h
#define vtkCSGVExtractLabels_h

#include "CSGVReadersModule.h"
#include "vtkDataObjectAlgorithm.h"

#include <string>

class CSGVREADERS_EXPORT vtkCSGVExtractLabels : public vtkDataObjectAlgorithm
{
public:
  static vtkCSGVExtractLabels* New();
  vtkTypeMacro(vtkCSGVExtractLabels, vtkDataObjectAlgorithm);

  /// What is made of the selection: surface meshes (vtkPolyData), or an image cropped to the
  /// selection's bounding box (a vtkImageData, cell data, the volume's geometry at Level, as the
  /// one block of a vtkMultiBlockDataSet: an image output's whole extent would be the input
  /// volume's, fixed before the box is known): a mask ("Mask", uint8: 1 where a selected label
  /// is) or a label image ("Label": the selected labels, 0 elsewhere).
  enum OutputTypes
  {
    MESHES = 0,
    MASK = 1,
    LABEL_IMAGE = 2
  };
  void SetOutputType(int value); ///< held to [MESHES, LABEL_IMAGE], with a warning (CSGVHeldValue.h)
  vtkGetMacro(OutputType, int);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /// Original labels, separated by spaces or commas ("" with a Query).
  void SetLabels(const char* labels);
  const char* GetLabels() { return this->Labels.c_str(); }
  /// An SQL condition over the attribute columns selecting labels ("" with Labels).
  void SetQuery(const char* query);
  const char* GetQuery() { return this->Query.c_str(); }
  /// Inclusive voxel box at full resolution: xmin, xmax, ymin, ymax, zmin, zmax.
  vtkSetVector6Macro(VOI, int);
  vtkGetVector6Macro(VOI, int);
  /// Level of detail, 0 (full resolution) to the file's coarsest level (clamped).
  void SetLevel(int value); ///< held to [0, 7], with a warning (CSGVHeldValue.h)
  vtkGetMacro(Level, int);
  /// Meshes only: windowed-sinc smoothing iterations (0, the default: none; the vertices then
  /// leave the voxel faces) and quadric decimation's target reduction (0 to 0.95; 0 none),
  /// for selections of at most 256 labels.
  void SetSmoothing(int value); ///< held to [0, 200], with a warning (CSGVHeldValue.h)
  vtkGetMacro(Smoothing, int);
  void SetDecimation(double value); ///< held to [0.0, 0.95], with a warning (CSGVHeldValue.h)
  vtkGetMacro(Decimation, double);
  void SetMaxLabels(int value); ///< held to [1, VTK_INT_MAX], with a warning (CSGVHeldValue.h)
  vtkGetMacro(MaxLabels, int);
  void SetMaxOutputMiB(int value); ///< held to [1, VTK_INT_MAX], with a warning (CSGVHeldValue.h)
  vtkGetMacro(MaxOutputMiB, int);

  /// What the last execution decoded: brick decodes (only bricks whose palettes hold a selected
  /// label, once per such label: labels are meshed one by one), and the volume's bricks.
  vtkGetMacro(BricksDecoded, int);
  vtkGetMacro(BricksTotal, int);

protected:
  vtkCSGVExtractLabels();
  ~vtkCSGVExtractLabels() override;
  int FillInputPortInformation(int port, vtkInformation* info) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestDataObject(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  std::string Labels;
  std::string Query;
  int VOI[6] = { 0, VTK_INT_MAX, 0, VTK_INT_MAX, 0, VTK_INT_MAX };
  int Level = 0;
  int OutputType = MESHES;
  int Smoothing = 0;
  double Decimation = 0;
  int MaxLabels = 1000000;
  int MaxOutputMiB = 4096;
  int BricksDecoded = 0;
  int BricksTotal = 0;

private:
  vtkCSGVExtractLabels(const vtkCSGVExtractLabels&) = delete;
  void operator=(const vtkCSGVExtractLabels&) = delete;
  class vtkInternals; ///< the input's encoding, parsed once per encoding array and time
  vtkInternals* Internals;
};

#endif
