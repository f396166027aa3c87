// SPDX-License-Identifier: MIT
#include "vtkCSGVNIfTIImageReader.h"

#include <vtkObjectFactory.h>

vtkStandardNewMacro(vtkCSGVNIfTIImageReader);

int vtkCSGVNIfTIImageReader::CanReadFile(const char* fileName)
{
  return IsNIfTIFile(fileName) && IsImageHeader(fileName) ? 1 : 0;
}
