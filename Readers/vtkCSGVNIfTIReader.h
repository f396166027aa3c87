// SPDX-License-Identifier: MIT
/**
 * @class vtkCSGVNIfTIReader
 * @brief Reads NIfTI-1 label volumes (`.nii`, `.nii.gz`) through Core's reader, so that atlases
 * land in their world space exactly as `csgv compress` places them.
 *
 * Debian's ParaView 5.11 registers no reader for NIfTI. Core's readNifti applies the sform (or
 * else the qform, else pixdim) to origin, spacing and direction of the voxel centres.
 *
 * Output: image data with CELL data "Labels" in the file's voxel type (uint8 ... int64,
 * float32, float64), one cell per voxel: the convention of every label volume of this plugin
 * (DESIGN.md "Where voxels are"), so a NIfTI atlas and its `.csgv` have the same points, bounds
 * and cells and overlay exactly. The file's voxel centres become cell centres (Core's
 * cellGeometryFromPointGeometry, as `csgv compress` does): the AAL atlas's first cell spans
 * (-90.5, -125.5, -71.5) .. (-89.5, -124.5, -70.5).
 *
 * Intensity images: since this is ParaView's only NIfTI reader here, files that Core refuses as
 * label volumes (floats that are not integers, scaled data) are read with VTK's
 * vtkNIFTIImageReader instead, with a warning (none with ExpectImages on): point array "Scalars"
 * holding the stored values (scl_slope/scl_inter not applied), placed with the same sform-else-qform rule. Intensities stay
 * point data, as ParaView's image readers give them (interpolated by Volume and Contour); their
 * points are the voxel centres, so they sit on the cell centres of an atlas of the same grid.
 * Other errors (missing, truncated, unsupported files) give Core's message and an empty output.
 *
 * One class for the NIfTI family, two proxies (CSGVReaders.xml): ParaView's reader factory picks
 * a proxy by CanReadFile and the proxy's hints give the default representation, so label volumes
 * ("NIfTI Label Reader", CSGVNIfTIReader) open as Segmentation Volume and images ("NIfTI Image
 * Reader", CSGVNIfTIImageReader: the same class with ExpectImages turned on at creation) as
 * ParaView opens other images, instead of a Segmentation Volume that cannot draw intensities.
 * ExpectImages changes only CanReadFile and the warning; the output is the same.
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

  /// Off (default): offered for label volumes, and an intensity image is read with a warning. On:
  /// offered for images, read without one (the "NIfTI Image Reader" proxy sets it on creation:
  /// post_creation="ExpectImagesOn", which runs before the reader factory asks CanReadFile).
  vtkSetMacro(ExpectImages, vtkTypeBool);
  vtkGetMacro(ExpectImages, vtkTypeBool);
  vtkBooleanMacro(ExpectImages, vtkTypeBool);

  /// 1 for a NIfTI-1 file (`.nii` with a NIfTI-1 header, or any `.nii.gz`) that IsImageHeader
  /// calls an image when ExpectImages is on, and does not when it is off; else 0.
  virtual int CanReadFile(const char* fileName);

  /// True when the header says the file holds an image rather than labels: floating-point or
  /// scaled voxels (scl_slope not 0 or 1, or scl_inter not 0) without NIfTI's label intent
  /// (intent_code 1002, NIFTI_INTENT_LABEL, which atlases carry). Integer voxels without that
  /// intent (segmentations of many tools, but also 8-bit templates) count as labels. Decides
  /// which of the two reader proxies the reader factory offers, and with it the default
  /// representation (CSGVReaders.xml).
  static bool IsImageHeader(const char* fileName);

protected:
  /// `.nii` with a NIfTI-1 header, or any `.nii.gz` (its header is compressed).
  static bool IsNIfTIFile(const char* fileName);

  vtkCSGVNIfTIReader();
  ~vtkCSGVNIfTIReader() override;

  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  char* FileName = nullptr;
  vtkTypeBool ExpectImages = 0;

private:
  vtkCSGVNIfTIReader(const vtkCSGVNIfTIReader&) = delete;
  void operator=(const vtkCSGVNIfTIReader&) = delete;

  class vtkInternals;
  vtkInternals* Internals;
};

#endif
