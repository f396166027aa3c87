// SPDX-License-Identifier: MIT
#include "CSGVHitOrder.h"
#include "pqCSGVPickPanel.h"

#include "pqCSGVLabelSelection.h"
#include "pqCSGVMaterialDocument.h"

#include <pqActiveObjects.h>
#include <pqApplicationCore.h>
#include <pqDataRepresentation.h>
#include <pqObjectBuilder.h>
#include <pqOutputPort.h>
#include <pqPipelineFilter.h>
#include <pqPipelineSource.h>
#include <pqServer.h>
#include <pqServerManagerModel.h>
#include <pqTimeKeeper.h>
#include <pqUndoStack.h>
#include <pqView.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMProxy.h>

#include <QCheckBox>
#include <QComboBox>
#include <QLabel>
#include <QLineEdit>
#include <QGridLayout>
#include <QHBoxLayout>
#include <QJsonArray>
#include <QMouseEvent>
#include <QPushButton>
#include <QTextBrowser>
#include <QVBoxLayout>

#include <cmath>

pqCSGVPickPanel::pqCSGVPickPanel(const QString& title, QWidget* parent, Qt::WindowFlags flags)
  : Superclass(title, parent, flags)
{
  this->build();
}

pqCSGVPickPanel::pqCSGVPickPanel(QWidget* parent)
  : Superclass(parent)
{
  this->build();
}

pqCSGVPickPanel::~pqCSGVPickPanel() = default;

