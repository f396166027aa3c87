// SPDX-License-Identifier: MIT
#include "vtkCSGVQuery.h"

#include "CSGVQueryProtocol.h"
#include "vtkCSGVRepresentation.h"

#include <vtkMultiProcessController.h>
#include <vtkMultiProcessStream.h>
#include <vtkObjectFactory.h>

#include <nlohmann/json.hpp>

#include <sstream>
#include <vector>

vtkStandardNewMacro(vtkCSGVQuery);

namespace
{
/// Every rank's `mine` on rank 0 (collective; the others get nothing), in rank order.
std::vector<std::vector<int64_t>> GatherLabelSets(vtkMultiProcessController* c, const std::vector<int64_t>& mine)
{
  const int ranks = c->GetNumberOfProcesses();
  const bool root = c->GetLocalProcessId() == 0;
  const long count = long(mine.size());
  std::vector<long> counts(size_t(ranks), 0);
  c->Gather(&count, counts.data(), 1, 0);
  std::vector<vtkIdType> lengths(size_t(ranks), 0), offsets(size_t(ranks), 0);
  vtkIdType total = 0;
  for (int r = 0; r < ranks; ++r)
  {
    lengths[size_t(r)] = vtkIdType(counts[size_t(r)]);
    offsets[size_t(r)] = total;
    total += lengths[size_t(r)];
  }
  std::vector<long> flat(root ? size_t(std::max<vtkIdType>(total, 1)) : 1);
  const long none = 0; // MPI takes a zero-length send, VTK's wrappers a valid pointer
  c->GatherV(mine.empty() ? &none : reinterpret_cast<const long*>(mine.data()), flat.data(), vtkIdType(count),
    lengths.data(), offsets.data(), 0);
  std::vector<std::vector<int64_t>> out;
  if (root)
  {
    for (int r = 0; r < ranks; ++r)
    {
      const long* at = flat.data() + offsets[size_t(r)];
      out.emplace_back(at, at + lengths[size_t(r)]);
    }
  }
  return out;
}
} // namespace

vtkCSGVQuery::~vtkCSGVQuery()
{
  this->SetRequest(nullptr);
}

void vtkCSGVQuery::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Request: " << (this->Request ? this->Request : "") << "\n";
}

void vtkCSGVQuery::SetRepresentation(vtkObject* object)
{
  vtkCSGVRepresentation* representation = vtkCSGVRepresentation::SafeDownCast(object);
  this->Representation = representation;
  this->Modified();
  if (this->Pending && representation)
  {
    this->Gather();
  }
}

void vtkCSGVQuery::SetRequest(const char* request)
{
  const std::string text = request ? request : "";
  delete[] this->Request;
  this->Request = new char[text.size() + 1];
  std::copy(text.c_str(), text.c_str() + text.size() + 1, this->Request);
  this->Modified();
  this->Gather();
}

