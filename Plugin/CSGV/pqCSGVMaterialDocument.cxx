// SPDX-License-Identifier: MIT
#include "pqCSGVMaterialDocument.h"

#include <pqApplicationCore.h>
#include <pqDataRepresentation.h>
#include <pqPipelineSource.h>
#include <pqServerManagerModel.h>
#include <pqUndoStack.h>
#include <pqView.h>
#include <vtkPVRenderView.h>
#include <vtkPVSession.h>
#include <vtkSMCoreUtilities.h>
#include <vtkSMSession.h>
#include <vtkSMViewProxy.h>
#include <vtkSMPVRepresentationProxy.h>
#include <vtkSMProperty.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMProxy.h>
#include <vtkSMSessionProxyManager.h>
#include <vtkSMTrace.h>
#include <vtkSMTransferFunctionManager.h>
#include <vtkSMTransferFunctionProxy.h>
#include <vtkNew.h>
#include <vtkSmartPointer.h>

#include <QJsonArray>
#include <QFileInfo>
#include <QJsonDocument>
#include <QSet>
#include <QStringList>

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

void setMaterials(vtkSMProxy* display, const QString& text)
{
  SM_SCOPED_TRACE(PropertiesModified).arg("proxy", display);
  vtkSMPropertyHelper(display, "CSGVMaterials").Set(text.toUtf8().constData());
  display->UpdateVTKObjects();
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

/// Client/server where the view renders on the client (a server that cannot render, such as
/// Debian's pvserver without a display: ParaView moves the pieces to the client): the client's
/// copy of the representation drew the volume, the server's nothing. The same rule as
/// csgv_tools._drawn_on_client (Examples/csgv_tools.py).
bool drawnOnClient(vtkSMProxy* display)
{
  vtkSMSession* session = display->GetSession();
  if (!session || !session->IsA("vtkSMSessionClient"))
    return false; // builtin: one process draws and answers
  vtkSMViewProxy* view = vtkSMViewProxy::FindView(display);
  auto* rendering = view ? vtkPVRenderView::SafeDownCast(view->GetClientSideObject()) : nullptr;
  return rendering && !rendering->GetUseDistributedRenderingForRender();
}

void renderViewsShowing(vtkSMProxy* display, pqView* also)
{
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  auto* shown = display ? model->findItem<pqDataRepresentation*>(display) : nullptr;
  pqView* view = shown ? shown->getView() : nullptr;
  if (view)
    view->render();
  if (also && also != view)
    also->render();
}

QString query(vtkSMProxy* display, const QString& request)
{
  vtkSMProxy* rep = segmentationProxy(display);
  if (!rep)
    return QString();
  vtkSMSessionProxyManager* pxm = rep->GetSessionProxyManager();
  // A question is no edit: the query proxy's state is kept off the undo stack (each query was an
  // undo step "Changed 'vtkSMProxy'" that did nothing).
  pqScopedUndoExclude keepOff;
  vtkSmartPointer<vtkSMProxy> q;
  q.TakeReference(pxm->NewProxy("misc", "CSGVQuery"));
  QString answer;
  if (q)
  {
    if (drawnOnClient(display))
      q->SetLocation(vtkPVSession::CLIENT); // asked where it was drawn
    vtkSMPropertyHelper(q, "Representation").Set(rep);
    vtkSMPropertyHelper(q, "Request").Set(request.toUtf8().constData());
    q->UpdateVTKObjects();
    q->UpdatePropertyInformation();
    const char* s = vtkSMPropertyHelper(q, "Result").GetAsString();
    answer = s ? QString::fromUtf8(s) : QString();
  }
  q = nullptr; // deleted while changes are not recorded
  return answer;
}

QJsonObject queryJson(vtkSMProxy* display, const QString& request)
{
  return QJsonDocument::fromJson(query(display, request).toUtf8()).object();
}

QString labelArrayOf(vtkSMProxy* display)
{
  const QString array = queryJson(display, "summary").value("labelArray").toString();
  return array.isEmpty() ? QString("Labels") : array;
}

vtkSMProxy* labelColorTable(vtkSMProxy* display, const QString& array, QString* message)
{
  const QJsonObject colors = queryJson(display, "colors 4096");
  if (colors.contains("error"))
  {
    if (message)
      *message = QString("No colours: %1").arg(colors.value("error").toString());
    return nullptr;
  }
  // A table of this data's own: the label array's shared table (every dataset with an array of
  // that name) stays as it is (issue 38, item 6: another dataset then raised "Could not determine
  // discrete values").
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  auto* self = model->findItem<pqDataRepresentation*>(display);
  pqPipelineSource* source = self ? self->getInput() : nullptr;
  const QString table = labelColorTableName(array, source ? source->getSMName() : QString());
  vtkNew<vtkSMTransferFunctionManager> mgr;
  vtkSMProxy* lut = mgr->GetColorTransferFunction(table.toUtf8().constData(), display->GetSessionProxyManager());
  if (!lut)
  {
    if (message)
      *message = "No lookup table";
    return nullptr;
  }
  std::vector<std::string> annotations;
  std::vector<double> rgb;
  std::vector<double> points; // x r g b per label
  bool ascending = true;      // as the query lists them: else no continuous table
  const QJsonArray labels = colors.value("labels").toArray();
  for (const QJsonValue& v : labels)
  {
    const QJsonArray e = v.toArray();
    const QString label = QString::number(qint64(e.at(0).toDouble()));
    const QString text = e.at(4).toString();
    annotations.push_back(label.toStdString());
    annotations.push_back((text.isEmpty() ? label : text).toStdString());
    ascending = ascending && (points.empty() || e.at(0).toDouble() > points[points.size() - 4]);
    points.push_back(e.at(0).toDouble());
    for (int k = 1; k <= 3; ++k)
    {
      rgb.push_back(e.at(k).toDouble());
      points.push_back(e.at(k).toDouble());
    }
  }
  // Read as a continuous map ("Interpret Values As Categories" unticked), the table gives each
  // label its material's colour too: a bar of the drawn colours over the labels, not ParaView's
  // Cool to Warm over 0..1, which described nothing drawn (found by a GUI pass).
  if (ascending && !points.empty())
  {
    // Half a label beyond the first and the last: a value exactly at the range's end took the
    // below-range colour's slot of a surface's colour texture (label 1 of a Slice drew black,
    // found by a GUI pass).
    const std::vector<double> first(points.begin(), points.begin() + 4), last(points.end() - 4, points.end());
    points.insert(points.begin(), { first[0] - kLabelMargin, first[1], first[2], first[3] });
    points.insert(points.end(), { last[0] + kLabelMargin, last[1], last[2], last[3] });
    vtkSMPropertyHelper(lut, "RGBPoints").Set(points.data(), unsigned(points.size()));
    vtkSMPropertyHelper(lut, "ColorSpace").Set(0); // RGB: between two labels, no hue of its own
    vtkSMPropertyHelper(lut, "Discretize").Set(0); // 256 bins would blend labels that share one
    // Below the first label (0, which the volume leaves empty): grey, not the first label's colour.
    const double grey[3] = { kBelowLabelsGrey, kBelowLabelsGrey, kBelowLabelsGrey };
    vtkSMPropertyHelper(lut, "BelowRangeColor").Set(grey, 3);
    vtkSMPropertyHelper(lut, "UseBelowRangeColor").Set(1);
  }
  // IndexedLookup is the proxy property; InterpretValuesAsCategories is only its Python name.
  vtkSMPropertyHelper(lut, "IndexedLookup").Set(1);
  // The labels are the categories: never rescaled from the data of whatever shows it.
  vtkSMPropertyHelper(lut, "AutomaticRescaleRangeMode").Set(vtkSMTransferFunctionManager::NEVER);
  // Values without an annotation are what the volume leaves empty: keep them empty here too.
  vtkSMPropertyHelper(lut, "NanOpacity").Set(0.0);
  vtkSMPropertyHelper ann(lut, "Annotations");
  ann.SetNumberOfElements(unsigned(annotations.size()));
  for (size_t i = 0; i < annotations.size(); ++i)
    ann.Set(unsigned(i), annotations[i].c_str());
  vtkSMPropertyHelper(lut, "IndexedColors").Set(rgb.data(), unsigned(rgb.size()));
  // The annotations are ours: ParaView must not compute them from the data (with more than 32
  // labels it cannot, and the GUI said so in a dialog each time the display was coloured).
  vtkSMPropertyHelper(lut, "AnnotationsInitialized").Set(1);
  lut->UpdateVTKObjects();
  if (message)
    *message = QString("Lookup table '%1': %2 label colours%3")
                 .arg(table)
                 .arg(labels.size())
                 .arg(colors.value("truncated").toBool() ? " (truncated)" : "");
  return lut;
}

void showLegend(vtkSMProxy* lut, const QString& array, vtkSMProxy* display, pqView* view)
{
  if (!view || !vtkSMPVRepresentationProxy::SetScalarBarVisibility(display, view->getProxy(), true))
    return;
  vtkSMProxy* bar = vtkSMTransferFunctionProxy::FindScalarBarRepresentation(lut, view->getProxy());
  if (!bar)
    return;
  // One entry per label up to kLegendLabels, else the colours alone and a title with the count.
  const int labels = int(vtkSMPropertyHelper(lut, "Annotations").GetNumberOfElements() / 2);
  const bool fits = labels <= kLegendLabels;
  vtkSMPropertyHelper(bar, "DrawAnnotations").Set(fits ? 1 : 0);
  // Short: a vertical legend writes its title along the bar, a third of the view's height (the
  // names are in View > Segmentation Pick; a GUI pass saw a longer title cut off).
  const QString title = fits ? array : QString("%1 (%2 labels)").arg(array).arg(labels);
  vtkSMPropertyHelper(bar, "Title").Set(title.toUtf8().constData());
  // Labels are integers: read as a continuous bar (categories unticked), its numbers say them
  // whole, not "1.2e+02" (GUI pass).
  vtkSMPropertyHelper(bar, "AutomaticLabelFormat").Set(0);
  vtkSMPropertyHelper(bar, "LabelFormat").Set("%.10g");
  vtkSMPropertyHelper(bar, "RangeLabelFormat").Set("%.10g");
  bar->UpdateVTKObjects();
}

void hideUnusedLegend(vtkSMProxy* lut, pqView* view)
{
  // ParaView showed the shared table's legend when the colouring was chosen; no other visible
  // display of the view maps its data through that table now: it goes.
  for (pqRepresentation* r : view->getRepresentations())
  {
    vtkSMProxy* other = r ? r->getProxy() : nullptr;
    if (r && r->isVisible() && other && other->GetProperty("LookupTable") &&
      vtkSMPropertyHelper(other, "LookupTable", true).GetAsProxy() == lut &&
      other->GetProperty("ColorArrayName"))
    {
      const char* array = vtkSMPropertyHelper(other, "ColorArrayName", true).GetInputArrayNameToProcess();
      if (array && *array)
      {
        return;
      }
    }
  }
  if (vtkSMProxy* bar = vtkSMTransferFunctionProxy::FindScalarBarRepresentation(lut, view->getProxy()))
  {
    vtkSMPropertyHelper(bar, "Visibility").Set(0);
    bar->UpdateVTKObjects();
  }
}

QString exportLabelColors(vtkSMProxy* display)
{
  QString message;
  const QString array = labelArrayOf(display);
  vtkSMProxy* lut = labelColorTable(display, array, &message);
  if (!lut)
    return message;
  // The displays of this data and of what is made from it (Slice, Threshold, ...) coloured by the
  // label array take the table and show its legend.
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  auto* self = model->findItem<pqDataRepresentation*>(display);
  QSet<pqPipelineSource*> family;
  for (QList<pqPipelineSource*> todo{ self ? self->getInput() : nullptr }; !todo.isEmpty();)
  {
    pqPipelineSource* s = todo.takeLast();
    if (s && !family.contains(s))
    {
      family.insert(s);
      todo << s->getAllConsumers();
    }
  }
  QStringList applied;
  for (pqDataRepresentation* r : model->findItems<pqDataRepresentation*>())
  {
    vtkSMProxy* proxy = r->getProxy();
    if (proxy == display || !family.contains(r->getInput()) || !proxy->GetProperty("LookupTable") ||
      !proxy->GetProperty("ColorArrayName") ||
      QString(vtkSMPropertyHelper(proxy, "ColorArrayName").GetInputArrayNameToProcess()) != array)
      continue;
    vtkSMProxy* before = vtkSMPropertyHelper(proxy, "LookupTable", true).GetAsProxy();
    vtkSMPropertyHelper(proxy, "LookupTable").Set(lut);
    proxy->UpdateVTKObjects();
    if (r->isVisible())
    {
      showLegend(lut, array, proxy, r->getView());
    }
    if (before && before != lut && r->getView())
    {
      hideUnusedLegend(before, r->getView()); // the shared table's legend stayed (GUI pass)
    }
    if (r->getView())
    {
      r->getView()->render();
    }
    applied << r->getInput()->getSMName();
  }
  return message +
    (applied.isEmpty() ? QString("; colour a Slice or Threshold of this data by '%1' and export again to use it").arg(array)
                       : QString("; applied to %1").arg(applied.join(", ")));
}

QString dataFolder(vtkSMProxy* display)
{
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  auto* self = model->findItem<pqDataRepresentation*>(display);
  pqPipelineSource* source = self ? self->getInput() : nullptr;
  vtkSMProxy* proxy = source ? source->getProxy() : nullptr;
  const char* property = proxy ? vtkSMCoreUtilities::GetFileNameProperty(proxy) : nullptr;
  if (!property)
    return QString();
  vtkSMPropertyHelper name(proxy, property);
  const QString file = name.GetNumberOfElements() > 0 ? QString::fromUtf8(name.GetAsString(0)) : QString();
  // A reader's file, or (a folder reader) the folder itself: the folder it lies in either way.
  return file.isEmpty() ? QString() : QFileInfo(file).absolutePath();
}

QString labelColorTableName(const QString& array, const QString& source)
{
  return source.isEmpty() ? QString("%1 (materials)").arg(array) : QString("%1 (%2 materials)").arg(array, source);
}

} // namespace pqCSGV
