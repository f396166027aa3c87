// SPDX-License-Identifier: MIT
/**
 * @class vtkCSGVQuery
 * @brief Asks a Segmentation Volume representation on the rendering process a question and
 * brings the answer to the client: attribute names and ranges for the material editor, the
 * label under a pixel for picking, the last label image, the materials' colour per label.
 *
 * Server-manager proxy `misc/CSGVQuery` (processes dataserver|renderserver, no client part), so
 * its information property `Result` is read where the data lives, also in client/server mode
 * (the representation's own information properties would read the client's empty copy). Set
 * `Representation` to the composite representation's subproxy "CSGVSegmentationVolume", set
 * `Request`, push, then UpdatePropertyInformation and read `Result`:
 * - `summary`: JSON {"attributes": [{"name", "numeric", "min", "max"}], "labels": count of
 *   labels present, "labelArray": the label array's name, "error": why attributes failed};
 * - `pick X Y` (pixel of the last render, row 0 at the bottom): JSON {"hit", "label" (original),
 *   "voxel": [i, j, k], "world": [x, y, z], "attributes": {name: value or text}};
 * - `labels`: "W H BASE64" of the last render's label image (uint32 little-endian, row 0 at the
 *   bottom, 0xFFFFFFFF where no opaque voxel was hit);
 * - `colors N`: JSON {"labels": [[label, r, g, b, "name"]...], "truncated", "text"} for at most
 *   N labels present in the volume (labels no material takes are left out).
 */
#ifndef vtkCSGVQuery_h
#define vtkCSGVQuery_h

#include "CSGVRepresentationModule.h"
#include "vtkObject.h"
#include "vtkWeakPointer.h" // for Representation

#include <string> // for Answer

class vtkCSGVRepresentation;

class CSGVREPRESENTATION_EXPORT vtkCSGVQuery : public vtkObject
{
public:
  static vtkCSGVQuery* New();
  vtkTypeMacro(vtkCSGVQuery, vtkObject);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  void SetRepresentation(vtkCSGVRepresentation* representation);
  vtkSetStringMacro(Request);
  vtkGetStringMacro(Request);
  /// The answer to Request (computed on each call).
  const char* GetResult();

protected:
  vtkCSGVQuery() = default;
  ~vtkCSGVQuery() override;

private:
  vtkCSGVQuery(const vtkCSGVQuery&) = delete;
  void operator=(const vtkCSGVQuery&) = delete;

  vtkWeakPointer<vtkCSGVRepresentation> Representation;
  char* Request = nullptr;
  std::string Answer;
};

#endif
