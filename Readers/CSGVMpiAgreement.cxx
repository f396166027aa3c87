// SPDX-License-Identifier: MIT
#include "CSGVMpiAgreement.h"
#include "CSGVStreamArrays.h"

#include <vtkCommunicator.h>
#include <vtkMultiProcessController.h>
#include <vtkMultiProcessStream.h>

namespace csgvvtk
{

const char* const kOtherFailed = "another process could not encode its piece";

namespace
{

/// Symbol counts summed over the processes (one all-reduce), or an error when one of them could
/// not encode its piece (`ok` false: this one).
csgv::Result<csgv::SymbolCounts> sumCounts(
  vtkMultiProcessController* c, bool ok, const csgv::SymbolCounts& mine)
{
  unsigned long long send[33] = {}, sum[33] = {};
  send[0] = ok ? 0 : 1;
  for (int k = 0; k < 16; ++k)
  {
    send[1 + k] = mine.a[k];
    send[17 + k] = mine.b[k];
  }
  c->AllReduce(send, sum, 33, vtkCommunicator::SUM_OP);
  if (sum[0] != 0)
  {
    return csgv::Status::error(kOtherFailed);
  }
  csgv::SymbolCounts all;
  for (int k = 0; k < 16; ++k)
  {
    all.a[k] = sum[1 + k];
    all.b[k] = sum[17 + k];
  }
  return all;
}

} // namespace

MpiAgreement::MpiAgreement(vtkMultiProcessController* c, uint32_t brickSize, bool shareCounts)
  : Controller(c)
  , BrickSize(brickSize)
  , ShareCounts(shareCounts)
{
}

csgv::Result<bool> MpiAgreement::anyRelabels(bool ok, bool mine)
{
  this->Asked = true;
  unsigned long long send[2] = { ok ? 0ull : 1ull, mine ? 1ull : 0ull }, sum[2] = {};
  this->Controller->AllReduce(send, sum, 2, vtkCommunicator::SUM_OP);
  if (sum[0] != 0)
  {
    return csgv::Status::error(kOtherFailed);
  }
  this->Relabelled = sum[1] != 0;
  return this->Relabelled;
}

csgv::Result<std::vector<uint64_t>> MpiAgreement::ids(bool ok, const csgv::StreamingRelabeller& mine)
{
  return this->exchangeIds(ok, mine.firstVisits());
}

csgv::Result<csgv::SymbolCounts> MpiAgreement::counts(bool ok, const csgv::SymbolCounts& mine)
{
  this->Shared = true;
  return sumCounts(this->Controller, ok, mine);
}

void MpiAgreement::catchUp(bool ok)
{
  if (!this->Asked)
  {
    this->anyRelabels(ok, false);
  }
  if (this->Relabelled && !this->Exchanged)
  {
    this->exchangeIds(ok, {});
  }
  if (this->ShareCounts && !this->Shared)
  {
    this->counts(ok, csgv::SymbolCounts{});
  }
}

/// Process 0 merges every piece's first visits, chooses the ids and sends them to all.
csgv::Result<std::vector<uint64_t>> MpiAgreement::exchangeIds(
  bool ok, std::vector<std::pair<uint64_t, csgv::VisitPosition>> visits)
{
  this->Exchanged = true;
  std::vector<vtkTypeUInt64> labels, bricks;
  std::vector<unsigned int> voxels;
  for (const auto& v : visits)
  {
    labels.push_back(v.first);
    bricks.push_back(v.second.brick);
    voxels.push_back(v.second.voxel);
  }
  visits.clear();
  vtkMultiProcessStream mine;
  mine << int(ok);
  pushArray(mine, labels);
  pushArray(mine, bricks);
  pushArray(mine, voxels);
  std::vector<vtkMultiProcessStream> all;
  this->Controller->Gather(mine, all, 0);
  vtkMultiProcessStream answer;
  if (this->Controller->GetLocalProcessId() == 0)
  {
    std::string error;
    csgv::StreamingRelabeller merged(this->volumeDims, this->BrickSize);
    for (vtkMultiProcessStream& s : all)
    {
      int theirOk = 0;
      s >> theirOk;
      const std::vector<vtkTypeUInt64> l = popArray<vtkTypeUInt64>(s), b = popArray<vtkTypeUInt64>(s);
      const std::vector<unsigned int> v = popArray<unsigned int>(s);
      if (!theirOk)
      {
        error = kOtherFailed;
      }
      for (size_t i = 0; i < l.size() && i < b.size() && i < v.size(); ++i)
      {
        merged.takeFirstVisit(l[i], csgv::VisitPosition{ b[i], v[i] });
      }
    }
    if (error.empty())
    {
      const csgv::Status finished = merged.finish();
      error = finished ? std::string() : finished.message();
    }
    std::vector<vtkTypeUInt64> table;
    if (error.empty())
    {
      table.assign(merged.originalBits().begin(), merged.originalBits().end());
    }
    answer << error;
    pushArray(answer, table);
  }
  this->Controller->Broadcast(answer, 0);
  std::string error;
  answer >> error;
  const std::vector<vtkTypeUInt64> table = popArray<vtkTypeUInt64>(answer);
  this->Table.assign(table.begin(), table.end());
  if (!error.empty())
  {
    return csgv::Status::error(error);
  }
  return this->Table;
}

} // namespace csgvvtk