void pqCSGVPickPanel::build()
{
  this->setObjectName("CSGVPickPanel");
  this->setWindowTitle("Segmentation Pick");
  auto* w = new QWidget(this);
  auto* l = new QVBoxLayout(w);
  auto* top = new QHBoxLayout();
  this->Enabled = new QCheckBox("Pick on click", w);
  this->Enabled->setObjectName("pickEnabled");
  this->Enabled->setChecked(true);
  this->Follow = new QCheckBox("Follow mouse", w);
  this->Follow->setObjectName("followMouse");
  top->addWidget(this->Enabled);
  top->addWidget(this->Follow);
  l->addLayout(top);
  this->Result = new QTextBrowser(w);
  this->Result->setObjectName("pickResult");
  this->Result->setPlaceholderText("Click on a Segmentation Volume in the render view.");
  l->addWidget(this->Result);
  // Two columns at most a row: the dock stays narrow enough to sit beside the view (in one row
  // each, these made it wider than a 1600-pixel screen with the window).
  auto* buttons = new QGridLayout();
  this->Hide = new QPushButton("Hide this label", w);
  this->Hide->setObjectName("hideLabel");
  this->ShowOnly = new QPushButton("Show only this label", w);
  this->ShowOnly->setObjectName("showOnlyLabel");
  this->ShowAll = new QPushButton("Show all", w);
  this->ShowAll->setObjectName("showAllLabels");
  this->Hide->setToolTip("Do not draw the picked label (the materials stay as they are)");
  this->ShowOnly->setToolTip("Draw only the picked label, in its material (the materials stay)");
  this->ShowAll->setToolTip("Draw every label the materials take again");
  buttons->addWidget(this->Hide, 0, 0);
  buttons->addWidget(this->ShowOnly, 0, 1);
  buttons->addWidget(this->ShowAll, 1, 0);
  l->addLayout(buttons);
  auto* selection = new QGridLayout();
  this->SelectOnClick = new QCheckBox("Select on click", w);
  this->SelectOnClick->setObjectName("selectOnClick");
  this->SelectOnClick->setChecked(true);
  this->SelectOnClick->setToolTip("A click selects the picked label; Ctrl+click adds it, Shift+click removes it");
  this->SelectionStyle = new QComboBox(w);
  this->SelectionStyle->setObjectName("selectionStyle");
  this->SelectionStyle->addItems({ "Highlight", "Dim the rest" });
  this->SelectionStyle->setToolTip("How the selected labels are shown");
  this->ClearSelection = new QPushButton("Clear selection", w);
  this->ClearSelection->setObjectName("clearSelection");
  this->ExtractSelection = new QPushButton("Extract selection", w);
  this->ExtractSelection->setObjectName("extractSelection");
  this->ExtractSelection->setToolTip("A CSGV Extract Labels filter of the selected labels (press Apply)");
  selection->addWidget(this->SelectOnClick, 0, 0);
  selection->addWidget(this->SelectionStyle, 0, 1);
  selection->addWidget(this->ClearSelection, 1, 0);
  selection->addWidget(this->ExtractSelection, 1, 1);
  l->addLayout(selection);
  this->SelectQuery = new QLineEdit(w);
  this->SelectQuery->setObjectName("selectQuery");
  this->SelectQuery->setPlaceholderText("Select where (SQL), e.g. voxels > 1000 and kind = 2");
  this->SelectQuery->setToolTip("Selects the labels whose attributes make the condition true (Enter)");
  l->addWidget(this->SelectQuery);
  connect(this->SelectQuery, &QLineEdit::returnPressed, this, &pqCSGVPickPanel::selectByQuery);
  this->SelectionInfo = new QLabel(w);
  this->SelectionInfo->setObjectName("selectionInfo");
  this->SelectionInfo->setWordWrap(true);
  l->addWidget(this->SelectionInfo);
  connect(this->ClearSelection, &QPushButton::clicked, this, &pqCSGVPickPanel::clearSelection);
  connect(this->ExtractSelection, &QPushButton::clicked, this, &pqCSGVPickPanel::extractSelection);
  connect(this->SelectionStyle, QOverload<int>::of(&QComboBox::activated), this, &pqCSGVPickPanel::setSelectionStyle);
  this->Hide->setEnabled(false);
  this->ShowOnly->setEnabled(false);
  this->setWidget(w);
  connect(this->Hide, &QPushButton::clicked, this, &pqCSGVPickPanel::hideLabel);
  connect(this->ShowOnly, &QPushButton::clicked, this, &pqCSGVPickPanel::showOnlyLabel);
  connect(this->ShowAll, &QPushButton::clicked, this, &pqCSGVPickPanel::showAllLabels);
  connect(&pqActiveObjects::instance(), &pqActiveObjects::viewChanged, this, &pqCSGVPickPanel::setView);
  connect(pqApplicationCore::instance()->getServerManagerModel(),
    &pqServerManagerModel::preRepresentationRemoved, this, &pqCSGVPickPanel::representationRemoved);

  this->setView(pqActiveObjects::instance().activeView());
  // Undo, redo and edits elsewhere (the table, ParaView's tools) change the selection too.
  if (pqUndoStack* undo = pqApplicationCore::instance()->getUndoStack())
  {
    connect(undo, &pqUndoStack::stackChanged, this, &pqCSGVPickPanel::updateSelectionInfo);
  }
  connect(&pqActiveObjects::instance(),
    QOverload<pqRepresentation*>::of(&pqActiveObjects::representationChanged), this,
    &pqCSGVPickPanel::updateSelectionInfo);
  // The active data set too: the one shown in another view than the active one has no active
  // representation to change (GUI pass 14: a click on the reader with a Spreadsheet active).
  connect(&pqActiveObjects::instance(), &pqActiveObjects::sourceChanged, this, &pqCSGVPickPanel::updateSelectionInfo);
  this->updateSelectionInfo();
  // An optional dock, hidden until the user opens it from the View menu (see the class comment).
  this->hide();
}

void pqCSGVPickPanel::clearPick()
{
  this->Last = QJsonObject();
  this->LastDisplay = nullptr;
  this->Result->clear();
  this->Hide->setEnabled(false);
  this->ShowOnly->setEnabled(false);
  this->updateSelectionInfo(); // Show all's display may have been the pick's
}

void pqCSGVPickPanel::representationRemoved(pqRepresentation* representation)
{
  if (representation && representation->getProxy() == this->LastDisplay)
  {
    this->clearPick();
  }
}

