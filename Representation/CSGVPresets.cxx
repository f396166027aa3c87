// SPDX-License-Identifier: MIT
#include "CSGVPresets.h"

#include <vtkColorTransferFunction.h>
#include <vtkNew.h>
#include <vtkSMTransferFunctionPresets.h>

#include <nlohmann/json.hpp>

#include <algorithm>

namespace csgvrep
{
namespace
{

using nlohmann::json;


/// Control points of a ParaView preset, sampled at 1024 positions over [0, 1]; false when
/// ParaView has no preset of that name (or it holds no colours).
bool presetPoints(const std::string& name, json& points)
{
  vtkSMTransferFunctionPresets* presets = vtkSMTransferFunctionPresets::GetInstance();
  if (!presets)
  {
    return false;
  }
  int index = -1;
  presets->GetFirstPresetWithName(name.c_str(), index);
  if (index < 0)
  {
    return false;
  }
  json preset = json::parse(presets->GetPresetAsString(unsigned(index)), nullptr, false);
  if (preset.is_discarded() || !preset.is_object())
  {
    return false;
  }
  vtkNew<vtkColorTransferFunction> ctf;
  const std::string space = preset.value("ColorSpace", std::string("RGB"));
  if (space == "HSV")
    ctf->SetColorSpaceToHSV();
  else if (space == "Lab")
    ctf->SetColorSpaceToLab();
  else if (space == "Lab/CIEDE2000")
    ctf->SetColorSpaceToLabCIEDE2000();
  else if (space == "Diverging")
    ctf->SetColorSpaceToDiverging();
  else if (space == "Step")
    ctf->SetColorSpaceToStep();
  else
    ctf->SetColorSpaceToRGB();
  double lo = 0, hi = 1;
  if (preset.contains("RGBPoints") && preset["RGBPoints"].is_array() && preset["RGBPoints"].size() >= 8)
  {
    const json& p = preset["RGBPoints"];
    lo = p[0].get<double>();
    hi = p[p.size() - 4].get<double>();
    for (size_t i = 0; i + 3 < p.size(); i += 4)
    {
      ctf->AddRGBPoint(p[i].get<double>(), p[i + 1].get<double>(), p[i + 2].get<double>(),
        p[i + 3].get<double>());
    }
  }
  else if (preset.contains("IndexedColors") && preset["IndexedColors"].is_array() &&
    preset["IndexedColors"].size() >= 3)
  {
    // Categorical preset: equal steps of each colour.
    const json& c = preset["IndexedColors"];
    const size_t n = c.size() / 3;
    ctf->SetColorSpaceToStep();
    for (size_t i = 0; i < n; ++i)
    {
      ctf->AddRGBPoint(double(i) / double(n), c[3 * i].get<double>(), c[3 * i + 1].get<double>(),
        c[3 * i + 2].get<double>());
    }
    lo = 0;
    hi = double(n - 1) / double(n);
  }
  else
  {
    return false;
  }
  if (!(hi > lo))
  {
    hi = lo + 1;
  }
  points = json::array();
  const int samples = 1024;
  for (int i = 0; i < samples; ++i)
  {
    const double x = double(i) / (samples - 1);
    double rgb[3];
    ctf->GetColor(lo + x * (hi - lo), rgb);
    points.push_back({ x, std::clamp(rgb[0], 0.0, 1.0), std::clamp(rgb[1], 0.0, 1.0),
      std::clamp(rgb[2], 0.0, 1.0) });
  }
  return true;
}

} // namespace

std::string resolveMaterials(const std::string& text, csgv::MaterialDocument& out)
{
  std::string toParse = text;
  json doc = json::parse(text, nullptr, false);
  if (!doc.is_discarded() && doc.is_object() && doc.contains("materials") && doc["materials"].is_array())
  {
    bool replaced = false;
    for (json& m : doc["materials"])
    {
      if (!m.is_object() || !m.contains("color") || !m["color"].is_object())
      {
        continue;
      }
      json& color = m["color"];
      if (color.contains("colormap") && color["colormap"].is_string())
      {
        json points;
        if (presetPoints(color["colormap"].get<std::string>(), points))
        {
          color["colormap"] = points;
          replaced = true;
        }
      }
    }
    if (replaced)
    {
      toParse = doc.dump(-1, ' ', false, json::error_handler_t::replace);
    }
  }
  csgv::Result<csgv::MaterialDocument> parsed = csgv::parseMaterialsOrDefault(toParse);
  if (!parsed)
  {
    return parsed.message();
  }
  csgv::Status s = csgv::resolveColormapNames(*parsed);
  if (!s)
  {
    return s.message();
  }
  out = std::move(*parsed);
  return std::string();
}

} // namespace csgvrep
