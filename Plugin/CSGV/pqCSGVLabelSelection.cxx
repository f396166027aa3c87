// SPDX-License-Identifier: MIT
#include "pqCSGVLabelSelection.h"

#include "pqCSGVMaterialDocument.h"

#include <pqActiveObjects.h>
#include <pqApplicationCore.h>
#include <pqDataRepresentation.h>
#include <pqOutputPort.h>
#include <pqPVApplicationCore.h>
#include <pqPipelineFilter.h>
#include <pqRenderView.h>
#include <pqSelectionManager.h>
#include <pqServerManagerModel.h>
#include <pqUndoStack.h>
#include <pqView.h>
#include <vtkAbstractArray.h>
#include <vtkAlgorithm.h>
#include <vtkCommand.h>
#include <vtkPVRenderView.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMProxy.h>
#include <vtkSMRenderViewProxy.h>
#include <vtkSMSelectionHelper.h>
#include <vtkSMSessionProxyManager.h>
#include <vtkSMSourceProxy.h>
#include <vtkSelectionNode.h>
#include <vtkSmartPointer.h>
#include <vtkTable.h>

#include <QByteArray>
#include <QPointer>
#include <QStringList>
#include <QTimer>

#include <algorithm>
#include <memory>
#include <array>
#include <cstring>

namespace
{
pqCSGVLabelSelection* Instance = nullptr;

/// A selection is held in the material property's text and drawn as one material per run of
/// labels: larger ones are refused (the document's own bound, csgv::kMaxOverlayLabels).
constexpr size_t kMaxSelectedLabels = csgv::kMaxOverlayLabels;

/// The pipeline output a display shows.
pqOutputPort* inputOf(vtkSMProxy* display)
{
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  auto* r = model->findItem<pqDataRepresentation*>(display);
  return r ? r->getOutputPortFromInput() : nullptr;
}


bool isLabelTable(pqPipelineSource* source)
{
  const char* name = source ? source->getProxy()->GetXMLName() : nullptr;
  return name && std::strcmp(name, "CSGVLabelTable") == 0;
}

/// The columns "label" and (when the table has it) "csgv_id" of a table output, fetched to the
/// client as servermanager.Fetch does:
/// ParaView's ReductionFilter (rank 0's table, where the label table is made) on the server, then
/// ClientServerMoveData to the client (the reduction's own client-side copy is empty in
/// client/server mode).
std::vector<int64_t> fetchLabels(vtkSMSourceProxy* source, unsigned int port, std::vector<int64_t>* ids = nullptr)
{
  pqScopedUndoExclude keepOff; // helper proxies (fetching rows) are no edits
  std::vector<int64_t> out;
  vtkSMSessionProxyManager* pxm = source->GetSessionProxyManager();
  vtkSmartPointer<vtkSMSourceProxy> reduce, move;
  reduce.TakeReference(vtkSMSourceProxy::SafeDownCast(pxm->NewProxy("filters", "ReductionFilter")));
  move.TakeReference(vtkSMSourceProxy::SafeDownCast(pxm->NewProxy("filters", "ClientServerMoveData")));
  if (!reduce || !move)
    return out;
  vtkSMPropertyHelper(reduce, "Input").Set(source, port);
  vtkSMPropertyHelper(reduce, "PassThrough").Set(0);
  reduce->UpdateVTKObjects();
  reduce->UpdatePipeline();
  vtkSMPropertyHelper(move, "Input").Set(reduce, 0);
  vtkSMPropertyHelper(move, "OutputDataType").Set(VTK_TABLE);
  move->UpdateVTKObjects();
  move->UpdatePipeline();
  auto* algorithm = vtkAlgorithm::SafeDownCast(move->GetClientSideObject());
  vtkTable* table = vtkTable::SafeDownCast(algorithm ? algorithm->GetOutputDataObject(0) : nullptr);
  vtkAbstractArray* labels = table ? table->GetColumnByName("label") : nullptr;
  if (!labels)
    return out;
  out.reserve(size_t(labels->GetNumberOfTuples()));
  for (vtkIdType i = 0; i < labels->GetNumberOfTuples(); ++i)
    out.push_back(labels->GetVariantValue(i).ToTypeInt64());
  vtkAbstractArray* column = ids ? table->GetColumnByName("csgv_id") : nullptr;
  if (column && column->GetNumberOfTuples() == labels->GetNumberOfTuples())
  {
    for (vtkIdType i = 0; i < column->GetNumberOfTuples(); ++i)
      ids->push_back(column->GetVariantValue(i).ToTypeInt64());
  }
  return out;
}

/// Whether a volume with these labels is drawn by ids (csgvrep::drawsIds: a label does not fit
/// the 32 bits a material document names).
bool beyond32Bits(const std::vector<int64_t>& labels)
{
  return std::any_of(labels.begin(), labels.end(),
    [](int64_t l) { return l < 0 || double(l) > csgv::kMaxMaterialLabel; });
}

/// The labels of the rows a selection picks out of a label table (their ids where `ids`).
std::vector<int64_t> labelsOfSelectedRows(pqOutputPort* table, bool ids)
{
  vtkSMSourceProxy* selection = table->getSelectionInput();
  if (!selection)
    return {};
  pqScopedUndoExclude keepOff; // helper proxies (fetching rows) are no edits
  vtkSmartPointer<vtkSMSourceProxy> extract;
  extract.TakeReference(vtkSMSourceProxy::SafeDownCast(
    table->getSource()->getProxy()->GetSessionProxyManager()->NewProxy("filters", "ExtractSelection")));
  if (!extract)
    return {};
  vtkSMPropertyHelper(extract, "Input").Set(table->getSource()->getProxy(), table->getPortNumber());
  vtkSMPropertyHelper(extract, "Selection").Set(selection, table->getSelectionInputPort());
  extract->UpdateVTKObjects();
  std::vector<int64_t> rowIds;
  std::vector<int64_t> labels = fetchLabels(extract, 0, ids ? &rowIds : nullptr);
  return ids ? rowIds : labels;
}

/// Document labels: [0, 4294967294] (wider labels cannot be drawn selected).
std::vector<uint32_t> documentLabels(const std::vector<int64_t>& labels)
{
  std::vector<uint32_t> out;
  for (int64_t l : labels)
    if (l >= 0 && double(l) <= csgv::kMaxMaterialLabel)
      out.push_back(uint32_t(l));
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}
} // namespace