void pqCSGVPickPanel::setView(pqView* view)
{
  if (this->ViewWidget)
  {
    this->ViewWidget->removeEventFilter(this);
  }
  if (view != this->View)
  {
    this->clearPick(); // the pick belongs to the view it was made in
  }
  this->View = view;
  this->ViewWidget = view ? view->widget() : nullptr;
  // The pick belongs to the time it was made at too: another time step may hold another volume
  // (a series of files of different sizes), where its voxel and label mean nothing.
  QObject::disconnect(this->TimeChange);
  if (view && view->getServer() && view->getServer()->getTimeKeeper())
  {
    this->TimeChange =
      connect(view->getServer()->getTimeKeeper(), &pqTimeKeeper::timeChanged, this, &pqCSGVPickPanel::clearPick);
  }
  // And to what the view showed: data shown in it since may be under the pixel now (GUI pass
  // 11: "No label at pixel ..." stayed after the volume appeared).
  QObject::disconnect(this->DataShown);
  if (view)
  {
    this->DataShown = connect(view, &pqView::representationAdded, this, &pqCSGVPickPanel::clearPick);
  }
  if (this->ViewWidget)
  {
    this->ViewWidget->installEventFilter(this);
    this->ViewWidget->setMouseTracking(true);
  }
  this->updateSelectionInfo();
}

bool pqCSGVPickPanel::eventFilter(QObject* watched, QEvent* event)
{
  // Only while the panel is open: a hidden panel neither picks nor selects on clicks.
  if (watched == this->ViewWidget && this->Enabled->isChecked() && this->isVisible())
  {
    if (event->type() == QEvent::MouseButtonPress)
    {
      auto* e = static_cast<QMouseEvent*>(event);
      this->Pressed = e->button() == Qt::LeftButton;
      this->PressPos = e->pos();
      this->PressModifiers = e->modifiers();
    }
    else if (event->type() == QEvent::MouseButtonRelease && this->Pressed)
    {
      auto* e = static_cast<QMouseEvent*>(event);
      this->Pressed = false;
      if ((e->pos() - this->PressPos).manhattanLength() <= 3 && this->pickAt(e->pos()) &&
        this->SelectOnClick->isChecked())
      {
        const csgv::SelectionEdit edit = (this->PressModifiers & Qt::ControlModifier) ? csgv::SelectionEdit::Add
          : (this->PressModifiers & Qt::ShiftModifier)                               ? csgv::SelectionEdit::Remove
                                                                                     : csgv::SelectionEdit::Replace;
        QString error;
        const auto label = uint32_t(this->Last.value("label").toDouble());
        if (!pqCSGVLabelSelection::edit(this->LastDisplay, { label }, edit, "Select label", &error))
        {
          this->Result->append(QString("<i>%1</i>").arg(error.toHtmlEscaped()));
        }
        this->updateSelectionInfo();
        pqCSGV::renderViewsShowing(this->LastDisplay, this->View);
      }
    }
    else if (event->type() == QEvent::MouseMove && this->Follow->isChecked() &&
      !(static_cast<QMouseEvent*>(event)->buttons() & Qt::LeftButton))
    {
      this->pickAt(static_cast<QMouseEvent*>(event)->pos());
    }
  }
  return this->Superclass::eventFilter(watched, event);
}

