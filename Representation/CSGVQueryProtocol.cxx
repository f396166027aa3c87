// SPDX-License-Identifier: MIT
#include "CSGVQueryProtocol.h"
#include "CSGVAdapter.h" // the readers' FieldData contract (CSGV::Readers)

#include "csgv/base/Math.h"

#include <vtkBase64Utilities.h>
#include <vtkImageData.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <limits>
#include <array>
#include <set>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <sstream>
#include <vector>

namespace csgvrep
{
namespace
{

using nlohmann::json;

/// World position of an NDC point under a column-major clip-to-world matrix (the inverse of the
/// view's world-to-clip); false at infinity (w = 0).
bool unproject(const csgv::Mat4& clipToWorld, double ndcX, double ndcY, double ndcZ, csgv::Vec3& world)
{
  const csgv::Vec4 p = csgv::transform(clipToWorld, { ndcX, ndcY, ndcZ, 1.0 });
  if (p[3] == 0.0)
  {
    return false;
  }
  world = { p[0] / p[3], p[1] / p[3], p[2] / p[3] };
  return true;
}

/// The property defaults, keyed by their server-manager names.
std::string defaultsJson()
{
  const RepresentationProperties d;
  json j;
#define CSGV_PROPERTY(Name, member, type, count, values) j["CSGV" #Name] = d.member;
#include "CSGVProperties.def"
#undef CSGV_PROPERTY
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

/// The request's next word as a whole number in [lo, hi] into `value` (which keeps its default
/// when there is no word, unless `required`): "" or an error naming the word.
std::string nextNumber(std::istringstream& in, const char* what, long long lo, long long hi, long long& value,
  bool required = false)
{
  std::string word;
  if (!(in >> word))
  {
    return required ? std::string(what) + " needs a whole number" : std::string();
  }
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(word.c_str(), &end, 10);
  if (*end != '\0' || errno == ERANGE || v < lo || v > hi)
  {
    return std::string(what) + ": '" + word.substr(0, 40) + "' is not a whole number from " + std::to_string(lo) +
      " to " + std::to_string(hi);
  }
  value = v;
  return std::string();
}

std::string errorJson(const std::string& message)
{
  return json({ { "error", message } }).dump(-1, ' ', false, json::error_handler_t::replace);
}

/// "" when the request has no words left, else an error naming the first (a command given more
/// than it takes: "summary extra" is not silently a summary).
std::string extraWords(std::istringstream& in, const std::string& what)
{
  std::string word;
  if (!(in >> word))
  {
    return std::string();
  }
  return "'" + what + "' takes no more than it was given: '" + word.substr(0, 40) + "' is left over";
}

} // namespace

std::string base64(const void* data, size_t bytes)
{
  std::string out((bytes + 2) / 3 * 4, '\0');
  if (bytes > 0)
  {
    const unsigned long n = vtkBase64Utilities::Encode(static_cast<const unsigned char*>(data),
      static_cast<unsigned long>(bytes), reinterpret_cast<unsigned char*>(&out[0]));
    out.resize(n);
  }
  return out;
}

namespace
{
json statisticsJson(const RenderStatistics& r)
{
  return json({ { "CSGVFramesLastRender", r.framesLastRender }, { "CSGVMinSamples", r.minSamples },
    { "CSGVCacheMiB", r.cacheMiB }, { "CSGVDeviceMiB", r.deviceMiB }, { "CSGVDeviceBudgetMiB", r.deviceBudgetMiB },
    { "CSGVCacheBits", r.cacheBits }, { "CSGVDetailSeparated", r.detailSeparated },
    { "CSGVDetailStreamedMiB", r.detailStreamedMiB }, { "CSGVLevelsOnDisk", r.levelsOnDisk },
    { "CSGVFileReadMiB", r.fileReadMiB }, { "CSGVBadBricks", r.badBricks }, { "CSGVLabelLookup", r.labelLookup } });
}

/// `render` over MPI ranks: the fewest samples of the ranks that rendered (a rank with nothing
/// to draw renders no frame), the most frames, memory (budgets too: each rank has its own) and bad
/// bricks summed, the label lookup "scan" where a rank's is, the largest of the rest.
json combineStatistics(const std::vector<json>& replies)
{
  json out = replies.front();
  int fewest = -1;
  for (const json& j : replies)
  {
    if (j.value("CSGVFramesLastRender", 0) > 0)
    {
      const int m = j.value("CSGVMinSamples", 0);
      fewest = fewest < 0 ? m : std::min(fewest, m);
    }
  }
  for (auto it = out.begin(); it != out.end(); ++it)
  {
    const std::string& key = it.key();
    const bool summed = key.size() > 3 && (key.compare(key.size() - 3, 3, "MiB") == 0 || key == "CSGVBadBricks");
    for (size_t i = 1; i < replies.size(); ++i)
    {
      const json& v = replies[i].contains(key) ? replies[i][key] : json(0);
      if (!v.is_number() || !it->is_number())
      {
        continue;
      }
      if (summed)
      {
        *it = it->is_number_integer() ? json(it->get<int64_t>() + v.get<int64_t>()) : json(it->get<double>() + v.get<double>());
      }
      else if (v.get<double>() > it->get<double>())
      {
        *it = v;
      }
    }
  }
  if (fewest >= 0)
  {
    out["CSGVMinSamples"] = fewest;
  }
  for (const json& j : replies)
  {
    const std::string lookup = j.value("CSGVLabelLookup", std::string());
    if (lookup == "scan" || out.value("CSGVLabelLookup", std::string()).empty())
    {
      out["CSGVLabelLookup"] = lookup;
    }
  }
  return out;
}
} // namespace

std::vector<int64_t> labelSetOf(const std::string& reply)
{
  std::vector<int64_t> out;
  if (reply.empty() || reply[0] == '{')
  {
    return out; // no labels, or an error
  }
  std::vector<unsigned char> bytes(reply.size());
  const size_t n = vtkBase64Utilities::DecodeSafely(
    reinterpret_cast<const unsigned char*>(reply.data()), reply.size(), bytes.data(), bytes.size());
  out.resize(n / sizeof(int64_t));
  std::memcpy(out.data(), bytes.data(), out.size() * sizeof(int64_t)); // little-endian, as the hosts here
  return out;
}

std::string combineAnswers(const std::string& request, const std::vector<std::string>& answers,
  const std::vector<std::vector<int64_t>>& labelSets)
{
  std::istringstream in(request);
  std::string what;
  in >> what;
  std::vector<json> replies;
  for (const std::string& a : answers)
  {
    json j = json::parse(a, nullptr, false);
    if (j.is_object())
    {
      replies.push_back(std::move(j));
    }
  }
  if (replies.empty())
  {
    return answers.empty() ? std::string() : answers.front();
  }
  if (what == "render")
  {
    return combineStatistics(replies).dump(-1, ' ', false, json::error_handler_t::replace);
  }
  if (what == "colors")
  {
    size_t cap = 4096;
    in >> cap;
    std::map<int64_t, json> byLabel;
    bool truncated = false;
    std::string text, error;
    for (const json& r : replies)
    {
      if (r.contains("error"))
      {
        error = error.empty() ? r["error"].get<std::string>() : error;
        continue;
      }
      truncated = truncated || r.value("truncated", false);
      text = text.empty() ? r.value("text", std::string()) : text;
      for (const json& l : r.value("labels", json::array()))
      {
        byLabel.emplace(l[0].get<int64_t>(), l);
      }
    }
    if (byLabel.empty() && !error.empty())
    {
      return json({ { "error", error } }).dump(-1, ' ', false, json::error_handler_t::replace);
    }
    json labels = json::array();
    for (auto& kv : byLabel)
    {
      if (labels.size() == cap)
      {
        truncated = true;
        break;
      }
      labels.push_back(kv.second);
    }
    return json({ { "labels", labels }, { "truncated", truncated }, { "text", text } }).dump(-1, ' ', false, json::error_handler_t::replace);
  }
  if (what == "match")
  {
    // The union of every rank's labels (ranks hold different labels), the first error.
    std::set<int64_t> labels;
    bool truncated = false;
    std::string error;
    for (const json& r : replies)
    {
      if (r.contains("error"))
      {
        error = error.empty() ? r["error"].get<std::string>() : error;
        continue;
      }
      truncated = truncated || r.value("truncated", false);
      for (const json& l : r.value("labels", json::array()))
      {
        labels.insert(l.get<int64_t>());
      }
    }
    if (labels.empty() && !error.empty())
    {
      return json({ { "error", error } }).dump(-1, ' ', false, json::error_handler_t::replace);
    }
    json out = json::array();
    for (int64_t l : labels)
    {
      if (out.size() == csgv::kMaxOverlayLabels)
      {
        truncated = true;
        break;
      }
      out.push_back(l);
    }
    return json({ { "labels", out }, { "truncated", truncated } }).dump(-1, ' ', false, json::error_handler_t::replace);
  }
  if (what == "span")
  {
    // Every rank's range widened, their label counts summed (ranks hold different labels).
    json out = { { "min", nullptr }, { "max", nullptr }, { "labels", 0 } };
    size_t labels = 0;
    for (const json& r : replies)
    {
      if (r.contains("error"))
      {
        continue;
      }
      labels += r.value("labels", size_t(0));
      for (const char* key : { "min", "max" })
      {
        if (!r.contains(key) || !r[key].is_number())
        {
          continue;
        }
        const double v = r[key].get<double>();
        json& mine = out[key];
        if (mine.is_null() || (key[1] == 'i' ? v < mine.get<double>() : v > mine.get<double>()))
        {
          mine = v;
        }
      }
    }
    out["labels"] = labels;
    return out.dump(-1, ' ', false, json::error_handler_t::replace);
  }
  // summary: every rank's attributes (ranges widened), the union of their labels.
  std::vector<int64_t> labels;
  for (const std::vector<int64_t>& set : labelSets)
  {
    labels.insert(labels.end(), set.begin(), set.end());
  }
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  // Empty only when every rank's piece is (a rank may hold no bricks of the volume); the error of
  // a rank with data, else the first rank's.
  json out = replies.front();
  bool empty = true;
  for (const json& r : replies)
  {
    if (!r.value("empty", false))
    {
      empty = false;
      out["error"] = r.value("error", std::string());
      break;
    }
  }
  out["empty"] = empty;
  // A rank whose reader failed (attack pass 8: the other ranks' pieces passed for the whole
  // volume, the failure on that rank's stderr alone): named, whatever the others hold.
  for (size_t i = 0; i < replies.size(); ++i)
  {
    if (replies[i].contains("failed"))
    {
      const std::string why = "rank " + std::to_string(i) + ": " + replies[i].value("failed", std::string());
      out["failed"] = why;
      out["error"] = why;
      break;
    }
  }
  std::vector<std::string> order;
  std::map<std::string, json> attributes;
  for (const json& r : replies)
  {
    if (out.value("labelArray", std::string()).empty() && !r.value("labelArray", std::string()).empty())
    {
      out["labelArray"] = r["labelArray"];
    }
    for (const json& a : r.value("attributes", json::array()))
    {
      const std::string name = a.value("name", std::string());
      auto it = attributes.find(name);
      if (it == attributes.end())
      {
        order.push_back(name);
        attributes[name] = a;
        continue;
      }
      for (const char* key : { "min", "max" })
      {
        if (!a.contains(key) || a[key].is_null())
        {
          continue;
        }
        json& mine = it->second[key];
        const double v = a[key].get<double>();
        if (mine.is_null() || (key[1] == 'i' ? v < mine.get<double>() : v > mine.get<double>()))
        {
          mine = v;
        }
      }
    }
  }
  json list = json::array();
  for (const std::string& name : order)
  {
    list.push_back(attributes[name]);
  }
  out["attributes"] = list;
  out["labels"] = labels.size();
  return out.dump(-1, ' ', false, json::error_handler_t::replace);
}

RenderStatistics renderStatistics(const ViewRenderer& view)
{
  constexpr double kMiB = 1048576.0;
  RenderStatistics r;
  r.framesLastRender = int(view.framesLastRender());
  r.minSamples = int(view.lastStats().minSamples);
  r.cacheMiB = double(view.cacheBytes()) / kMiB;
  r.deviceMiB = double(view.deviceBytes()) / kMiB;
  r.deviceBudgetMiB = double(view.deviceBudget()) / kMiB;
  r.cacheBits = int(view.cacheBits());
  r.detailSeparated = view.detailSeparated() ? 1 : 0;
  r.detailStreamedMiB = double(view.detailStreamedBytes()) / kMiB;
  r.levelsOnDisk = view.levelsOnDisk();
  r.fileReadMiB = double(view.fileReadBytes()) / kMiB;
  r.badBricks = int(std::min<uint64_t>(view.badBricks(), uint64_t(std::numeric_limits<int>::max())));
  r.labelLookup = view.labelLookup();
  return r;
}


std::string answerQuery(const std::string& request, QueryContext& c)
{
  std::istringstream in(request);
  std::string what;
  in >> what;
  // Commands without arguments, and those of numbers (their words are read first), take nothing
  // more; "match" and "span" take the rest of the request.
  if (what == "defaults" || what == "stats" || what == "render" || what == "summary" || what == "labels")
  {
    if (const std::string extra = extraWords(in, what); !extra.empty())
    {
      return errorJson(extra);
    }
  }
  if (what == "defaults")
  {
    return defaultsJson();
  }
  if (what == "render")
  {
    return (c.view ? statisticsJson(renderStatistics(*c.view)) : json::object())
      .dump(-1, ' ', false, json::error_handler_t::replace);
  }
  if (what == "stats")
  {
    const std::shared_ptr<VolumeCache> cache = VolumeCache::instance();
    return json({ { "parses", cache->parses() }, { "sharedParses", cache->sharedParses() },
                  { "compressions", cache->compressions() } })
      .dump(-1, ' ', false, json::error_handler_t::replace);
  }

  const VolumeSource& source = c.source;
  std::shared_ptr<const csgv::AttributeTable> table;
  std::string tableError = c.sourceError;
  if (source.shared && c.attributes && c.config)
  {
    table = c.attributes->get(c.input, source, *c.config, tableError);
  }

  if (what == "summary")
  {
    const std::string summary = attributeSummary(
      table.get(), source.shared.get(), source.shared ? source.shared->arrayName : std::string(), tableError);
    json s = json::parse(summary);
    s["empty"] = c.emptyInput;
    if (!c.readError.empty())
    {
      s["failed"] = c.readError;
      s["error"] = c.readError; // not only "no input"
    }
    if (c.skipped && !c.skipped->empty())
    {
      s["skipped"] = *c.skipped;
    }
    return s.dump(-1, ' ', false, json::error_handler_t::replace);
  }
  if (what == "labelset")
  {
    long long given = 1LL << 22;
    if (const std::string bad = nextNumber(in, "labelset", 0, 1LL << 40, given); !bad.empty())
    {
      return errorJson(bad);
    }
    if (const std::string extra = extraWords(in, "labelset"); !extra.empty())
    {
      return errorJson(extra);
    }
    const size_t cap = size_t(given);
    std::vector<int64_t> labels;
    if (source.shared)
    {
      bool truncated = false;
      for (uint32_t stored : storedLabels(*source.shared, cap, truncated))
      {
        labels.push_back(originalLabel(*source.shared, stored));
      }
      std::sort(labels.begin(), labels.end());
    }
    return base64(labels.data(), labels.size() * sizeof(int64_t));
  }
  if (what == "span")
  {
    // span {"attribute": A, "filter": F, "min": lo, "max": hi} (JSON: names may hold spaces).
    std::string rest;
    std::getline(in, rest);
    const json q = json::parse(rest, nullptr, false);
    if (!q.is_object() || !q.contains("attribute") || !q.contains("filter") || !q.contains("min") ||
      !q.contains("max") || !q["attribute"].is_string() || !q["filter"].is_string() ||
      !q["min"].is_number() || !q["max"].is_number())
    {
      return json({ { "error", "span takes {\"attribute\", \"filter\", \"min\", \"max\"}" } }).dump(-1, ' ', false, json::error_handler_t::replace);
    }
    if (!source.shared)
    {
      return json({ { "error", c.sourceError } }).dump(-1, ' ', false, json::error_handler_t::replace);
    }
    return attributeSpanJson(table.get(), *source.shared, q["attribute"].get<std::string>(),
      q["filter"].get<std::string>(), q["min"].get<double>(), q["max"].get<double>());
  }
  if (what == "match")
  {
    // match SQL: the labels whose attributes make the condition true (the label selection's query).
    std::string condition;
    std::getline(in, condition);
    if (!source.shared || !table)
    {
      return json({ { "error", tableError.empty() ? std::string("no attributes") : tableError } }).dump(-1, ' ', false, json::error_handler_t::replace);
    }
    // One row per label present here (a file without a database has rows only where attribute
    // files give them) joined with the attribute table's rows and columns.
    bool truncated = false;
    std::vector<int64_t> present;
    std::map<int64_t, uint32_t> idOf; // where the volume draws ids, the answer names them
    const bool ids = drawsIds(*source.shared);
    for (uint32_t stored : storedLabels(*source.shared, size_t(1) << 22, truncated))
    {
      present.push_back(originalLabel(*source.shared, stored));
      if (ids)
      {
        idOf.emplace(present.back(), stored);
      }
    }
    csgv::Result<csgv::AttributeTable> rows = csgv::AttributeTable::fromLabels(std::move(present));
    if (!rows)
    {
      return json({ { "error", rows.message() } }).dump(-1, ' ', false, json::error_handler_t::replace);
    }
    if (csgv::Status merged = rows->merge(*table, csgv::AttributeTable::OnConflict::Replace); !merged)
    {
      return json({ { "error", merged.message() } }).dump(-1, ' ', false, json::error_handler_t::replace);
    }
    csgv::Result<std::vector<int64_t>> matched = csgv::labelsWhere(*rows, condition);
    if (!matched)
    {
      return json({ { "error", matched.message() } }).dump(-1, ' ', false, json::error_handler_t::replace);
    }
    json labels = json::array();
    std::vector<int64_t> drawn = *matched;
    if (ids)
    {
      drawn.clear();
      for (int64_t l : *matched)
      {
        if (auto it = idOf.find(l); it != idOf.end())
        {
          drawn.push_back(int64_t(it->second));
        }
      }
      std::sort(drawn.begin(), drawn.end());
    }
    // Label 0 is empty space unless the materials draw it (GUI pass 11: "voxels > 10000"
    // selected the background, and Extract selection would mesh it).
    bool zeroDrawn = false;
    if (c.materials)
    {
      const csgv::MaterialEvaluator::AttributeFn attributes = drawnAttributes(*table, *source.shared);
      const csgv::MaterialDocument shown = csgv::effectiveMaterials(*c.materials, attributes);
      const int m = csgv::MaterialEvaluator(shown, attributes).materialOf(0);
      zeroDrawn = m >= 0 && shown.materials[size_t(m)].opacity > 0.0f;
    }
    for (int64_t l : drawn)
    {
      if (l < 0 || double(l) > csgv::kMaxMaterialLabel)
      {
        continue; // beyond what a material document can name
      }
      if (l == 0 && !zeroDrawn)
      {
        continue;
      }
      if (labels.size() == csgv::kMaxOverlayLabels)
      {
        truncated = true;
        break;
      }
      labels.push_back(l);
    }
    return json({ { "labels", labels }, { "truncated", truncated } }).dump(-1, ' ', false, json::error_handler_t::replace);
  }
  if (what == "colors")
  {
    long long given = 4096;
    if (const std::string bad = nextNumber(in, "colors", 0, 1LL << 40, given); !bad.empty())
    {
      return errorJson(bad);
    }
    if (const std::string extra = extraWords(in, "colors"); !extra.empty())
    {
      return errorJson(extra);
    }
    const size_t cap = size_t(given);
    if (!source.shared)
    {
      return json({ { "error", c.sourceError } }).dump(-1, ' ', false, json::error_handler_t::replace);
    }
    if (!c.materials)
    {
      return json({ { "error", "the materials are not valid" } }).dump(-1, ' ', false, json::error_handler_t::replace);
    }
    // The labels as drawn: the visibility overlay applied, labels of transparent materials left out.
    const csgv::MaterialDocument drawn = csgv::effectiveMaterials(
      *c.materials, table ? drawnAttributes(*table, *source.shared) : csgv::MaterialEvaluator::AttributeFn());
    return labelColorsJson(drawn, table.get(), *source.shared, cap);
  }
  static const csgv::gpu::FrameOutput nothing;
  const csgv::gpu::FrameOutput& out = c.view && c.drawn
    ? c.view->output(csgv::gpu::Renderer::Color | csgv::gpu::Renderer::Depth | csgv::gpu::Renderer::GBuffer)
    : nothing;
  if (what == "labels")
  {
    // "W H base64(uint32 little-endian labels, row 0 at the bottom)" of the last render.
    std::ostringstream o;
    o << out.width << " " << out.height << " "
      << base64(out.label.data(), out.label.size() * sizeof(uint32_t));
    return o.str();
  }
  if (what == "pick")
  {
    long long x = -1, y = -1;
    std::string bad = nextNumber(in, "pick x", -(1LL << 31), (1LL << 31) - 1, x, true);
    if (bad.empty())
    {
      bad = nextNumber(in, "pick y", -(1LL << 31), (1LL << 31) - 1, y, true);
    }
    if (bad.empty())
    {
      bad = extraWords(in, "pick");
    }
    json r = { { "hit", false } };
    if (!bad.empty())
    {
      r["error"] = bad;
      return r.dump(-1, ' ', false, json::error_handler_t::replace);
    }
    if (x < 0 || y < 0 || size_t(x) >= out.width || size_t(y) >= out.height || out.label.empty())
    {
      r["error"] = c.drawn ? "no rendered pixel there" : "nothing drawn in the view's last render (its message says why)";
      return r.dump(-1, ' ', false, json::error_handler_t::replace);
    }
    const size_t i = size_t(y) * out.width + size_t(x);
    const uint32_t label = out.label[i];
    if (label == csgv::kInvalidLabel)
    {
      return r.dump(-1, ' ', false, json::error_handler_t::replace);
    }
    r["hit"] = true;
    r["label"] = label;
    // The voxel's own label: the same, but where the volume draws ids (drawsIds) their original.
    const bool ids = source.shared && drawsIds(*source.shared);
    r["original"] = ids ? originalLabelJson(*source.shared, label) : json(label);
    if (ids) // exact for readers whose JSON numbers are doubles (Qt's: the pick panel)
    {
      r["originalText"] = r["original"].dump();
    }
    const double depth = i < out.hitDepth.size() ? double(out.hitDepth[i]) : 1.0;
    r["depth"] = depth;
    // No opaque surface there: the first semi-transparent one (what the pixel shows first).
    r["translucent"] = i < out.translucent.size() && out.translucent[i] != 0;
    const csgv::Geometry& g = source.corner;
    const double nx = (double(x) + 0.5) / out.width * 2.0 - 1.0;
    const double ny = (double(y) + 0.5) / out.height * 2.0 - 1.0;
    csgv::Mat4 clipToWorld{};
    csgv::Vec3 nearP{}, hitP{};
    if (source.shared && csgv::invert(c.view->lastMatrix(), clipToWorld) &&
      unproject(clipToWorld, nx, ny, -1.0, nearP) &&
      unproject(clipToWorld, nx, ny, 2.0 * depth - 1.0, hitP))
    {
      const csgv::Vec3 dir = csgv::normalize(csgv::sub(hitP, nearP));
      if (csgv::dot(dir, dir) > 0 && i < out.distance.size() && std::isfinite(out.distance[i]) &&
        out.distance[i] > 0)
      {
        // The world distance is more precise than window depth far from the camera.
        for (int k = 0; k < 3; ++k)
        {
          hitP[size_t(k)] = nearP[size_t(k)] + dir[size_t(k)] * double(out.distance[i]);
        }
      }
      // Index coordinates: world = origin + D (idx * spacing).
      csgv::Mat4 worldToIndex{};
      const bool invertible = csgv::invert(csgv::indexToWorldMatrix(g), worldToIndex);
      const csgv::Vec3 idx = csgv::transformPoint(worldToIndex, hitP);
      const csgv::Face face = i < out.face.size() ? out.face[i] : csgv::Face::None;
      // A piece drawn as a volume of its own (MPI ranks, not placed in the volume's index space)
      // counts voxels from its own corner: the reader says where that is in the volume.
      const std::array<long, 3> pieceOffset = source.shared->owned.empty()
        ? csgvvtk::pieceOffset(c.input ? c.input->GetFieldData() : nullptr)
        : std::array<long, 3>{ { 0, 0, 0 } };
      json voxel = json::array();
      for (int k = 0; invertible && k < 3; ++k)
      {
        long v = long(std::floor(idx[size_t(k)]));
        // On the entry face the coordinate is an integer: the face says which side is the voxel.
        if (face == csgv::Face(1 + 2 * k))
        {
          v = long(std::lround(idx[size_t(k)]));
        }
        else if (face == csgv::Face(2 + 2 * k))
        {
          v = long(std::lround(idx[size_t(k)])) - 1;
        }
        const long dim = long(source.shared->volume.dim[size_t(k)]);
        voxel.push_back(std::max(0L, std::min(dim - 1, v)) + pieceOffset[size_t(k)]);
      }
      r["voxel"] = voxel;
      r["world"] = { hitP[0], hitP[1], hitP[2] };
    }
    r["attributes"] = json::parse(
      labelAttributesJson(table.get(), ids ? originalLabel(*source.shared, label) : int64_t(label)));
    if (!tableError.empty())
    {
      r["error"] = tableError;
    }
    return r.dump(-1, ' ', false, json::error_handler_t::replace);
  }
  return errorJson("unknown query '" + what.substr(0, 80) + (what.size() > 80 ? "...'" : "'"));
}

} // namespace csgvrep
