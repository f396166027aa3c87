// SPDX-License-Identifier: MIT
#include "CSGVAttributes.h"

#include "CSGVAdapter.h" // the readers' FieldData contract (CSGV::Readers)

#include <vtkDataArray.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkStringArray.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <sstream>
#include <cctype>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <set>

namespace csgvrep
{
namespace
{

using nlohmann::json;

/// The table of the input's `CSGVAttribute:*` arrays (indexed by stored id), keyed by label.
std::string fieldDataTable(vtkImageData* image, const SharedVolume& volume, csgv::AttributeTable& out)
{
  vtkFieldData* fd = image ? image->GetFieldData() : nullptr;
  if (!fd)
  {
    return std::string();
  }
  const size_t prefix = std::strlen(csgvvtk::kAttributePrefix);
  std::vector<vtkAbstractArray*> arrays;
  for (int i = 0; i < fd->GetNumberOfArrays(); ++i)
  {
    vtkAbstractArray* a = fd->GetAbstractArray(i);
    if (a && a->GetName() && std::strncmp(a->GetName(), csgvvtk::kAttributePrefix, prefix) == 0 &&
      a->GetNumberOfComponents() == 1)
    {
      arrays.push_back(a);
    }
  }
  if (arrays.empty())
  {
    return std::string();
  }
  // Ids of the stored volume: its label map, else the labels themselves.
  size_t ids = size_t(arrays[0]->GetNumberOfTuples());
  std::vector<int64_t> labels(ids);
  for (size_t i = 0; i < ids; ++i)
  {
    labels[i] = i < volume.idToLabel.size() ? volume.idToLabel[i] : int64_t(i);
  }
  csgv::Result<csgv::AttributeTable> t = csgv::AttributeTable::fromLabels(labels);
  if (!t)
  {
    return "attribute database: " + t.message();
  }
  csgv::AttributeTable table = std::move(*t);
  for (vtkAbstractArray* a : arrays)
  {
    if (size_t(a->GetNumberOfTuples()) != ids)
    {
      continue; // not of this volume's ids
    }
    csgv::AttributeColumn c;
    c.name = a->GetName() + prefix;
    if (c.name == "label" || table.hasColumn(c.name))
    {
      continue;
    }
    const size_t rows = table.rowCount();
    if (auto* s = vtkStringArray::SafeDownCast(a))
    {
      c.numeric = false;
      c.text.assign(rows, std::string());
      for (size_t i = 0; i < ids; ++i)
      {
        c.text[size_t(table.rowOf(labels[i]))] = s->GetValue(vtkIdType(i));
      }
    }
    else if (auto* d = vtkDataArray::SafeDownCast(a))
    {
      c.values.assign(rows, std::numeric_limits<double>::quiet_NaN());
      for (size_t i = 0; i < ids; ++i)
      {
        c.values[size_t(table.rowOf(labels[i]))] = d->GetComponent(vtkIdType(i), 0);
      }
    }
    else
    {
      continue;
    }
    csgv::Status s = table.addColumn(std::move(c));
    if (!s)
    {
      return "attribute database: " + s.message();
    }
  }
  out = std::move(table);
  return std::string();
}

} // namespace

csgv::Result<csgv::AttributeSums> ownedAttributeSums(
  const SharedVolume& volume, const csgv::ComputeAttributesOptions& options)
{
  csgv::Result<csgv::CompressedVolume> piece = csgv::extractPiece(volume.volume, volume.owned);
  if (!piece)
  {
    return piece.status();
  }
  const uint32_t b = volume.volume.brickSize;
  return csgv::computeAttributeSums(*piece, options,
    { volume.owned.lo[0] * b, volume.owned.lo[1] * b, volume.owned.lo[2] * b }, volume.volume.dim);
}

namespace
{

/// Computed attributes of the voxels this process holds: the volume, or an MPI rank's own bricks
/// (until the ranks' sums replace them: CSGVPieceAttributes).
csgv::Result<csgv::AttributeTable> computedOfOwned(
  const SharedVolume& volume, const csgv::ComputeAttributesOptions& options)
{
  if (volume.owned.empty())
  {
    return csgv::computeAttributes(volume.volume, options);
  }
  csgv::Result<csgv::AttributeSums> sums = ownedAttributeSums(volume, options);
  if (!sums)
  {
    return sums.status();
  }
  return csgv::attributeTable(*sums, options);
}

/// The attribute table of the configuration. Returns what makes the table unusable (its FieldData
/// columns unreadable); `problems` gets each source that could not be added (a file that does not
/// read, a computation or derived attribute that fails), which is left out while the others stay:
/// materials naming a left-out column are skipped with that reason, the rest draw.
std::string buildTable(vtkImageData* image, const VolumeSource& source, const AttributeConfig& config,
  csgv::AttributeTable& table, std::string& problems)
{
  SharedVolume& volume = *source.shared;
  std::string error = fieldDataTable(image, volume, table);
  if (!error.empty())
  {
    return error;
  }
  auto problem = [&](const std::string& text) { problems += (problems.empty() ? "" : "; ") + text; };
  csgv::Status s;
  // A label table the reader found beside the input (an atlas's `.nii.txt`): read before the
  // user's files, which replace its columns. Not the user's file: one that does not read as a
  // table (a `.txt` of something else) is left out without a word.
  const std::string sidecar = csgvvtk::attributeSidecar(image ? image->GetFieldData() : nullptr);
  if (!sidecar.empty() && std::find(config.files.begin(), config.files.end(), sidecar) == config.files.end())
  {
    csgv::Result<csgv::AttributeTable> t = csgv::readAttributeFile(sidecar);
    csgv::AttributeTable merged = table;
    if (t && merged.merge(*t, csgv::AttributeTable::OnConflict::Keep))
    {
      table = std::move(merged);
    }
  }
  std::set<std::string> read; // one file named several times is read (and its error said) once
  for (const std::string& path : config.files)
  {
    if (path.empty() || !read.insert(path).second)
    {
      continue;
    }
    csgv::Result<csgv::AttributeTable> t = csgv::readAttributeFile(path);
    if (!t)
    {
      problem(t.message());
    }
    else if (!(s = table.merge(*t, csgv::AttributeTable::OnConflict::Replace)))
    {
      problem(path + ": " + s.message());
    }
  }
  if (config.computed)
  {
    std::shared_ptr<const csgv::AttributeTable> computed;
    {
      std::lock_guard<std::mutex> lock(volumeMutex());
      computed = volume.computed;
    }
    if (!computed)
    {
      csgv::ComputeAttributesOptions options;
      if (!volume.idToLabel.empty())
      {
        options.idToLabel = &volume.idToLabel;
      }
      csgv::Result<csgv::AttributeTable> t = computedOfOwned(volume, options);
      if (t)
      {
        computed = std::make_shared<const csgv::AttributeTable>(std::move(*t));
        std::lock_guard<std::mutex> lock(volumeMutex());
        volume.computed = computed;
      }
      else
      {
        problem("computing attributes: " + t.message());
      }
    }
    if (computed && !(s = table.merge(*computed, csgv::AttributeTable::OnConflict::Replace)))
    {
      problem("computed attributes: " + s.message());
    }
  }
  // One budget for all derived attributes together, not one each: the whole table is built on
  // the rendering process's thread, and a GUI waits for it (found by an attack pass: four slow
  // expressions froze the first render for 40 s).
  const csgv::DerivedBudget whole;
  const auto derivedStart = std::chrono::steady_clock::now();
  for (const auto& d : config.derived)
  {
    if (d.first.empty() && d.second.empty())
    {
      continue; // an empty row (the editor's new one)
    }
    csgv::DerivedBudget budget = whole;
    budget.seconds = whole.seconds -
      std::chrono::duration<double>(std::chrono::steady_clock::now() - derivedStart).count();
    if (budget.seconds <= 0)
    {
      problem("derived attribute '" + d.first + "' was not evaluated: the derived attributes together " +
        "took their " + std::to_string(int(whole.seconds)) + " s");
      continue;
    }
    // Core names the attribute (or says it needs a name) in its message.
    if (!(s = csgv::addDerivedAttribute(table, d.first, d.second, true, budget)))
    {
      problem(s.message());
    }
  }
  return std::string();
}

/// What buildTable reads of the input's field data: its attribute arrays (name, object and
/// modification time) and the sidecar's name. Not the field data's own time, which other arrays
/// change: a query right after a render built the whole table again (found by an attack pass: a
/// slow derived attribute cost the render its time, then the first query the same again).
std::string fieldSignature(vtkImageData* image)
{
  vtkFieldData* fd = image ? image->GetFieldData() : nullptr;
  if (!fd)
  {
    return std::string();
  }
  std::ostringstream o;
  const size_t prefix = std::strlen(csgvvtk::kAttributePrefix);
  for (int i = 0; i < fd->GetNumberOfArrays(); ++i)
  {
    vtkAbstractArray* a = fd->GetAbstractArray(i);
    if (a && a->GetName() && std::strncmp(a->GetName(), csgvvtk::kAttributePrefix, prefix) == 0)
    {
      o << a->GetName() << '\n' << static_cast<const void*>(a) << ' ' << a->GetMTime() << '\n';
    }
  }
  o << csgvvtk::attributeSidecar(fd);
  return o.str();
}

json numberOrNull(double v)
{
  return std::isfinite(v) ? json(v) : json(nullptr);
}

/// The text column shown as a label's name: `name` when it exists, else the first text column.
const csgv::AttributeColumn* nameColumn(const csgv::AttributeTable* table)
{
  if (!table)
  {
    return nullptr;
  }
  if (const csgv::AttributeColumn* c = table->column("name"))
  {
    if (!c->numeric)
    {
      return c;
    }
  }
  for (const csgv::AttributeColumn& c : table->columns())
  {
    if (!c.numeric)
    {
      return &c;
    }
  }
  return nullptr;
}

} // namespace

std::shared_ptr<const csgv::AttributeTable> AttributeCache::get(
  vtkImageData* image, const VolumeSource& source, const AttributeConfig& config, std::string& error)
{
  error.clear();
  if (!source.shared)
  {
    error = "no input";
    return nullptr;
  }
  const std::string fieldTime = fieldSignature(image);
  const void* computed = nullptr;
  {
    std::lock_guard<std::mutex> lock(volumeMutex());
    computed = source.shared->computed.get();
  }
  if (this->Valid && this->Volume == source.shared.get() && this->FieldTime == fieldTime &&
    this->Config == config && (!config.computed || this->Computed == computed))
  {
    error = this->Error;
    return this->Table;
  }
  auto table = std::make_shared<csgv::AttributeTable>();
  std::string problems;
  this->Error = buildTable(image, source, config, *table, problems);
  this->Table = this->Error.empty() ? std::shared_ptr<const csgv::AttributeTable>(table) : nullptr;
  if (this->Error.empty())
  {
    this->Error = problems; // said, with the table of what could be added
  }
  this->Volume = source.shared.get();
  {
    std::lock_guard<std::mutex> lock(volumeMutex());
    this->Computed = source.shared->computed.get();
  }
  this->FieldTime = fieldTime;
  this->Config = config;
  this->Valid = true;
  error = this->Error;
  return this->Table;
}

std::vector<uint32_t> storedLabels(const SharedVolume& shared, size_t cap, bool& truncated)
{
  truncated = false;
  // The palette summary lists them when the reader or an upload made it (a whole volume's).
  if (const auto palettes = std::atomic_load(&shared.palettes); palettes && palettes->labelsComplete && shared.owned.empty())
  {
    truncated = palettes->labels.size() > cap;
    return std::vector<uint32_t>(
      palettes->labels.begin(), palettes->labels.begin() + std::ptrdiff_t(std::min(cap, palettes->labels.size())));
  }
  std::shared_ptr<const std::pair<std::vector<uint32_t>, bool>> own = std::atomic_load(&shared.ownLabels);
  if (!own)
  {
    constexpr size_t kMost = size_t(1) << 26;
    std::vector<uint32_t> seen;
    bool more = false;
    // Every palette entry, sorted and made unique whenever the list doubles (bounded by twice
    // the distinct labels plus a brick's palette).
    size_t distinct = 0;
    const auto compact = [&]() {
      std::sort(seen.begin(), seen.end());
      seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
      if (seen.size() > kMost)
      {
        more = true;
        seen.resize(kMost);
      }
      distinct = seen.size();
    };
    const csgv::CompressedVolume& volume = shared.volume;
    const uint32_t L = volume.levels();
    const std::array<uint32_t, 3> grid = volume.brickGrid();
    for (uint64_t b = 0; b < volume.brickCount(); ++b)
    {
      if (!shared.owned.empty() &&
        !shared.owned.contains(uint32_t(b % grid[0]), uint32_t(b / grid[0] % grid[1]), uint32_t(b / grid[0] / grid[1])))
      {
        continue; // absent: another rank's brick
      }
      if (!csgv::brickSound(volume, b))
      {
        continue; // a bad brick (checkBrick): drawn empty
      }
      const csgv::BrickWords bw = volume.brick(b);
      for (uint32_t k = 0; k < bw.words[L]; ++k)
      {
        seen.push_back(bw.words[bw.size - 1 - k]);
      }
      if (seen.size() > 2 * distinct + (size_t(1) << 20))
      {
        compact();
      }
    }
    compact();
    own = std::make_shared<const std::pair<std::vector<uint32_t>, bool>>(std::move(seen), more);
    std::atomic_store(&shared.ownLabels, own);
  }
  truncated = own->second || own->first.size() > cap;
  return std::vector<uint32_t>(own->first.begin(), own->first.begin() + std::ptrdiff_t(std::min(cap, own->first.size())));
}

int64_t originalLabel(const SharedVolume& volume, uint32_t stored)
{
  return stored < volume.idToLabel.size() ? volume.idToLabel[stored] : int64_t(stored);
}

bool drawsIds(const SharedVolume& volume)
{
  return !volume.idToLabel.empty() && volume.storedToOriginal.empty();
}

int64_t drawnLabel(const SharedVolume& volume, uint32_t stored)
{
  return drawsIds(volume) ? int64_t(stored) : originalLabel(volume, stored);
}

json originalLabelJson(const SharedVolume& volume, uint32_t stored)
{
  const int64_t label = originalLabel(volume, stored);
  return volume.originalsUnsigned && stored < volume.idToLabel.size() ? json(uint64_t(label)) : json(label);
}

csgv::MaterialEvaluator::AttributeFn drawnAttributes(const csgv::AttributeTable& table, const SharedVolume& volume)
{
  if (!drawsIds(volume))
  {
    return table.attributeFunction();
  }
  return [&table, &volume](const std::string& name, uint32_t id)
  { return name == "label" ? double(id) : table.value(name, originalLabel(volume, id)); };
}

std::string denseColumns(const csgv::AttributeTable& table, const SharedVolume& volume,
  const std::vector<std::string>& names, std::map<std::string, std::vector<float>>& out)
{
  out.clear();
  uint64_t labelCount = 0;
  for (const std::string& n : names)
  {
    if (n == "label")
    {
      continue;
    }
    if (!table.hasColumn(n))
    {
      std::string available = "label";
      for (const std::string& c : table.columnNames())
      {
        if (c != "label")
        {
          available += ", " + c;
        }
      }
      return "the materials name attribute '" + n + "', which the volume does not have (attributes: " +
        available + ")";
    }
    csgv::Result<std::vector<float>> v = std::vector<float>();
    if (!volume.idToLabel.empty())
    {
      v = table.denseFloatColumnForIds(n, volume.idToLabel);
    }
    else
    {
      if (labelCount == 0)
      {
        bool truncated = false;
        const std::vector<uint32_t> labels = storedLabels(volume, size_t(1) << 26, truncated);
        labelCount = labels.empty() ? 1 : uint64_t(labels.back()) + 1;
        if (labelCount > (uint64_t(1) << 26))
        {
          return "labels go up to " + std::to_string(labelCount - 1) +
            ": too large to index attribute arrays (relabel the volume)";
        }
      }
      v = table.denseFloatColumn(n, labelCount);
    }
    if (!v)
    {
      return "attribute '" + n + "': " + v.message();
    }
    out[n] = std::move(*v);
  }
  return std::string();
}

std::string attributeSummary(const csgv::AttributeTable* table, const SharedVolume* volume,
  const std::string& labelArray, const std::string& error)
{
  json doc;
  json attrs = json::array();
  double lo = std::numeric_limits<double>::quiet_NaN(), hi = lo;
  size_t count = 0;
  if (volume)
  {
    bool truncated = false;
    for (uint32_t s : storedLabels(*volume, size_t(1) << 22, truncated))
    {
      const double l = double(originalLabel(*volume, s));
      lo = std::isnan(lo) ? l : std::min(lo, l);
      hi = std::isnan(hi) ? l : std::max(hi, l);
      ++count;
    }
  }
  attrs.push_back({ { "name", "label" }, { "numeric", true }, { "min", numberOrNull(lo) },
    { "max", numberOrNull(hi) } });
  if (table)
  {
    for (const csgv::AttributeColumn& c : table->columns())
    {
      if (c.name == "label")
      {
        continue;
      }
      json a = { { "name", c.name }, { "numeric", c.numeric } };
      if (c.numeric)
      {
        csgv::Result<std::array<double, 2>> r = table->range(c.name);
        a["min"] = r ? numberOrNull((*r)[0]) : json(nullptr);
        a["max"] = r ? numberOrNull((*r)[1]) : json(nullptr);
      }
      attrs.push_back(a);
    }
  }
  doc["attributes"] = attrs;
  doc["labels"] = count;
  doc["labelArray"] = labelArray;
  doc["error"] = error;
  return doc.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string labelAttributesJson(const csgv::AttributeTable* table, int64_t label)
{
  json o = json::object();
  if (table)
  {
    for (const csgv::AttributeColumn& c : table->columns())
    {
      if (c.name == "label")
      {
        continue;
      }
      if (c.numeric)
      {
        o[c.name] = numberOrNull(table->value(c.name, label));
      }
      else
      {
        o[c.name] = table->text(c.name, label);
      }
    }
  }
  return o.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string labelColorsJson(const csgv::MaterialDocument& doc, const csgv::AttributeTable* table,
  const SharedVolume& volume, size_t cap)
{
  csgv::AttributeTable empty;
  const csgv::AttributeTable& t = table ? *table : empty;
  csgv::MaterialEvaluator evaluator(doc, drawnAttributes(t, volume));
  const csgv::AttributeColumn* names = nameColumn(table);
  bool truncated = false;
  json labels = json::array();
  for (uint32_t s : storedLabels(volume, cap, truncated))
  {
    // Materials take the drawn label (an id where the volume draws ids); the list names the
    // original, as the label array that a lookup table colours holds it.
    const int64_t drawn = drawnLabel(volume, s);
    if (drawn < 0 || drawn > int64_t(0xFFFFFFFEll))
    {
      continue;
    }
    const int m = evaluator.materialOf(uint32_t(drawn));
    if (m < 0 || doc.materials[size_t(m)].opacity <= 0.0f) // not drawn
    {
      continue;
    }
    const std::array<float, 3> c = evaluator.colorOf(uint32_t(drawn), m);
    const int64_t label = originalLabel(volume, s);
    labels.push_back({ originalLabelJson(volume, s), c[0], c[1], c[2], names ? t.text(names->name, label) : std::string() });
  }
  // Ascending original labels (stored ids of a relabelled volume follow another order).
  std::sort(labels.begin(), labels.end(),
    [](const json& a, const json& b) { return a[0].get<int64_t>() < b[0].get<int64_t>(); });
  json o = { { "labels", labels }, { "truncated", truncated },
    { "text", names ? names->name : std::string() } };
  return o.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string attributeSpanJson(const csgv::AttributeTable* table, const SharedVolume& volume,
  const std::string& attribute, const std::string& filter, double lo, double hi)
{
  csgv::AttributeTable empty;
  const csgv::AttributeTable& t = table ? *table : empty;
  const csgv::MaterialEvaluator::AttributeFn value = drawnAttributes(t, volume);
  auto of = [&](const std::string& name, int64_t label)
  { return name == "label" ? double(label) : value(name, uint32_t(label)); };
  double min = std::numeric_limits<double>::quiet_NaN(), max = min;
  size_t count = 0;
  bool truncated = false;
  for (uint32_t s : storedLabels(volume, size_t(1) << 22, truncated))
  {
    const int64_t label = drawnLabel(volume, s);
    if (label < 0 || label > int64_t(0xFFFFFFFEll))
    {
      continue;
    }
    const double f = of(filter, label);
    if (!(f >= lo && f <= hi))
    {
      continue;
    }
    const double v = of(attribute, label);
    if (std::isnan(v))
    {
      continue;
    }
    min = std::isnan(min) ? v : std::min(min, v);
    max = std::isnan(max) ? v : std::max(max, v);
    ++count;
  }
  return json({ { "min", numberOrNull(min) }, { "max", numberOrNull(max) }, { "labels", count } })
    .dump(-1, ' ', false, json::error_handler_t::replace);
}

} // namespace csgvrep
