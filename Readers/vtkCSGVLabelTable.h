// SPDX-License-Identifier: MIT
/**
 * @class vtkCSGVLabelTable
 * @brief The per-label table of the CSGV encoding carried by its input (the FieldData of
 * vtkCSGVReader's output), as a vtkTable for ParaView's Spreadsheet view, Find Data, sorting and
 * Save Data (CSV) (issue 41, item 3).
 *
 * One row per label the volume holds (the labels of the bricks' palettes; for a relabelled file
 * the labels of its attribute database): column "label" (the original label), "csgv_id" (the
 * stored id) for a relabelled file, every attribute column of its database, and with
 * ComputedAttributes the attributes Core computes from the voxels (voxels, surface area, centroid,
 * bounding box: csgv::computedAttributeNames), which decode the whole volume brick by brick with
 * progress and abort. More than MaxRows labels are refused with a message.
 */
#ifndef vtkCSGVLabelTable_h
#define vtkCSGVLabelTable_h

#include "CSGVReadersModule.h"
#include "vtkTableAlgorithm.h"

class CSGVREADERS_EXPORT vtkCSGVLabelTable : public vtkTableAlgorithm
{
public:
  static vtkCSGVLabelTable* New();
  vtkTypeMacro(vtkCSGVLabelTable, vtkTableAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /// Add the attributes computed from the voxels (decodes the whole volume; default off).
  vtkSetMacro(ComputedAttributes, int);
  vtkGetMacro(ComputedAttributes, int);
  vtkBooleanMacro(ComputedAttributes, int);
  /// Volumes with more labels are refused (default 10,000,000).
  void SetMaxRows(int value); ///< held to [1, VTK_INT_MAX], with a warning (CSGVHeldValue.h)
  vtkGetMacro(MaxRows, int);

protected:
  vtkCSGVLabelTable();
  ~vtkCSGVLabelTable() override;
  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  int ComputedAttributes = 0;
  int MaxRows = 10000000;

private:
  vtkCSGVLabelTable(const vtkCSGVLabelTable&) = delete;
  void operator=(const vtkCSGVLabelTable&) = delete;
  class vtkInternals; ///< the input's encoding, parsed once per encoding array and time
  vtkInternals* Internals;
};

#endif
