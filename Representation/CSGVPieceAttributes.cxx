// SPDX-License-Identifier: MIT
#include "CSGVPieceAttributes.h"

#include "CSGVAdapter.h"
#include "CSGVStreamArrays.h"

#include "csgv/attributes/Attributes.h"

#include <vtkCommunicator.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkMultiProcessController.h>
#include <vtkMultiProcessStream.h>

#include <mutex>

namespace csgvrep
{

namespace
{

using csgvvtk::popArray;
using csgvvtk::pushArray;

} // namespace

std::string reduceComputedAttributes(
  vtkMultiProcessController* c, vtkImageData* input, const VolumeSource& source, bool& reduced)
{
  reduced = false;
  const std::shared_ptr<SharedVolume> shared = source.shared;
  (void)input;
  // A rank's piece placed in the volume's index space (the reader's pieces of a .csgv).
  const bool piece = shared && !shared->owned.empty();
  // Every rank's input a piece of one file (or nothing): otherwise each keeps its own.
  int mineOk = !shared || piece ? 1 : 0, allOk = 0;
  c->AllReduce(&mineOk, &allOk, 1, vtkCommunicator::MIN_OP);
  if (!allOk)
  {
    return std::string();
  }
  std::array<uint32_t, 3> offset{}, volumeDims{};
  std::string error;
  csgv::AttributeSums sums;
  csgv::PieceLayers layers;
  if (piece)
  {
    const uint32_t b = shared->volume.brickSize;
    volumeDims = shared->volume.dim;
    for (int a = 0; a < 3; ++a)
    {
      offset[a] = shared->owned.lo[a] * b;
    }
    csgv::Result<csgv::CompressedVolume> own = csgv::extractPiece(shared->volume, shared->owned);
    csgv::Result<csgv::AttributeSums> s =
      own ? csgv::computeAttributeSums(*own, {}, offset, volumeDims) : csgv::Result<csgv::AttributeSums>(own.status());
    csgv::Result<csgv::PieceLayers> l =
      s ? csgv::pieceLayers(*own, offset, volumeDims) : csgv::Result<csgv::PieceLayers>(s.status());
    if (!l)
    {
      error = "computing attributes of this piece: " + l.message();
    }
    else
    {
      sums = std::move(*s);
      layers = std::move(*l);
    }
  }
  vtkMultiProcessStream mine;
  mine << error << int(piece && error.empty());
  pushArray(mine, sums.keys);
  pushArray(mine, std::vector<vtkTypeUInt64>(sums.values.begin(), sums.values.end()));
  for (int a = 0; a < 3; ++a)
  {
    mine << layers.lo[a] << layers.hi[a];
  }
  for (const std::vector<uint32_t>& layer : layers.layers)
  {
    pushArray(mine, layer);
  }
  sums = csgv::AttributeSums{};
  layers = csgv::PieceLayers{};
  std::vector<vtkMultiProcessStream> all;
  c->Gather(mine, all, 0);

  vtkMultiProcessStream answer;
  if (c->GetLocalProcessId() == 0)
  {
    csgv::AttributeSums total;
    std::vector<csgv::PieceLayers> pieces;
    std::string first;
    for (size_t r = 0; r < all.size(); ++r)
    {
      std::string theirError;
      int has = 0;
      all[r] >> theirError >> has;
      csgv::AttributeSums theirs;
      theirs.keys = popArray<unsigned int, uint32_t>(all[r]);
      theirs.values = popArray<vtkTypeUInt64, uint64_t>(all[r]);
      csgv::PieceLayers l;
      for (int a = 0; a < 3; ++a)
      {
        all[r] >> l.lo[a] >> l.hi[a];
      }
      for (std::vector<uint32_t>& layer : l.layers)
      {
        layer = popArray<unsigned int, uint32_t>(all[r]);
      }
      if (!theirError.empty() && first.empty())
      {
        first = "rank " + std::to_string(r) + ": " + theirError;
      }
      if (has)
      {
        total.add(theirs);
        pieces.push_back(std::move(l));
      }
    }
    csgv::addFacesBetweenPieces(total, pieces);
    answer << first;
    pushArray(answer, total.keys);
    pushArray(answer, std::vector<vtkTypeUInt64>(total.values.begin(), total.values.end()));
  }
  c->Broadcast(answer, 0);
  csgv::AttributeSums total;
  answer >> error;
  total.keys = popArray<unsigned int, uint32_t>(answer);
  total.values = popArray<vtkTypeUInt64, uint64_t>(answer);
  if (!error.empty() || !piece)
  {
    return error;
  }
  csgv::ComputeAttributesOptions options;
  if (!shared->idToLabel.empty())
  {
    options.idToLabel = &shared->idToLabel;
  }
  csgv::Result<csgv::AttributeTable> table = csgv::attributeTable(total, options);
  if (!table)
  {
    return "computing attributes: " + table.message();
  }
  std::lock_guard<std::mutex> lock(volumeMutex());
  shared->computed = std::make_shared<const csgv::AttributeTable>(std::move(*table));
  reduced = true;
  return std::string();
}

std::string shareGhostFaces(vtkMultiProcessController* c, const VolumeSource& source)
{
  const std::shared_ptr<SharedVolume> shared = source.shared;
  const bool piece = shared && !shared->owned.empty();
  std::string error;
  csgv::PieceLayers layers;
  if (piece)
  {
    const uint32_t b = shared->volume.brickSize;
    std::array<uint32_t, 3> offset{};
    for (int a = 0; a < 3; ++a)
    {
      offset[a] = shared->owned.lo[a] * b;
    }
    csgv::Result<csgv::CompressedVolume> own = csgv::extractPiece(shared->volume, shared->owned);
    csgv::Result<csgv::PieceLayers> l =
      own ? csgv::pieceLayers(*own, offset, shared->volume.dim) : csgv::Result<csgv::PieceLayers>(own.status());
    if (l)
    {
      layers = std::move(*l);
    }
    else
    {
      error = "the piece's outer layers: " + l.message();
    }
  }
  // Every rank gets every piece's layers (gathered on rank 0, broadcast).
  vtkMultiProcessStream mine;
  mine << int(piece && error.empty());
  for (int a = 0; a < 3; ++a)
  {
    mine << layers.lo[a] << layers.hi[a];
  }
  for (const std::vector<uint32_t>& layer : layers.layers)
  {
    pushArray(mine, layer);
  }
  layers = csgv::PieceLayers{};
  std::vector<vtkMultiProcessStream> all;
  c->Gather(mine, all, 0);
  // Read a piece's part of a stream (what `mine` holds).
  auto readPiece = [](vtkMultiProcessStream& s, csgv::PieceLayers& l) {
    int has = 0;
    s >> has;
    for (int a = 0; a < 3; ++a)
    {
      s >> l.lo[a] >> l.hi[a];
    }
    for (std::vector<uint32_t>& layer : l.layers)
    {
      layer = popArray<unsigned int, uint32_t>(s);
    }
    return has != 0;
  };
  std::vector<csgv::PieceLayers> pieces;
  vtkMultiProcessStream everyone;
  if (c->GetLocalProcessId() == 0)
  {
    for (vtkMultiProcessStream& s : all)
    {
      csgv::PieceLayers l;
      if (readPiece(s, l))
      {
        pieces.push_back(std::move(l));
      }
    }
    everyone << static_cast<unsigned int>(pieces.size());
    for (const csgv::PieceLayers& l : pieces)
    {
      everyone << 1;
      for (int a = 0; a < 3; ++a)
      {
        everyone << l.lo[a] << l.hi[a];
      }
      for (const std::vector<uint32_t>& layer : l.layers)
      {
        pushArray(everyone, layer);
      }
    }
  }
  all.clear();
  c->Broadcast(everyone, 0);
  if (c->GetLocalProcessId() != 0)
  {
    unsigned int n = 0;
    everyone >> n;
    for (unsigned int r = 0; r < n; ++r)
    {
      csgv::PieceLayers l;
      readPiece(everyone, l);
      pieces.push_back(std::move(l));
    }
  }
  if (!piece || !error.empty())
  {
    return error;
  }
  std::array<uint32_t, 3> lo{}, hi{};
  const uint32_t b = shared->volume.brickSize;
  for (int a = 0; a < 3; ++a)
  {
    lo[a] = shared->owned.lo[a] * b;
    hi[a] = lo[a] + shared->pieceDims[a];
  }
  auto ghost = std::make_shared<const GhostFaces>(csgv::ghostFaces(lo, hi, shared->volume.dim, pieces));
  std::lock_guard<std::mutex> lock(volumeMutex());
  shared->ghost = std::move(ghost);
  return std::string();
}

} // namespace csgvrep
