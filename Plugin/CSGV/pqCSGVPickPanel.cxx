// SPDX-License-Identifier: MIT
#include "pqCSGVPickPanel.h"

#include "pqCSGVMaterialDocument.h"

#include <pqActiveObjects.h>
#include <pqApplicationCore.h>
#include <pqDataRepresentation.h>
#include <pqServerManagerModel.h>
#include <pqUndoStack.h>
#include <pqView.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMProxy.h>

#include <QCheckBox>
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
  auto* buttons = new QHBoxLayout();
  this->Hide = new QPushButton("Hide this label", w);
  this->Hide->setObjectName("hideLabel");
  this->ShowOnly = new QPushButton("Show only this label", w);
  this->ShowOnly->setObjectName("showOnlyLabel");
  this->ShowAll = new QPushButton("Show all", w);
  this->ShowAll->setObjectName("showAllLabels");
  this->Hide->setToolTip("Do not draw the picked label (the materials stay as they are)");
  this->ShowOnly->setToolTip("Draw only the picked label, in its material (the materials stay)");
  this->ShowAll->setToolTip("Draw every label the materials take again");
  buttons->addWidget(this->Hide);
  buttons->addWidget(this->ShowOnly);
  buttons->addWidget(this->ShowAll);
  l->addLayout(buttons);
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
  if (this->ViewWidget)
  {
    this->ViewWidget->installEventFilter(this);
    this->ViewWidget->setMouseTracking(true);
  }
}

bool pqCSGVPickPanel::eventFilter(QObject* watched, QEvent* event)
{
  if (watched == this->ViewWidget && this->Enabled->isChecked())
  {
    if (event->type() == QEvent::MouseButtonPress)
    {
      auto* e = static_cast<QMouseEvent*>(event);
      this->Pressed = e->button() == Qt::LeftButton;
      this->PressPos = e->pos();
    }
    else if (event->type() == QEvent::MouseButtonRelease && this->Pressed)
    {
      auto* e = static_cast<QMouseEvent*>(event);
      this->Pressed = false;
      if ((e->pos() - this->PressPos).manhattanLength() <= 3)
      {
        this->pickAt(e->pos());
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
    if (p.value("hit").toBool() &&
      (best.isEmpty() || p.value("depth").toDouble(1) < best.value("depth").toDouble(1)))
    {
      best = p;
      bestDisplay = dr->getProxy();
    }
  }
  this->Last = best;
  this->LastDisplay = bestDisplay;
  this->Hide->setEnabled(bestDisplay != nullptr);
  this->ShowOnly->setEnabled(bestDisplay != nullptr);
  if (!bestDisplay)
  {
    this->Result->setHtml(QString("<i>No opaque label at pixel (%1, %2).</i>").arg(x).arg(y));
    return false;
  }
  QString html = QString("<b>Label %1</b>").arg(qint64(best.value("label").toDouble()));
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
  vtkSMPropertyHelper(display, "CSGVMaterials").Set(text.toUtf8().constData());
  display->UpdateVTKObjects();
  END_UNDO_SET();
  if (this->View)
  {
    this->View->render();
  }
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
  vtkSMProxy* display = this->LastDisplay;
  if (!display)
  {
    if (pqDataRepresentation* r = pqActiveObjects::instance().activeRepresentation())
    {
      display = r->getProxy();
    }
  }
  this->editVisibility("Show all labels", display, pqCSGV::LabelVisibility::ShowAll);
}
