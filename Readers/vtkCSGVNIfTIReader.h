// SPDX-License-Identifier: MIT
/**
 * @class vtkCSGVNIfTIReader
 * @brief Reads NIfTI-1 label volumes (`.nii`, `.nii.gz`) through Core's reader, so that atlases
 * land in their world space exactly as `csgv compress` places them.
 *
 * Debian's ParaView 5.11 registers no reader for NIfTI. Core's readNifti applies the sform (or
 * else the qform, else pixdim) to origin, spacing and direction; this reader hands those to the
 * image unchanged.
 *
 * Output: image data with POINT data "Labels" in the file's voxel type (uint8 ... int64,
 * float32, float64), one point per voxel, voxel (i,j,k) centred on point (i,j,k). That is what
 * ParaView users know from VTK's NIfTI/NRRD/MetaImage readers, and Slice then cuts through voxel
 * centres; the AAL atlas's first point is (-90, -125, -71). DESIGN.md "Where voxels are" draws
 * such voxels centred on their points; vtkCSGVWriter turns point geometry into cell (corner)
 * geometry with Core's helper, so a written `.csgv` covers the same space.
 *
 * Intensity images: since this is ParaView's only NIfTI reader here, files that Core refuses as
 * label volumes (floats that are not integers, scaled data) are read with VTK's
 * vtkNIFTIImageReader instead, with a warning: point array "Scalars" holding the stored values
 * (scl_slope/scl_inter not applied), placed with the same sform-else-qform rule. Other errors
 * (missing, truncated, unsupported files) give Core's message and an empty output.
 */
#ifndef vtkCSGVNIfTIReader_h
#define vtkCSGVNIfTIReader_h

#include "CSGVReadersModule.h"
#include "vtkImageAlgorithm.h"

class CSGVREADERS_EXPORT vtkCSGVNIfTIReader : public vtkImageAlgorithm
{
public:
  static vtkCSGVNIfTIReader* New();
  vtkTypeMacro(vtkCSGVNIfTIReader, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetStringMacro(FileName);
  vtkGetStringMacro(FileName);

  /// 1 for `.nii` with a NIfTI-1 header, or any `.nii.gz`; else 0.
  virtual int CanReadFile(const char* fileName);

protected:
  vtkCSGVNIfTIReader();
  ~vtkCSGVNIfTIReader() override;

  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  char* FileName = nullptr;

private:
  vtkCSGVNIfTIReader(const vtkCSGVNIfTIReader&) = delete;
  void operator=(const vtkCSGVNIfTIReader&) = delete;

  class vtkInternals;
  vtkInternals* Internals;
};

#endif