bool pqCSGVPickPanel::pickAt(const QPoint& pos)
{
  this->clearPick();
  if (!this->View || !this->ViewWidget)
  {
    return false;
  }
  const double dpr = this->ViewWidget->devicePixelRatioF();
  const int x = int(std::floor(pos.x() * dpr));
  const int y = int(std::floor((this->ViewWidget->height() - 1 - pos.y()) * dpr));
  QJsonObject best;
  vtkSMProxy* bestDisplay = nullptr;
  for (pqRepresentation* r : this->View->getRepresentations())
  {
    auto* dr = qobject_cast<pqDataRepresentation*>(r);
    if (!dr || !dr->isVisible() || !dr->getProxy()->GetProperty("Representation"))
    {
      continue;
    }
    const char* type = vtkSMPropertyHelper(dr->getProxy(), "Representation").GetAsString();
    if (!type || QString(type) != "Segmentation Volume")
    {
      continue;
    }
    const QJsonObject p = pqCSGV::queryJson(dr->getProxy(), QString("pick %1 %2").arg(x).arg(y));
    // The one a render of all of them would report: opaque before semi-transparent, then nearest.
    const auto order = [](const QJsonObject& h) {
      return csgvrep::hitOrder(h.value("hit").toBool(), h.value("translucent").toBool(), h.value("depth").toDouble(1));
    };
    if (p.value("hit").toBool() && (best.isEmpty() || order(p) < order(best)))
    {
      best = p;
      bestDisplay = dr->getProxy();
    }
  }
  this->Last = best;
  this->LastDisplay = bestDisplay;
  this->updateSelectionInfo();
  this->Hide->setEnabled(bestDisplay != nullptr);
  this->ShowOnly->setEnabled(bestDisplay != nullptr);
  if (!bestDisplay)
  {
    this->Result->setHtml(QString("<i>No label at pixel (%1, %2).</i>").arg(x).arg(y));
    return false;
  }
  QString html = QString("<b>Label %1</b>").arg(qint64(best.value("label").toDouble()));
  // A volume whose labels do not fit 32 bits is drawn by ids: the voxel's own label beside it.
  if (best.contains("originalText"))
  {
    html += QString(" (original label %1)").arg(best.value("originalText").toString().toHtmlEscaped());
  }
  if (best.value("translucent").toBool())
  {
    html += " (semi-transparent: no opaque label behind it)";
  }
  const QJsonArray v = best.value("voxel").toArray();
  if (v.size() == 3)
  {
    html += QString("<br>voxel (%1, %2, %3)").arg(v[0].toInt()).arg(v[1].toInt()).arg(v[2].toInt());
  }
  const QJsonArray wp = best.value("world").toArray();
  if (wp.size() == 3)
  {
    html += QString("<br>world (%1, %2, %3)")
              .arg(wp[0].toDouble(), 0, 'g', 6)
              .arg(wp[1].toDouble(), 0, 'g', 6)
              .arg(wp[2].toDouble(), 0, 'g', 6);
  }
  html += "<table>";
  const QJsonObject attrs = best.value("attributes").toObject();
  for (auto it = attrs.begin(); it != attrs.end(); ++it)
  {
    const QString value = it.value().isString() ? it.value().toString().toHtmlEscaped()
      : it.value().isDouble()                    ? QString::number(it.value().toDouble(), 'g', 10)
                                                 : QString("-");
    html += QString("<tr><td>%1</td><td>%2</td></tr>").arg(it.key().toHtmlEscaped(), value);
  }
  html += "</table>";
  this->Result->setHtml(html);
  return true;
}

void pqCSGVPickPanel::editVisibility(
  const QString& undoLabel, vtkSMProxy* display, pqCSGV::LabelVisibility edit)
{
  if (!display || !display->GetProperty("CSGVMaterials"))
  {
    return;
  }
  const char* current = vtkSMPropertyHelper(display, "CSGVMaterials").GetAsString();
  const qint64 label = qint64(this->Last.value("label").toDouble());
  QString error;
  const QString text = pqCSGV::editLabelVisibility(
    current, edit, label, &error);
  if (!error.isEmpty())
  {
    this->Result->setHtml(
      QString("<i>The materials are not valid, so labels cannot be shown or hidden: %1</i>")
        .arg(error.toHtmlEscaped()));
    return;
  }
  BEGIN_UNDO_SET(undoLabel);
  pqCSGV::setMaterials(display, text);
  END_UNDO_SET();
  pqCSGV::renderViewsShowing(display, this->View);
}