void vtkCSGVQuery::Gather()
{
  const std::string text = this->Request ? this->Request : "";
  this->Gathered = false;
  this->Pending = !this->Representation;
  vtkMultiProcessController* c = vtkMultiProcessController::GetGlobalController();
  std::istringstream in(text);
  std::string what;
  in >> what;
  if (!c || c->GetNumberOfProcesses() < 2 || !this->Representation || what.empty() ||
    (what != "pick" && what != "labels" && what != "summary" && what != "colors" && what != "span" &&
      what != "match" && what != "render"))
  {
    return; // answered by GetResult where it is read
  }
  // Every rank answers for its own piece; rank 0 keeps, per pixel, the one rank's hit: the
  // nearest opaque one, else the nearest semi-transparent one (csgvrep::hitOrder).
  vtkMultiProcessStream mine;
  if (what == "pick" || what == "colors" || what == "span" || what == "match" || what == "render")
  {
    mine << std::string(this->Representation->Query(text.c_str()));
  }
  else if (what == "summary")
  {
    mine << std::string(this->Representation->Query(text.c_str()));
  }
  else
  {
    uint32_t w = 0, h = 0;
    std::vector<uint32_t> labels;
    std::vector<float> depths;
    if (!this->Representation->LastLabels(w, h, labels, depths) || labels.size() != size_t(w) * h ||
      depths.size() != labels.size())
    {
      w = h = 0; // nothing drawn here (a hidden display, an empty piece, one off the screen)
      labels.clear();
      depths.clear();
    }
    mine << w << h;
    if (!labels.empty()) // vtkMultiProcessStream asserts on an empty array (attack pass 8: a rank
    {                    // that drew nothing aborted the job, and a connected client with it)
      mine.Push(labels.data(), static_cast<unsigned int>(labels.size()));
      mine.Push(depths.data(), static_cast<unsigned int>(depths.size()));
    }
  }
  std::vector<vtkMultiProcessStream> all;
  c->Gather(mine, all, 0);
  // summary: every rank's labels (for the count of their union), as arrays: through the stream
  // (a deque of bytes, as base64 text) 2 million labels a rank took 4 s.
  std::vector<std::vector<int64_t>> labelSets;
  if (what == "summary")
  {
    labelSets = GatherLabelSets(c, csgvrep::labelSetOf(this->Representation->Query("labelset")));
  }
  if (c->GetLocalProcessId() == 0)
  {
    this->Combine(text, what, all, labelSets);
  }
  // Every rank reads the combined answer: under pvbatch --symmetric each rank's script reads its
  // own Result, and a value derived from a rank's local answer (a bound for a material, say)
  // would differ between ranks, and so would what they draw.
  vtkMultiProcessStream answer;
  if (c->GetLocalProcessId() == 0)
  {
    answer << this->Answer;
  }
  c->Broadcast(answer, 0);
  if (c->GetLocalProcessId() != 0)
  {
    answer >> this->Answer;
  }
  this->Gathered = true;
}

void vtkCSGVQuery::Combine(const std::string& text, const std::string& what,
  std::vector<vtkMultiProcessStream>& all, const std::vector<std::vector<int64_t>>& labelSets)
{
  this->Answer.clear();
  if (what == "summary" || what == "colors" || what == "span" || what == "match" || what == "render")
  {
    std::vector<std::string> answers;
    for (vtkMultiProcessStream& s : all)
    {
      std::string answer;
      s >> answer;
      answers.push_back(answer);
    }
    this->Answer = csgvrep::combineAnswers(text, answers, labelSets);
  }
  else if (what == "pick")
  {
    double nearest = 5.0;
    for (vtkMultiProcessStream& s : all)
    {
      std::string answer;
      s >> answer;
      const nlohmann::json j = nlohmann::json::parse(answer, nullptr, false);
      const bool hit = j.is_object() && j.value("hit", false) && j.contains("depth") && j["depth"].is_number();
      const double order =
        csgvrep::hitOrder(hit, hit && j.value("translucent", false), hit ? j["depth"].get<double>() : 1.0);
      if (this->Answer.empty() || order < nearest)
      {
        nearest = order;
        this->Answer = answer;
      }
    }
  }
  else
  {
    uint32_t width = 0, height = 0;
    std::vector<uint32_t> labels;
    std::vector<float> depths;
    for (vtkMultiProcessStream& s : all)
    {
      uint32_t w = 0, h = 0;
      s >> w >> h;
      unsigned int* l = nullptr;
      float* d = nullptr;
      unsigned int nl = 0, nd = 0;
      if (w > 0 && h > 0)
      {
        s.Pop(l, nl);
        s.Pop(d, nd);
      }
      if (labels.empty() && nl == size_t(w) * h && nd == nl)
      {
        width = w;
        height = h;
        labels.assign(l, l + nl);
        depths.assign(d, d + nd);
      }
      else if (w == width && h == height && nl == labels.size() && nd == nl)
      {
        for (size_t i = 0; i < nl; ++i)
        {
          if (d[i] < depths[i])
          {
            depths[i] = d[i];
            labels[i] = l[i];
          }
        }
      }
      delete[] l;
      delete[] d;
    }
    std::ostringstream o;
    o << width << " " << height << " " << csgvrep::base64(labels.data(), labels.size() * sizeof(uint32_t));
    this->Answer = o.str();
  }
}

const char* vtkCSGVQuery::GetResult()
{
  if (this->Gathered)
  {
    return this->Answer.c_str();
  }
  if (!this->Representation)
  {
    this->Answer = "{\"error\": \"no Segmentation Volume representation\"}";
  }
  else
  {
    this->Answer = this->Representation->Query(this->Request ? this->Request : "summary");
  }
  return this->Answer.c_str();
}
