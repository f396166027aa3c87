// SPDX-License-Identifier: MIT
#ifndef CSGVMpiAgreement_h
#define CSGVMpiAgreement_h

#include "CSGVAdapter.h"

class vtkMultiProcessController;

namespace csgvvtk
{

/// The message a process gets when another one could not encode its piece.
extern const char* const kOtherFailed;

/// @brief The pieces' agreement over MPI for encodeLabelArray: whether to relabel and the ids
/// (process 0 merges every piece's first visits, so the ids are those one process gives the whole
/// volume), and with `shareCounts` the symbol counts (vtkCSGVWriter's byte-identical file).
/// Every process makes each collective call exactly once: catchUp makes those a piece skipped (it
/// failed first, or holds no bricks). Used by the parallel writer and by the Segmentation Volume
/// representation for plain images that its ranks compress piece by piece.
class MpiAgreement : public PieceAgreement
{
public:
  MpiAgreement(vtkMultiProcessController* c, uint32_t brickSize, bool shareCounts);

  csgv::Result<bool> anyRelabels(bool ok, bool mine) override;
  csgv::Result<std::vector<uint64_t>> ids(bool ok, const csgv::StreamingRelabeller& mine) override;
  /// The counts of every piece (options.shareCounts), only with `shareCounts`.
  csgv::Result<csgv::SymbolCounts> counts(bool ok, const csgv::SymbolCounts& mine);
  /// The collective calls this process has not made yet, with `ok`.
  void catchUp(bool ok);

  bool Relabelled = false;
  std::vector<uint64_t> Table; ///< id -> original bits, when relabelled

private:
  csgv::Result<std::vector<uint64_t>> exchangeIds(
    bool ok, std::vector<std::pair<uint64_t, csgv::VisitPosition>> visits);

  vtkMultiProcessController* Controller;
  uint32_t BrickSize;
  bool ShareCounts;
  bool Asked = false;
  bool Exchanged = false;
  bool Shared = false;
};

} // namespace csgvvtk

#endif
