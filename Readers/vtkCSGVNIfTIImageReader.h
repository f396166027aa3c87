// SPDX-License-Identifier: MIT
/**
 * @class vtkCSGVNIfTIImageReader
 * @brief vtkCSGVNIfTIReader for the NIfTI files whose header says they are images (floating-point
 * or scaled voxels without the label intent, vtkCSGVNIfTIReader::IsImageHeader).
 *
 * Only CanReadFile differs: ParaView's reader factory picks a reader proxy by CanReadFile and the
 * proxy's hints give the default representation, so label volumes ("NIfTI Label Reader") open as
 * Segmentation Volume and images ("NIfTI Image Reader") as ParaView opens other images, instead
 * of a Segmentation Volume that cannot draw intensities. The output is the same class's.
 */
#ifndef vtkCSGVNIfTIImageReader_h
#define vtkCSGVNIfTIImageReader_h

#include "CSGVReadersModule.h"
#include "vtkCSGVNIfTIReader.h"

class CSGVREADERS_EXPORT vtkCSGVNIfTIImageReader : public vtkCSGVNIfTIReader
{
public:
  static vtkCSGVNIfTIImageReader* New();
  vtkTypeMacro(vtkCSGVNIfTIImageReader, vtkCSGVNIfTIReader);

  /// 1 for a NIfTI-1 file that IsImageHeader calls an image; else 0.
  int CanReadFile(const char* fileName) override;

protected:
  vtkCSGVNIfTIImageReader() { this->ExpectsImages = true; }
  ~vtkCSGVNIfTIImageReader() override = default;

private:
  vtkCSGVNIfTIImageReader(const vtkCSGVNIfTIImageReader&) = delete;
  void operator=(const vtkCSGVNIfTIImageReader&) = delete;
};

#endif
