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

#include <string>
#include <vector>

namespace pqCSGV
{
csgv::MaterialDocument parseDocument(const QString& text, QString* error)
{
  csgv::Result<csgv::MaterialDocument> doc = csgv::parseMaterialsOrDefault(text.toStdString());
  if (error)
  {
    *error = doc.isOk() ? QString() : QString::fromStdString(doc.message());
  }
  return doc.isOk() ? *doc : csgv::defaultMaterials();
}

QString serialize(const csgv::MaterialDocument& doc)
{
  return QString::fromStdString(csgv::serializeMaterials(doc, -1));
}

QString editLabelVisibility(
  const QString& materials, LabelVisibility edit, qint64 label, QString* error)
{
  QString why;
  csgv::MaterialDocument doc = parseDocument(materials, &why);
  if (error)
  {
    *error = why;
  }
  if (!why.isEmpty())
  {
    return QString(); // never replace the user's text by the default document
  }
  switch (edit)
  {
    case LabelVisibility::Hide:
      csgv::hideLabelOver(doc, uint32_t(label));
      break;
    case LabelVisibility::ShowOnly:
      csgv::showOnlyLabelOver(doc, uint32_t(label));
      break;
    case LabelVisibility::ShowAll:
      csgv::showAllLabels(doc);
      break;
  }
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
  // IndexedLookup is the proxy property; InterpretValuesAsCategories is only its Python name.
  vtkSMPropertyHelper(lut, "IndexedLookup").Set(1);
  // Values without an annotation are what the volume leaves empty: keep them empty here too.
  vtkSMPropertyHelper(lut, "NanOpacity").Set(0.0);
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
