// SPDX-License-Identifier: MIT
/**
 * @class vtkCSGVQuery
 * @brief Asks a Segmentation Volume representation on the rendering process a question and
 * brings the answer to the client: attribute names and ranges for the material editor, the
 * label under a pixel for picking, the last label image, the materials' colour per label.
 *
 * Server-manager proxy `misc/CSGVQuery` (processes dataserver|renderserver, no client part), so
 * its information property `Result` is read where the data lives, also in client/server mode
 * (the representation's own information properties would read the client's empty copy); where
 * the view renders on the client (a server that cannot render), the asker places the proxy on
 * the client, whose copy drew the piece ParaView moved there (vtkSMProxy::SetLocation). Set
 * `Representation` to the composite representation's subproxy "CSGVSegmentationVolume", set
 * `Request`, push, then UpdatePropertyInformation and read `Result`. The commands (summary,
 * pick X Y, labels, colors N, defaults, stats), their arguments and replies are listed in one place:
 * Representation/CSGVQueryProtocol.h.
 */
#ifndef vtkCSGVQuery_h
#define vtkCSGVQuery_h

#include "CSGVRepresentationModule.h"
#include "vtkObject.h"
#include "vtkWeakPointer.h" // for Representation

#include <string> // for Answer
#include <cstdint> // for Combine
#include <vector> // for Combine

class vtkCSGVRepresentation;
class vtkMultiProcessStream;

class CSGVREPRESENTATION_EXPORT vtkCSGVQuery : public vtkObject
{
public:
  static vtkCSGVQuery* New();
  vtkTypeMacro(vtkCSGVQuery, vtkObject);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /// Takes any object: one that is not a Segmentation Volume representation (a view or a reader
  /// given by mistake) is held as none, and the answer says so (ParaView's wrapping printed an
  /// alarming "Aborting execution" for a typed argument of another class).
  void SetRepresentation(vtkObject* representation);
  /// With several processes (MPI ranks: pvbatch, a parallel pvserver) a push reaches every rank,
  /// so `pick X Y`, `labels`, `summary` and `colors N` are answered here, collectively: each
  /// rank's own answer (its piece's) is gathered on rank 0, which keeps the nearest hit per pixel
  /// or combines them (csgvrep::combineAnswers). A request pushed before the representation is
  /// answered when it arrives; an empty one (the proxy's default) gathers nothing.
  void SetRequest(const char* request);
  vtkGetStringMacro(Request);
  /// The answer to Request (computed on each call, except the collective answers above).
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
  bool Gathered = false; ///< Answer holds the ranks' combined answer to Request (every rank)
  bool Pending = false;  ///< Request arrived before the representation
  /// Answers Request with every rank (when there are several and the request is collective).
  void Gather();
  /// Rank 0: the answer of all ranks from their gathered answers (`what`: the request's word).
  /// What the ranks send as arrays, by rank (rank 0's copy).
  struct GatheredArrays
  {
    std::vector<std::vector<int64_t>> labelSets; ///< `summary`: each rank's labels
    std::vector<std::vector<uint32_t>> labels;   ///< `labels`: each rank's label image
    std::vector<std::vector<float>> depths;      ///< `labels`: and its depths
  };
  void Combine(const std::string& text, const std::string& what, std::vector<vtkMultiProcessStream>& all,
    const GatheredArrays& arrays);
};

#endif
