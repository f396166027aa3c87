// SPDX-License-Identifier: MIT
#include "CSGVPieceAttributes.h"

#include "CSGVAttributes.h"
#include "CSGVStreamArrays.h"

#include "csgv/attributes/Attributes.h"
#include "csgv/codec/Decoder.h"

#include <vtkCommunicator.h>
#include <vtkMultiProcessController.h>
#include <vtkMultiProcessStream.h>

#include <algorithm>
#include <mutex>

namespace csgvrep
{

namespace
{

using csgvvtk::popArray;
using csgvvtk::pushArray;

void pushLayers(vtkMultiProcessStream& s, const csgv::PieceLayers& l)
{
  for (int a = 0; a < 3; ++a)
  {
    s << l.lo[a] << l.hi[a];
  }
  for (const std::vector<uint32_t>& layer : l.layers)
  {
    pushArray(s, layer);
  }
}

csgv::PieceLayers popLayers(vtkMultiProcessStream& s)
{
  csgv::PieceLayers l;
  for (int a = 0; a < 3; ++a)
  {
    s >> l.lo[a] >> l.hi[a];
  }
  for (std::vector<uint32_t>& layer : l.layers)
  {
    layer = popArray<unsigned int, uint32_t>(s);
  }
  return l;
}

/// Every piece's layers on every rank (gathered on rank 0, broadcast). `mine` holds this rank's
/// when `has`; a rank that failed to decode its own says so in `error`, which rank 0 sends to all.
std::string exchangeLayers(vtkMultiProcessController* c, bool has, const csgv::PieceLayers& mine,
  std::string error, std::vector<csgv::PieceLayers>& all)
{
  vtkMultiProcessStream out;
  out << error << int(has);
  if (has)
  {
    pushLayers(out, mine);
  }
  std::vector<vtkMultiProcessStream> gathered;
  c->Gather(out, gathered, 0);
  vtkMultiProcessStream everyone;
  if (c->GetLocalProcessId() == 0)
  {
    std::string first;
    for (size_t r = 0; r < gathered.size(); ++r)
    {
      std::string theirError;
      int theirs = 0;
      gathered[r] >> theirError >> theirs;
      if (!theirError.empty() && first.empty())
      {
        first = "rank " + std::to_string(r) + ": " + theirError;
      }
      if (theirs)
      {
        all.push_back(popLayers(gathered[r]));
      }
    }
    everyone << first << static_cast<unsigned int>(all.size());
    for (const csgv::PieceLayers& l : all)
    {
      pushLayers(everyone, l);
    }
  }
  gathered.clear();
  c->Broadcast(everyone, 0);
  if (c->GetLocalProcessId() != 0)
  {
    unsigned int n = 0;
    everyone >> error >> n;
    for (unsigned int r = 0; r < n; ++r)
    {
      all.push_back(popLayers(everyone));
    }
    return error;
  }
  everyone >> error;
  return error;
}

/// The computed attributes of the whole volume from every piece's sums (rank 0 adds them and the
/// faces between the pieces, from `layers`) on every rank that has a piece.
std::string reduceComputed(vtkMultiProcessController* c, const std::shared_ptr<SharedVolume>& shared,
  const std::vector<csgv::PieceLayers>& layers, bool& reduced)
{
  std::string error;
  csgv::AttributeSums sums;
  if (shared)
  {
    csgv::Result<csgv::AttributeSums> s = ownedAttributeSums(*shared, {});
    if (s)
    {
      sums = std::move(*s);
    }
    else
    {
      error = "computing attributes of this piece: " + s.message();
    }
  }
  vtkMultiProcessStream mine;
  mine << error;
  pushArray(mine, sums.keys);
  pushArray(mine, std::vector<vtkTypeUInt64>(sums.values.begin(), sums.values.end()));
  sums = csgv::AttributeSums{};
  std::vector<vtkMultiProcessStream> all;
  c->Gather(mine, all, 0);
  vtkMultiProcessStream answer;
  if (c->GetLocalProcessId() == 0)
  {
    csgv::AttributeSums total;
    std::string first;
    for (size_t r = 0; r < all.size(); ++r)
    {
      std::string theirError;
      all[r] >> theirError;
      csgv::AttributeSums theirs;
      theirs.keys = popArray<unsigned int, uint32_t>(all[r]);
      theirs.values = popArray<vtkTypeUInt64, uint64_t>(all[r]);
      if (!theirError.empty() && first.empty())
      {
        first = "rank " + std::to_string(r) + ": " + theirError;
      }
      total.add(theirs);
    }
    csgv::addFacesBetweenPieces(total, layers);
    answer << first;
    pushArray(answer, total.keys);
    pushArray(answer, std::vector<vtkTypeUInt64>(total.values.begin(), total.values.end()));
  }
  c->Broadcast(answer, 0);
  csgv::AttributeSums total;
  answer >> error;
  total.keys = popArray<unsigned int, uint32_t>(answer);
  total.values = popArray<vtkTypeUInt64, uint64_t>(answer);
  if (!error.empty() || !shared)
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

/// Memory the coarse stand-ins' finest level may take on each rank (the coarser ones add a
/// seventh): the finest level that fits is shared, exact for small volumes (about 1024^3 at B 32:
/// level 3, 4^3 nodes a brick, 8 MiB).
constexpr uint64_t kCoarseStandInBytes = uint64_t(16) << 20;

uint32_t coarseStandInLevel(const csgv::CompressedVolume& v)
{
  for (uint32_t level = 0;; ++level)
  {
    const std::array<uint32_t, 3> d = csgv::lodDimensions(v.dim, level);
    if (uint64_t(d[0]) * d[1] * d[2] * 4 <= kCoarseStandInBytes || level + 1 >= v.levels())
    {
      return level;
    }
  }
}

/// The whole volume's levels from coarseStandInLevel to the coarsest on every rank: each decodes
/// its own bricks there, and a maximum over the ranks fills in the others' (every node has one
/// owner; the others give 0).
std::string shareCoarseStandIns(vtkMultiProcessController* c, const std::shared_ptr<SharedVolume>& shared)
{
  // The first level, the levels and the volume's dimensions: every rank with a piece agrees.
  unsigned int mine[5] = { 0, 0, 0, 0, 0 }, agreed[5] = { 0, 0, 0, 0, 0 };
  if (shared)
  {
    mine[0] = coarseStandInLevel(shared->volume);
    mine[1] = shared->volume.levels();
    std::copy(shared->volume.dim.begin(), shared->volume.dim.end(), mine + 2);
  }
  c->AllReduce(mine, agreed, 5, vtkCommunicator::MAX_OP);
  const uint32_t first = agreed[0], levels = agreed[1];
  const std::array<uint32_t, 3> dim{ agreed[2], agreed[3], agreed[4] };
  if (levels == 0)
  {
    return std::string();
  }
  std::vector<uint64_t> offsets{ 0 }; // of each level in the exchanged words
  for (uint32_t l = first; l < levels; ++l)
  {
    const std::array<uint32_t, 3> d = csgv::lodDimensions(dim, l);
    offsets.push_back(offsets.back() + uint64_t(d[0]) * d[1] * d[2]);
  }
  std::vector<uint32_t> words(offsets.back(), 0u);
  std::string error;
  if (shared && !std::equal(mine, mine + 5, agreed))
  {
    error = "the pieces disagree on the volume's coarse levels";
  }
  for (uint32_t l = first; shared && error.empty() && l < levels; ++l)
  {
    const std::array<uint32_t, 3> d = csgv::lodDimensions(dim, l);
    const uint32_t edge = shared->volume.brickSize >> l;
    csgv::Box box;
    for (int a = 0; a < 3; ++a)
    {
      box.min[a] = shared->owned.lo[a] * edge;
      box.max[a] = std::min(shared->owned.hi[a] * edge, d[a]);
    }
    csgv::Result<csgv::LabelVolume> part = csgv::decodeRegion(shared->volume, l, box);
    if (!part)
    {
      error = "the piece's level " + std::to_string(l) + ": " + part.message();
      break;
    }
    uint32_t* level = words.data() + offsets[l - first];
    for (uint32_t z = 0; z < part->dim[2]; ++z)
      for (uint32_t y = 0; y < part->dim[1]; ++y)
      {
        const uint32_t* from = part->labels.data() + part->index(0, y, z);
        std::copy(from, from + part->dim[0],
          level + box.min[0] + d[0] * (uint64_t(box.min[1] + y) + d[1] * uint64_t(box.min[2] + z)));
      }
  }
  std::vector<uint32_t> all(words.size());
  c->AllReduce(words.data(), all.data(), vtkIdType(words.size()), vtkCommunicator::MAX_OP);
  if (shared && error.empty())
  {
    auto coarse = std::make_shared<CoarseStandIns>();
    coarse->first = first;
    for (size_t i = 0; i + 1 < offsets.size(); ++i)
    {
      coarse->levels.emplace_back(all.begin() + offsets[i], all.begin() + offsets[i + 1]);
    }
    std::lock_guard<std::mutex> lock(volumeMutex());
    shared->coarse = std::move(coarse);
  }
  return error;
}

} // namespace

std::string shareAcrossRanks(
  vtkMultiProcessController* c, const VolumeSource& source, bool computed, bool& reduced)
{
  reduced = false;
  // Only pieces of one .csgv placed in the volume's index space (or nothing) share.
  const std::shared_ptr<SharedVolume> shared =
    source.shared && !source.shared->owned.empty() ? source.shared : nullptr;
  int mineOk = !source.shared || shared ? 1 : 0, allOk = 0;
  c->AllReduce(&mineOk, &allOk, 1, vtkCommunicator::MIN_OP);
  if (!allOk)
  {
    return std::string();
  }
  // The piece's voxels and their outer layers, decoded from the embedded volume.
  std::array<uint32_t, 3> lo{}, hi{};
  std::string error;
  csgv::PieceLayers mine;
  if (shared)
  {
    const uint32_t b = shared->volume.brickSize;
    for (int a = 0; a < 3; ++a)
    {
      lo[a] = shared->owned.lo[a] * b;
      hi[a] = lo[a] + shared->pieceDims[a];
    }
    csgv::Result<csgv::PieceLayers> l = csgv::pieceLayers(shared->volume, lo, hi);
    if (l)
    {
      mine = std::move(*l);
    }
    else
    {
      error = "the piece's outer layers: " + l.message();
    }
  }
  std::vector<csgv::PieceLayers> layers;
  error = exchangeLayers(c, shared && error.empty(), mine, error, layers);
  if (error.empty() && shared)
  {
    auto ghost = std::make_shared<const GhostFaces>(csgv::ghostFaces(lo, hi, shared->volume.dim, layers));
    std::lock_guard<std::mutex> lock(volumeMutex());
    shared->ghost = std::move(ghost);
  }
  const std::string coarseError = shareCoarseStandIns(c, shared); // collective: every rank, always
  if (error.empty())
  {
    error = coarseError;
  }
  if (shared)
  {
    // What the renderer's label table must cover beyond the piece's own labels.
    std::lock_guard<std::mutex> lock(volumeMutex());
    uint32_t largest = 0;
    auto take = [&largest](const std::vector<uint32_t>& labels)
    {
      for (uint32_t l : labels)
      {
        largest = l != csgv::gpu::kNone && l > largest ? l : largest;
      }
    };
    if (shared->ghost)
    {
      for (const std::vector<uint32_t>& face : *shared->ghost)
      {
        take(face);
      }
    }
    if (shared->coarse)
    {
      for (const std::vector<uint32_t>& level : shared->coarse->levels)
      {
        take(level);
      }
    }
    shared->largestOtherLabel = largest;
  }
  if (!computed || !error.empty())
  {
    return error;
  }
  return reduceComputed(c, shared, layers, reduced);
}

} // namespace csgvrep