void pqCSGVPickPanel::hideLabel()
{
  if (this->Last.value("hit").toBool())
  {
    this->editVisibility("Hide label", this->LastDisplay, pqCSGV::LabelVisibility::Hide);
  }
}

void pqCSGVPickPanel::showOnlyLabel()
{
  if (this->Last.value("hit").toBool())
  {
    this->editVisibility("Show only label", this->LastDisplay, pqCSGV::LabelVisibility::ShowOnly);
  }
}

void pqCSGVPickPanel::showAllLabels()
{
  // The display the selection buttons act on (a Label Table active in a Spreadsheet: its
  // volume's; GUI pass 15 found Show all enabled there but editing nothing).
  this->editVisibility("Show all labels", this->selectionDisplay(), pqCSGV::LabelVisibility::ShowAll);
}

vtkSMProxy* pqCSGVPickPanel::selectionDisplay() const
{
  if (this->LastDisplay)
  {
    return this->LastDisplay;
  }
  pqDataRepresentation* r = pqActiveObjects::instance().activeRepresentation();
  if (r && r->getProxy()->GetProperty("CSGVMaterials"))
  {
    return r->getProxy();
  }
  // A filter of a segmentation is active (its Label Table, whose rows select labels, shown in a
  // Spreadsheet view: GUI pass 10 read "No label selected" there): the selection of its input's
  // volume, one per data set.
  pqPipelineSource* active = pqActiveObjects::instance().activeSource();
  auto* filter = qobject_cast<pqPipelineFilter*>(active);
  pqOutputPort* input = filter ? filter->getAnyInput() : nullptr;
  QList<vtkSMProxy*> displays = pqCSGVLabelSelection::volumeDisplaysOf(input);
  // The active data set's own volume, shown in a view that is not active (GUI pass 14 read "No
  // label selected" with the reader active and a Spreadsheet view active).
  if (displays.isEmpty() && active)
  {
    displays = pqCSGVLabelSelection::volumeDisplaysOf(active->getOutputPort(0));
  }
  return displays.isEmpty() ? nullptr : displays.front();
}

void pqCSGVPickPanel::updateSelectionInfo()
{
  vtkSMProxy* display = this->selectionDisplay();
  const std::vector<uint32_t> labels = pqCSGV::selectedLabels(display);
  const auto enable = [this](QPushButton* b, bool enabled)
  {
    if (!enabled && b->hasFocus())
    {
      // A focused button that is disabled hands the focus to the next field, the SQL box, which
      // then took the view's shortcut keys ('s' for Select Cells: found by a GUI pass): the view
      // takes it.
      b->clearFocus();
      if (this->View && this->View->widget())
      {
        this->View->widget()->setFocus();
      }
    }
    b->setEnabled(enabled);
  };
  enable(this->ClearSelection, !labels.empty());
  enable(this->ExtractSelection, !labels.empty());
  enable(this->ShowAll, display != nullptr);
  if (!display || labels.empty())
  {
    this->SelectionInfo->setText("No label selected.");
    return;
  }
  constexpr size_t kShown = 12;
  QString text = QString("%1 label%2 selected: ").arg(labels.size()).arg(labels.size() == 1 ? "" : "s");
  text += pqCSGV::labelsText(std::vector<uint32_t>(labels.begin(), labels.begin() + std::min(labels.size(), kShown)));
  if (labels.size() > kShown)
  {
    text += " ...";
  }
  this->SelectionInfo->setText(text);
  const QString style = QString::fromUtf8(vtkSMPropertyHelper(display, "CSGVMaterials").GetAsString());
  this->SelectionStyle->setCurrentIndex(
    pqCSGV::parseDocument(style).selectionStyle == csgv::MaterialDocument::SelectionStyle::Dim ? 1 : 0);
}

void pqCSGVPickPanel::clearSelection()
{
  if (vtkSMProxy* display = this->selectionDisplay())
  {
    pqCSGVLabelSelection::edit(display, {}, csgv::SelectionEdit::Replace, "Clear label selection");
    pqCSGV::renderViewsShowing(display, this->View);
  }
  this->updateSelectionInfo();
}

