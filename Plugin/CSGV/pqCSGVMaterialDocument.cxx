// SPDX-License-Identifier: MIT
#include "pqCSGVMaterialDocument.h"

#include <vtkSMProperty.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMProxy.h>
#include <vtkSMSessionProxyManager.h>
#include <vtkSMTransferFunctionManager.h>
#include <vtkNew.h>
#include <vtkSmartPointer.h>

#include <QJsonArray>
#include <QJsonDocument>

#include <limits>
#include <string>
#include <vector>

namespace pqCSGV
{
namespace
{

constexpr double kMaxLabel = 4294967294.0;

QJsonObject filterOf(const QJsonObject& m)
{
  QJsonObject f = m.value("filter").toObject();
  if (!f.contains("attribute"))
    f["attribute"] = "label";
  if (!f.contains("min"))
    f["min"] = 1;
  if (!f.contains("max"))
    f["max"] = kMaxLabel;
  return f;
}

QJsonObject labelFilter(double lo, double hi)
{
  return QJsonObject{ { "attribute", "label" }, { "min", lo }, { "max", hi } };
}

/// The value of the filter attribute for a label (NaN when unknown).
double valueOf(const QString& attribute, qint64 label, const QJsonObject& attributes)
{
  if (attribute == "label")
    return double(label);
  const QJsonValue v = attributes.value(attribute);
  return v.isDouble() ? v.toDouble() : std::numeric_limits<double>::quiet_NaN();
}

} // namespace

QJsonObject defaultDocument()
{
  QJsonObject m{ { "name", "all" }, { "filter", labelFilter(1, kMaxLabel) },
    { "color", QJsonObject{ { "mode", "random" } } } };
  return QJsonObject{ { "version", 1 }, { "materials", QJsonArray{ m } } };
}

QJsonObject parseDocument(const QString& text, bool* ok)
{
  if (ok)
    *ok = true;
  if (text.trimmed().isEmpty())
    return defaultDocument();
  QJsonParseError error;
  const QJsonDocument d = QJsonDocument::fromJson(text.toUtf8(), &error);
  if (error.error != QJsonParseError::NoError || !d.isObject())
  {
    if (ok)
      *ok = false;
    return defaultDocument();
  }
  QJsonObject o = d.object();
  if (!o.contains("version"))
    o["version"] = 1;
  if (!o.value("materials").isArray())
    o["materials"] = QJsonArray();
  return o;
}

QString serialize(const QJsonObject& doc)
{
  return QString::fromUtf8(QJsonDocument(doc).toJson(QJsonDocument::Compact));
}

QJsonObject newMaterial(const QString& name)
{
  return QJsonObject{ { "name", name }, { "filter", labelFilter(1, kMaxLabel) },
    { "color", QJsonObject{ { "mode", "constant" }, { "rgb", QJsonArray{ 1.0, 1.0, 1.0 } } } },
    { "opacity", 1.0 }, { "emission", 0.0 } };
}

QString hideLabel(const QString& materials, qint64 label, const QJsonObject& attributes)
{
  QJsonObject doc = parseDocument(materials);
  QJsonArray out;
  bool hiddenFirst = false;
  for (const QJsonValue& v : doc.value("materials").toArray())
  {
    const QJsonObject m = v.toObject();
    const QJsonObject f = filterOf(m);
    const double lo = f.value("min").toDouble(), hi = f.value("max").toDouble();
    const QString attribute = f.value("attribute").toString();
    const double x = valueOf(attribute, label, attributes);
    if (attribute == "label" && x >= lo && x <= hi)
    {
      // Split the interval around the label; the rest keeps its place in the order.
      const double parts[2][2] = { { lo, double(label) - 1 }, { double(label) + 1, hi } };
      for (const auto& p : parts)
      {
        if (p[0] <= p[1])
        {
          QJsonObject c = m;
          c["filter"] = labelFilter(p[0], p[1]);
          out.append(c);
        }
      }
      continue;
    }
    if (attribute != "label" && !(x < lo || x > hi))
    {
      hiddenFirst = true; // the label may be taken here (or its value is unknown)
    }
    out.append(m);
  }
  if (hiddenFirst)
  {
    out.prepend(QJsonObject{ { "name", QString("hidden %1").arg(label) },
      { "filter", labelFilter(double(label), double(label)) },
      { "color", QJsonObject{ { "mode", "constant" }, { "rgb", QJsonArray{ 0, 0, 0 } } } },
      { "opacity", 0.0 } });
  }
  doc["materials"] = out;
  return serialize(doc);
}

QString showOnlyLabel(const QString& materials, qint64 label, const QJsonObject& attributes)
{
  QJsonObject doc = parseDocument(materials);
  for (const QJsonValue& v : doc.value("materials").toArray())
  {
    QJsonObject m = v.toObject();
    const QJsonObject f = filterOf(m);
    const double x = valueOf(f.value("attribute").toString(), label, attributes);
    if (x >= f.value("min").toDouble() && x <= f.value("max").toDouble())
    {
      m["filter"] = labelFilter(double(label), double(label));
      doc["materials"] = QJsonArray{ m };
      return serialize(doc);
    }
  }
  QJsonObject m = newMaterial(QString("label %1").arg(label));
  m["filter"] = labelFilter(double(label), double(label));
  m["color"] = QJsonObject{ { "mode", "random" } };
  doc["materials"] = QJsonArray{ m };
  return serialize(doc);
}

vtkSMProxy* segmentationProxy(vtkSMProxy* display)
{
  if (!display)
    return nullptr;
  // The composite representation exposes its subproxy's own property objects.
  vtkSMProperty* p = display->GetProperty("CSGVMaterials");
  return p ? p->GetParent() : nullptr;
}

QString query(vtkSMProxy* display, const QString& request)
{
  vtkSMProxy* rep = segmentationProxy(display);
  if (!rep)
    return QString();
  vtkSMSessionProxyManager* pxm = rep->GetSessionProxyManager();
  vtkSmartPointer<vtkSMProxy> q;
  q.TakeReference(pxm->NewProxy("misc", "CSGVQuery"));
  if (!q)
    return QString();
  vtkSMPropertyHelper(q, "Representation").Set(rep);
  vtkSMPropertyHelper(q, "Request").Set(request.toUtf8().constData());
  q->UpdateVTKObjects();
  q->UpdatePropertyInformation();
  const char* s = vtkSMPropertyHelper(q, "Result").GetAsString();
  return s ? QString::fromUtf8(s) : QString();
}

QJsonObject queryJson(vtkSMProxy* display, const QString& request)
{
  return QJsonDocument::fromJson(query(display, request).toUtf8()).object();
}

QString exportLabelColors(vtkSMProxy* display)
{
  const QJsonObject colors = queryJson(display, "colors 4096");
  if (colors.contains("error"))
    return QString("No colours: %1").arg(colors.value("error").toString());
  QString array = queryJson(display, "summary").value("labelArray").toString();
  if (array.isEmpty())
    array = "Labels";
  vtkSMSessionProxyManager* pxm = display->GetSessionProxyManager();
  vtkNew<vtkSMTransferFunctionManager> mgr;
  vtkSMProxy* lut = mgr->GetColorTransferFunction(array.toUtf8().constData(), pxm);
  if (!lut)
    return "No lookup table";
  std::vector<std::string> annotations;
  std::vector<double> rgb;
  const QJsonArray labels = colors.value("labels").toArray();
  for (const QJsonValue& v : labels)
  {
    const QJsonArray e = v.toArray();
    const QString label = QString::number(qint64(e.at(0).toDouble()));
    const QString text = e.at(4).toString();
    annotations.push_back(label.toStdString());
    annotations.push_back((text.isEmpty() ? label : text).toStdString());
    for (int k = 1; k <= 3; ++k)
      rgb.push_back(e.at(k).toDouble());
  }
  vtkSMPropertyHelper(lut, "InterpretValuesAsCategories").Set(1);
  vtkSMPropertyHelper ann(lut, "Annotations");
  ann.SetNumberOfElements(unsigned(annotations.size()));
  for (size_t i = 0; i < annotations.size(); ++i)
    ann.Set(unsigned(i), annotations[i].c_str());
  vtkSMPropertyHelper(lut, "IndexedColors").Set(rgb.data(), unsigned(rgb.size()));
  lut->UpdateVTKObjects();
  return QString("Lookup table '%1': %2 label colours%3")
    .arg(array)
    .arg(labels.size())
    .arg(colors.value("truncated").toBool() ? " (truncated)" : "");
}

} // namespace pqCSGV