namespace pqCSGV
{
std::vector<uint32_t> selectedLabels(vtkSMProxy* display)
{
  if (!display || !display->GetProperty("CSGVMaterials"))
    return {};
  QString error;
  const csgv::MaterialDocument doc =
    parseDocument(QString::fromUtf8(vtkSMPropertyHelper(display, "CSGVMaterials").GetAsString()), &error);
  return error.isEmpty() ? doc.selected : std::vector<uint32_t>();
}

std::vector<uint32_t> labelsInRectangle(vtkSMProxy* display, int x0, int y0, int x1, int y1)
{
  const QStringList reply = query(display, "labels").split(' ');
  if (reply.size() != 3)
    return {};
  const long w = reply[0].toLong(), h = reply[1].toLong();
  const QByteArray pixels = QByteArray::fromBase64(reply[2].toLatin1());
  if (w <= 0 || h <= 0 || pixels.size() != w * h * 4)
    return {};
  const long xa = std::max(0L, long(std::min(x0, x1))), xb = std::min(w - 1, long(std::max(x0, x1)));
  const long ya = std::max(0L, long(std::min(y0, y1))), yb = std::min(h - 1, long(std::max(y0, y1)));
  std::vector<uint32_t> out;
  for (long y = ya; y <= yb; ++y)
  {
    for (long x = xa; x <= xb; ++x)
    {
      uint32_t v = 0;
      std::memcpy(&v, pixels.constData() + 4 * (y * w + x), 4); // little-endian, as the hosts here
      if (v != 0xFFFFFFFFu)
        out.push_back(v);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

QString labelsText(const std::vector<uint32_t>& labels)
{
  QStringList words;
  for (uint32_t l : labels)
    words << QString::number(l);
  return words.join(' ');
}
} // namespace pqCSGV

pqCSGVLabelSelection::pqCSGVLabelSelection(QObject* parent)
  : QObject(parent)
{
}

pqCSGVLabelSelection::~pqCSGVLabelSelection()
{
  this->shutdown();
}

QList<vtkSMProxy*> pqCSGVLabelSelection::volumeDisplaysOf(pqOutputPort* port)
{
  QList<vtkSMProxy*> out;
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  for (pqDataRepresentation* r : model->findItems<pqDataRepresentation*>())
  {
    if (port && r->getOutputPortFromInput() == port && r->getProxy()->GetProperty("CSGVMaterials"))
    {
      out.push_back(r->getProxy());
    }
  }
  return out;
}

pqCSGVLabelSelection* pqCSGVLabelSelection::instance()
{
  return Instance;
}

void pqCSGVLabelSelection::startup()
{
  Instance = this;
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  connect(model, &pqServerManagerModel::viewAdded, this, &pqCSGVLabelSelection::viewAdded);
  connect(model, &pqServerManagerModel::preViewRemoved, this, &pqCSGVLabelSelection::viewRemoved);
  connect(model, &pqServerManagerModel::preSourceRemoved, this, &pqCSGVLabelSelection::forgetRows);
  connect(model, &pqServerManagerModel::sourceAdded, this, &pqCSGVLabelSelection::sourceAdded);
  connect(model, &pqServerManagerModel::representationAdded, this, &pqCSGVLabelSelection::representationAdded);
  for (pqView* v : model->findItems<pqView*>())
    this->viewAdded(v);
  if (!this->connectSelectionManager())
  {
    // Started from PV_PLUGIN_PATH: the selection manager comes with pqPVApplicationCore, after
    // this; asked again from the event loop (and at every view or source added), for a minute.
    auto* retry = new QTimer(this);
    retry->setInterval(100);
    connect(retry, &QTimer::timeout, this, [this, retry, left = 600]() mutable {
      if (this->connectSelectionManager() || --left <= 0)
        retry->deleteLater();
    });
    retry->start();
  }
}

bool pqCSGVLabelSelection::connectSelectionManager()
{
  if (this->Selections)
    return true;
  pqPVApplicationCore* core = pqPVApplicationCore::instance();
  pqSelectionManager* selections = core ? core->selectionManager() : nullptr;
  if (!selections)
    return false;
  this->Selections = selections;
  connect(selections, &pqSelectionManager::selectionChanged, this, &pqCSGVLabelSelection::selectionChanged,
    Qt::UniqueConnection);
  return true;
}

void pqCSGVLabelSelection::shutdown()
{
  if (Instance == this)
    Instance = nullptr;
  if (pqApplicationCore* core = pqApplicationCore::instance())
    disconnect(core->getServerManagerModel(), nullptr, this, nullptr);
  if (this->Selections)
    disconnect(this->Selections, nullptr, this, nullptr);
  this->Selections = nullptr;
  for (auto it = this->Observed.begin(); it != this->Observed.end(); ++it)
    if (auto* rv = qobject_cast<pqRenderView*>(it.key()))
      if (vtkSMRenderViewProxy* rmp = rv->getRenderViewProxy())
        rmp->RemoveObserver(it.value());
  this->Observed.clear();
  this->RowLabels.clear();
}

void pqCSGVLabelSelection::viewAdded(pqView* view)
{
  this->connectSelectionManager();
  auto* rv = qobject_cast<pqRenderView*>(view);
  vtkSMRenderViewProxy* rmp = rv ? rv->getRenderViewProxy() : nullptr;
  if (!rmp || this->Observed.contains(view))
    return;
  // Before ParaView's own reaction (priority 0), which ends the selection mode: the mode tells a
  // rectangle (int[4]) from a polygon (vtkIntArray) here.
  const unsigned long id =
    rmp->AddObserver(vtkCommand::SelectionChangedEvent, this, &pqCSGVLabelSelection::regionSelected, 1.0f);
  this->Observed.insert(view, id);
}

void pqCSGVLabelSelection::representationAdded(pqRepresentation* representation)
{
  // Found by a GUI pass: a view made after a selection drew the data without it. A display is
  // registered before its input is linked: it is looked at from the event loop.
  QPointer<pqDataRepresentation> added = qobject_cast<pqDataRepresentation*>(representation);
  if (!added || !added->getProxy()->GetProperty("CSGVMaterials"))
    return;
  QTimer::singleShot(0, this, [added]() {
    vtkSMProxy* display = added ? added->getProxy() : nullptr;
    if (!display)
      return;
    const QString current = QString::fromUtf8(vtkSMPropertyHelper(display, "CSGVMaterials").GetAsString());
    QString why;
    csgv::MaterialDocument doc = pqCSGV::parseDocument(current, &why);
    if (!why.isEmpty())
      return;
    for (vtkSMProxy* other : volumeDisplaysOf(added->getOutputPortFromInput()))
    {
      if (other == display)
        continue;
      csgv::MaterialDocument shown =
        pqCSGV::parseDocument(QString::fromUtf8(vtkSMPropertyHelper(other, "CSGVMaterials").GetAsString()), &why);
      if (!why.isEmpty() || shown.selected.empty())
        continue;
      doc.selected = shown.selected;
      doc.selectionStyle = shown.selectionStyle;
      doc.selectionColor = shown.selectionColor;
      const QString text = pqCSGV::serialize(doc);
      if (text != current)
      {
        // Part of making the display (its Show, or the state's load): no undo step of its own.
        pqScopedUndoExclude partOfShow;
        vtkSMPropertyHelper(display, "CSGVMaterials").Set(text.toUtf8().constData());
        display->UpdateVTKObjects();
        if (pqView* view = added->getView())
          view->render();
      }
      return;
    }
  });
}

void pqCSGVLabelSelection::viewRemoved(pqView* view)
{
  auto it = this->Observed.find(view);
  if (it == this->Observed.end())
    return;
  if (auto* rv = qobject_cast<pqRenderView*>(view))
    if (vtkSMRenderViewProxy* rmp = rv->getRenderViewProxy())
      rmp->RemoveObserver(it.value());
  this->Observed.erase(it);
}

void pqCSGVLabelSelection::regionSelected(vtkObject* caller, unsigned long, void* calldata)
{
  auto* rmp = vtkSMRenderViewProxy::SafeDownCast(caller);
  pqView* view = nullptr;
  for (auto it = this->Observed.begin(); it != this->Observed.end(); ++it)
    if (auto* rv = qobject_cast<pqRenderView*>(it.key()); rv && rv->getRenderViewProxy() == rmp)
      view = it.key();
  if (!rmp || !view || !calldata || vtkSMPropertyHelper(rmp, "InteractionMode").GetAsInt() != vtkPVRenderView::INTERACTION_MODE_SELECTION)
    return;
  const int* r = static_cast<const int*>(calldata);
  const std::array<int, 4> region{ { r[0], r[1], r[2], r[3] } };
  vtkRenderWindowInteractor* interactor = rmp->GetInteractor();
  const bool ctrl = interactor && interactor->GetControlKey(), shift = interactor && interactor->GetShiftKey();
  const csgv::SelectionEdit edit = ctrl ? csgv::SelectionEdit::Add
    : shift                             ? csgv::SelectionEdit::Remove
                                        : csgv::SelectionEdit::Replace;
  // After ParaView's own selection, which clears the selections it did not make.
  QPointer<pqView> guarded(view);
  QTimer::singleShot(0, this, [guarded, region, edit]() {
    if (guarded)
      pqCSGVLabelSelection::selectRectangle(guarded, region.data(), edit);
  });
}

void pqCSGVLabelSelection::selectRectangle(pqView* view, const int region[4], csgv::SelectionEdit edit)
{
  for (pqRepresentation* r : view->getRepresentations())
  {
    auto* dr = qobject_cast<pqDataRepresentation*>(r);
    if (!dr || !dr->isVisible() || !dr->getProxy()->GetProperty("Representation"))
      continue;
    const char* type = vtkSMPropertyHelper(dr->getProxy(), "Representation").GetAsString();
    if (!type || std::strcmp(type, "Segmentation Volume") != 0)
      continue;
    const std::vector<uint32_t> labels =
      pqCSGV::labelsInRectangle(dr->getProxy(), region[0], region[1], region[2], region[3]);
    if (labels.empty() && edit != csgv::SelectionEdit::Replace)
      continue;
    QString error;
    if (!pqCSGVLabelSelection::edit(dr->getProxy(), labels, edit, "Select labels", &error))
      qWarning("%s", qUtf8Printable(error));
  }
  view->render();
}

bool pqCSGVLabelSelection::edit(vtkSMProxy* display, const std::vector<uint32_t>& labels,
  csgv::SelectionEdit edit, const QString& undoLabel, QString* error)
{
  pqOutputPort* port = inputOf(display);
  QList<vtkSMProxy*> displays = volumeDisplaysOf(port);
  if (!displays.contains(display))
    displays.push_front(display);
  // Every display's text edited first, so that an invalid one changes none.
  QList<QByteArray> texts;
  std::vector<uint32_t> selected;
  for (vtkSMProxy* d : displays)
  {
    QString why;
    const QString current = QString::fromUtf8(vtkSMPropertyHelper(d, "CSGVMaterials").GetAsString());
    csgv::MaterialDocument doc = pqCSGV::parseDocument(current, &why);
    if (!why.isEmpty())
    {
      if (error)
        *error = QString("The materials are not valid, so labels cannot be selected: %1").arg(why);
      return false;
    }
    csgv::editSelection(doc, labels, edit);
    if (doc.selected.size() > kMaxSelectedLabels)
    {
      if (error)
        *error = QString("%1 labels would be selected, more than %2: select fewer (a query, a smaller "
                         "rectangle), or extract them by a Query in CSGV Extract Labels")
                   .arg(doc.selected.size())
                   .arg(kMaxSelectedLabels);
      return false;
    }
    if (d == display)
      selected = doc.selected;
    const QString text = pqCSGV::serialize(doc);
    texts.push_back(text == current ? QByteArray() : text.toUtf8());
  }
  bool changed = false;
  for (const QByteArray& t : texts)
    changed = changed || !t.isEmpty();
  if (changed)
  {
    BEGIN_UNDO_SET(undoLabel);
    for (int i = 0; i < displays.size(); ++i)
    {
      if (texts[i].isEmpty())
        continue;
      pqCSGV::setMaterials(displays[i], QString::fromUtf8(texts[i]));
    }
    END_UNDO_SET();
  }
  pqCSGVLabelSelection* self = Instance;
  if (self && !self->Busy && port)
  {
    // From the event loop, after the edit's own signals (an edit may come from inside a view's
    // mouse event: the pick panel).
    QPointer<pqOutputPort> guarded(port);
    QTimer::singleShot(0, self, [self, guarded, selected]() {
      if (!guarded)
        return;
      self->Busy = true;
      self->selectRows(guarded, selected);
      self->Busy = false;
    });
  }
  return true;
}

void pqCSGVLabelSelection::selectRows(pqOutputPort* input, const std::vector<uint32_t>& labels)
{
  pqSelectionManager* selections = pqPVApplicationCore::instance() ? pqPVApplicationCore::instance()->selectionManager() : nullptr;
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  for (pqPipelineSource* s : model->findItems<pqPipelineSource*>())
  {
    auto* table = qobject_cast<pqPipelineFilter*>(s);
    if (!isLabelTable(s) || !table || table->getAnyInput() != input || s->getNumberOfOutputPorts() < 1)
      continue;
    pqOutputPort* out = s->getOutputPort(0);
    if (labels.empty())
    {
      if (out->getSelectionInput())
      {
        out->setSelectionInput(nullptr, 0);
        if (selections)
          selections->clearSelection(out);
      }
      continue;
    }
    // Rows are the table's labels in ascending order: an ID selection of rows (ParaView's
    // selectors look IDs up in a sorted list; a threshold per label would be scanned per row).
    const std::vector<std::pair<int64_t, int64_t>>& rows = this->rowLabels(s).byLabel;
    std::vector<vtkIdType> ids;
    for (uint32_t l : labels)
    {
      const auto it = std::lower_bound(rows.begin(), rows.end(), std::make_pair(int64_t(l), int64_t(-1)));
      if (it != rows.end() && it->first == int64_t(l))
      {
        ids.push_back(0); // process 0's table
        ids.push_back(vtkIdType(it->second));
      }
    }
    pqScopedUndoExclude keepOff; // helper proxies (fetching rows) are no edits
    vtkSmartPointer<vtkSMSourceProxy> selection;
    selection.TakeReference(vtkSMSourceProxy::SafeDownCast(
      s->getProxy()->GetSessionProxyManager()->NewProxy("sources", "IDSelectionSource")));
    if (!selection)
      continue;
    vtkSMPropertyHelper(selection, "FieldType").Set(vtkSelectionNode::ROW);
    vtkSMPropertyHelper(selection, "IDs").Set(ids.data(), static_cast<unsigned int>(ids.size()));
    selection->UpdateVTKObjects();
    // ParaView 5.11's selection inputs are AppendSelections of selection sources (its Find Data
    // frame reads the first source through them, and crashed on a bare source).
    vtkSmartPointer<vtkSMSourceProxy> append;
    append.TakeReference(
      vtkSMSourceProxy::SafeDownCast(vtkSMSelectionHelper::NewAppendSelectionsFromSelectionSource(selection)));
    if (!append)
      continue;
    out->setSelectionInput(append, 0);
    if (selections)
    {
      // ParaView's selection manager makes the selected port the active one; a selection made in
      // 3D leaves the active source (the volume, a filter) as it was.
      pqPipelineSource* active = pqActiveObjects::instance().activeSource();
      selections->select(out);
      if (active && active != s)
        pqActiveObjects::instance().setActiveSource(active);
    }
  }
}

void pqCSGVLabelSelection::sourceAdded(pqPipelineSource* source)
{
  this->connectSelectionManager();
  if (!isLabelTable(source))
    return;
  // Its input and rows exist at its first update (not yet when it is added): then its rows take
  // the selection made before it existed, once (later selections reach it as they are made).
  auto once = std::make_shared<QMetaObject::Connection>();
  *once = connect(source, QOverload<pqPipelineSource*>::of(&pqPipelineSource::dataUpdated), this,
    [this, once](pqPipelineSource* table) {
      QObject::disconnect(*once);
      auto* filter = qobject_cast<pqPipelineFilter*>(table);
      pqOutputPort* input = filter ? filter->getAnyInput() : nullptr;
      const QList<vtkSMProxy*> displays = volumeDisplaysOf(input);
      if (this->Busy || displays.isEmpty())
        return;
      const std::vector<uint32_t> labels = pqCSGV::selectedLabels(displays.front());
      if (labels.empty())
        return;
      this->Busy = true; // the labels are selected already
      this->selectRows(input, labels);
      this->Busy = false;
    });
}

void pqCSGVLabelSelection::forgetRows(pqPipelineSource* table)
{
  this->RowLabels.remove(table);
}

const pqCSGVLabelSelection::TableRows& pqCSGVLabelSelection::rowLabels(pqPipelineSource* table)
{
  auto it = this->RowLabels.find(table);
  if (it == this->RowLabels.end())
  {
    // Fetched again after the table's next update (the file changed, attributes were computed).
    connect(table, QOverload<pqPipelineSource*>::of(&pqPipelineSource::dataUpdated), this,
      &pqCSGVLabelSelection::forgetRows, Qt::UniqueConnection);
    std::vector<int64_t> ids;
    const std::vector<int64_t> labels = fetchLabels(vtkSMSourceProxy::SafeDownCast(table->getProxy()), 0, &ids);
    TableRows rows;
    rows.ids = beyond32Bits(labels) && ids.size() == labels.size();
    const std::vector<int64_t>& drawn = rows.ids ? ids : labels;
    for (size_t i = 0; i < drawn.size(); ++i)
      rows.byLabel.emplace_back(drawn[i], int64_t(i));
    std::sort(rows.byLabel.begin(), rows.byLabel.end());
    it = this->RowLabels.insert(table, rows);
  }
  return *it;
}

void pqCSGVLabelSelection::selectionChanged(pqOutputPort* port)
{
  if (this->Busy || !port || !isLabelTable(port->getSource()) || !port->getSelectionInput())
    return;
  auto* table = qobject_cast<pqPipelineFilter*>(port->getSource());
  pqOutputPort* input = table ? table->getAnyInput() : nullptr;
  const QList<vtkSMProxy*> displays = volumeDisplaysOf(input);
  if (displays.isEmpty())
    return;
  const std::vector<uint32_t> labels = documentLabels(labelsOfSelectedRows(port, this->rowLabels(table).ids));
  if (labels == pqCSGV::selectedLabels(displays.front()))
    return;
  this->Busy = true; // the rows are selected already
  QString error;
  if (!pqCSGVLabelSelection::edit(displays.front(), labels, csgv::SelectionEdit::Replace, "Select labels from the table", &error))
    qWarning("%s", qUtf8Printable(error));
  this->Busy = false;
  for (pqView* v : pqApplicationCore::instance()->getServerManagerModel()->findItems<pqView*>())
    v->render();
}