void pqCSGVPickPanel::setSelectionStyle(int index)
{
  vtkSMProxy* display = this->selectionDisplay();
  if (!display)
  {
    return;
  }
  QString error;
  csgv::MaterialDocument doc =
    pqCSGV::parseDocument(QString::fromUtf8(vtkSMPropertyHelper(display, "CSGVMaterials").GetAsString()), &error);
  if (!error.isEmpty())
  {
    this->Result->setHtml(QString("<i>The materials are not valid: %1</i>").arg(error.toHtmlEscaped()));
    return;
  }
  doc.selectionStyle =
    index == 1 ? csgv::MaterialDocument::SelectionStyle::Dim : csgv::MaterialDocument::SelectionStyle::Highlight;
  BEGIN_UNDO_SET("Label selection style");
  pqCSGV::setMaterials(display, pqCSGV::serialize(doc));
  END_UNDO_SET();
  pqCSGV::renderViewsShowing(display, this->View);
}

void pqCSGVPickPanel::extractSelection()
{
  vtkSMProxy* display = this->selectionDisplay();
  std::vector<uint32_t> labels = pqCSGV::selectedLabels(display);
  // Label 0 is the background of the meshes; when no material takes it (empty space, the
  // default), a selection that holds it (a query over the table's rows) extracts the rest.
  const csgv::MaterialDocument doc =
    pqCSGV::parseDocument(QString::fromUtf8(vtkSMPropertyHelper(display, "CSGVMaterials").GetAsString()));
  if (!labels.empty() && labels.front() == 0 && 
    csgv::MaterialEvaluator(doc, [](const std::string&, uint32_t) { return std::nan(""); }).materialOf(0) < 0)
  {
    labels.erase(labels.begin());
  }
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  auto* r = model->findItem<pqDataRepresentation*>(display);
  pqOutputPort* port = r ? r->getOutputPortFromInput() : nullptr;
  if (labels.empty() || !port)
  {
    return;
  }
  BEGIN_UNDO_SET("Extract selected labels");
  pqPipelineSource* filter = pqApplicationCore::instance()->getObjectBuilder()->createFilter(
    "filters", "CSGVExtractLabels", port->getSource(), port->getPortNumber());
  if (filter)
  {
    vtkSMPropertyHelper(filter->getProxy(), "Labels").Set(pqCSGV::labelsText(labels).toUtf8().constData());
    filter->getProxy()->UpdateVTKObjects();
    pqActiveObjects::instance().setActiveSource(filter);
  }
  END_UNDO_SET();
}

void pqCSGVPickPanel::selectByQuery()
{
  vtkSMProxy* display = this->selectionDisplay();
  const QString condition = this->SelectQuery->text().trimmed();
  if (!display || condition.isEmpty())
  {
    return;
  }
  const QJsonObject answer = pqCSGV::queryJson(display, "match " + condition);
  if (answer.contains("error") || !answer.contains("labels"))
  {
    this->Result->setHtml(QString("<i>The query selects nothing: %1</i>")
                            .arg(answer.value("error").toString("no answer").toHtmlEscaped()));
    return;
  }
  std::vector<uint32_t> labels;
  for (const QJsonValue& v : answer.value("labels").toArray())
  {
    labels.push_back(uint32_t(v.toDouble()));
  }
  QString error;
  if (!pqCSGVLabelSelection::edit(display, labels, csgv::SelectionEdit::Replace, "Select labels by query", &error))
  {
    this->Result->setHtml(QString("<i>%1</i>").arg(error.toHtmlEscaped()));
  }
  else if (answer.value("truncated").toBool())
  {
    this->Result->setHtml(QString("<i>The query matches more labels than a selection holds; the first %1 are selected.</i>")
                            .arg(labels.size()));
  }
  this->updateSelectionInfo();
  pqCSGV::renderViewsShowing(display, this->View);
}
