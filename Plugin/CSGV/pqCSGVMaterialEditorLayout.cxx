// SPDX-License-Identifier: MIT
/// @file pqCSGVMaterialEditorLayout.cxx
/// @brief The material editor's widgets, section by section (the list and its buttons, the
/// selected material's details, the attributes), their signals and the property links. What the
/// widgets do is in pqCSGVMaterialEditor.cxx.
#include "pqCSGVMaterialEditor.h"

#include "pqCSGVMaterialDocument.h"

#include <pqApplicationCore.h>
#include <pqColorChooserButton.h>
#include <pqDataRepresentation.h>
#include <pqServerManagerModel.h>
#include <pqView.h>
#include <vtkCommand.h>
#include <vtkSMProperty.h>
#include <vtkSMProxy.h>

#include <QApplication>
#include <QCheckBox>
#include <QComboBox>
#include <QDoubleSpinBox>
#include <QDoubleValidator>
#include <QEvent>
#include <QFormLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QLabel>
#include <QLineEdit>
#include <QListWidget>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QTimer>
#include <QVBoxLayout>

namespace
{
// Combo-box entries in the order of Material::ColorMode and Material::Wrap.
const char* const kModes[] = { "constant", "colormap", "random" };
const char* const kWraps[] = { "clamp", "repeat" };

QPushButton* button(const QString& text, const char* name, const QString& tip, QWidget* parent)
{
  auto* b = new QPushButton(text, parent);
  b->setObjectName(name);
  b->setToolTip(tip);
  return b;
}

QLineEdit* numberEdit(const char* name, QWidget* parent)
{
  auto* e = new QLineEdit(parent);
  e->setObjectName(name);
  e->setValidator(new QDoubleValidator(e));
  return e;
}

/// A spin box that applies its value when the user finishes (Enter, focus out, the arrows), not
/// at each keystroke: "0.5" typed passes through "0" and "0.", and each of those would otherwise
/// be applied, rendered and reformatted under the cursor.
QDoubleSpinBox* numberBox(const char* name, double lo, double hi, double step, QWidget* parent)
{
  auto* b = new QDoubleSpinBox(parent);
  b->setObjectName(name);
  b->setRange(lo, hi);
  b->setSingleStep(step);
  b->setDecimals(3);
  b->setKeyboardTracking(false);
  return b;
}

/// @brief Keeps the mouse wheel from editing a field the user did not click: scrolling the
/// Properties panel over the editor changed a material's opacity (issue 38). A combo box or number
/// box takes the wheel only when it has focus, as ParaView's own widgets do; otherwise the event
/// goes on to the widgets around it, so the panel scrolls.
class WheelOnlyWhenFocused : public QObject
{
public:
  using QObject::QObject;

  /// Installs the guard on `w` and asks for focus by click or tab only (not by the wheel).
  static void guard(QWidget* w)
  {
    static WheelOnlyWhenFocused* filter = new WheelOnlyWhenFocused(qApp);
    w->setFocusPolicy(Qt::StrongFocus);
    w->installEventFilter(filter);
  }

protected:
  bool eventFilter(QObject* object, QEvent* event) override
  {
    auto* w = qobject_cast<QWidget*>(object);
    if (event->type() != QEvent::Wheel || !w || w->hasFocus())
    {
      return false;
    }
    // Qt hands a wheel event that a widget leaves up its parents: the panel's scroll area.
    if (QWidget* parent = w->parentWidget())
    {
      QCoreApplication::sendEvent(parent, event);
    }
    return true;
  }
};

} // namespace

pqCSGVMaterialEditor::pqCSGVMaterialEditor(vtkSMProxy* proxy, vtkSMPropertyGroup*, QWidget* parent)
  : Superclass(proxy, parent)
{
  this->setObjectName("CSGVMaterialEditor");
  this->setShowLabel(false);
  auto* top = new QVBoxLayout(this);
  top->setContentsMargins(0, 0, 0, 0);
  this->buildList(top);
  top->addWidget(this->buildDetails());
  top->addWidget(this->buildAttributes());
  this->Status = new QLabel(this);
  this->Status->setObjectName("status");
  this->Status->setWordWrap(true);
  top->addWidget(this->Status);

  this->connectDetails();

  this->RefreshTimer = new QTimer(this);
  this->RefreshTimer->setSingleShot(true);
  this->RefreshTimer->setInterval(0);
  connect(this->RefreshTimer, &QTimer::timeout, this, &pqCSGVMaterialEditor::refreshAttributes);
  // The property links push an edit only when the panel applies it (a queued changeFinished), so
  // a refresh right after the edit would ask the rendering process before the files reached it.
  // Refreshing when the representation's attribute properties are pushed sees them every time:
  // edits here, pvpython, undo and state files alike.
  if (vtkSMProxy* rep = pqCSGV::segmentationProxy(proxy))
  {
    this->Observed = rep;
    this->ObserverTag =
      rep->AddObserver(vtkCommand::UpdatePropertyEvent, this, &pqCSGVMaterialEditor::propertyPushed);
    this->DataObserverTag =
      rep->AddObserver(vtkCommand::UpdateDataEvent, this, &pqCSGVMaterialEditor::dataUpdated);
    // Another time step reaches the representation through the view's update alone: ParaView
    // fires the representation's UpdateDataEvent only when its own inputs changed (found by a GUI
    // pass: the data range of step 0 stayed beside step 1's labels).
    auto* shown = pqApplicationCore::instance()->getServerManagerModel()->findItem<pqDataRepresentation*>(proxy);
    this->View = shown ? shown->getView() : nullptr;
    if (this->View)
    {
      connect(this->View, &pqView::updateDataEvent, this, &pqCSGVMaterialEditor::viewUpdated);
    }
  }

  this->Doc = csgv::defaultMaterials();
  this->rebuildList(0);
  this->linkProperties(proxy);
}

void pqCSGVMaterialEditor::buildList(QVBoxLayout* top)
{
  // Material list and its buttons.
  this->List = new QListWidget(this);
  this->List->setObjectName("materialList");
  this->List->setMaximumHeight(120);
  top->addWidget(new QLabel("Materials (a label takes the first material whose filter holds it):", this));
  top->addWidget(this->List);
  auto* row = new QHBoxLayout();
  this->Add = button("Add", "addMaterial",
    "Add a material before the selected one, with its filter and look, so nothing changes until you edit it",
    this);
  this->Remove = button("Remove", "removeMaterial", "Remove the selected material", this);
  this->Duplicate = button("Duplicate", "duplicateMaterial", "Duplicate the selected material", this);
  this->Up = button("Up", "moveMaterialUp", "Move the selected material up (earlier wins)", this);
  this->Down = button("Down", "moveMaterialDown", "Move the selected material down", this);
  this->CopyFromView = button("From view...", "copyMaterials",
    "Copy the materials this data has in another view (materials are per view, as display properties are; "
    "attribute files and derived attributes are shared by every view)",
    this);
  // Two rows of three, so that the editor fits the Properties panel's default width.
  auto* second = new QHBoxLayout();
  for (QPushButton* b : { this->Add, this->Remove, this->Duplicate })
  {
    row->addWidget(b);
  }
  for (QPushButton* b : { this->Up, this->Down, this->CopyFromView })
  {
    second->addWidget(b);
  }
  top->addLayout(row);
  top->addLayout(second);
}

QGroupBox* pqCSGVMaterialEditor::buildDetails()
{
  // Details of the selected material.
  this->Details = new QGroupBox("Material", this);
  this->Details->setObjectName("materialDetails");
  auto* form = new QFormLayout(this->Details);
  this->Problem = new QLabel(this->Details);
  this->Problem->setObjectName("materialProblem");
  this->Problem->setWordWrap(true);
  this->Problem->setStyleSheet("color: #c00000");
  this->Problem->setVisible(false);
  this->Name = new QLineEdit(this->Details);
  this->Name->setObjectName("materialName");
  form->addRow("Name", this->Name);

  this->FilterAttribute = new QComboBox(this->Details);
  this->FilterAttribute->setObjectName("filterAttribute");
  form->addRow("Filter attribute", this->FilterAttribute);
  auto* fr = new QHBoxLayout();
  this->FilterMin = numberEdit("filterMin", this->Details);
  this->FilterMax = numberEdit("filterMax", this->Details);
  fr->addWidget(this->FilterMin);
  fr->addWidget(new QLabel("to", this->Details));
  fr->addWidget(this->FilterMax);
  form->addRow("Filter interval", fr);
  this->FilterRange = new QLabel(this->Details);
  this->FilterRange->setObjectName("filterRange");
  form->addRow("", this->FilterRange);

  this->ColorMode = new QComboBox(this->Details);
  this->ColorMode->setObjectName("colorMode");
  for (const char* m : kModes)
  {
    this->ColorMode->addItem(m);
  }
  form->addRow("Colour mode", this->ColorMode);
  auto* cr = new QHBoxLayout();
  this->ColorButton = new pqColorChooserButton(this->Details);
  this->ColorButton->setObjectName("colorButton");
  this->ColorHex = new QLineEdit(this->Details);
  this->ColorHex->setObjectName("colorHex");
  this->ColorHex->setPlaceholderText("#rrggbb");
  cr->addWidget(this->ColorButton);
  cr->addWidget(this->ColorHex);
  form->addRow("Colour", cr);
  auto* pr = new QHBoxLayout();
  this->ColormapName = new QLineEdit(this->Details);
  this->ColormapName->setObjectName("colormapName");
  this->ColormapName->setPlaceholderText("ParaView preset name");
  this->PresetButton = button("Choose...", "choosePreset", "Choose a ParaView colormap preset", this->Details);
  pr->addWidget(this->ColormapName);
  pr->addWidget(this->PresetButton);
  form->addRow("Colormap", pr);
  this->ColorAttribute = new QComboBox(this->Details);
  this->ColorAttribute->setObjectName("colorAttribute");
  form->addRow("Colour attribute", this->ColorAttribute);
  auto* ci = new QHBoxLayout();
  this->ColorMin = numberEdit("colorMin", this->Details);
  this->ColorMax = numberEdit("colorMax", this->Details);
  ci->addWidget(this->ColorMin);
  ci->addWidget(new QLabel("to", this->Details));
  ci->addWidget(this->ColorMax);
  form->addRow("Colour interval", ci);
  this->ColorRange = new QLabel(this->Details);
  this->ColorRange->setObjectName("colorRange");
  form->addRow("", this->ColorRange);
  this->Wrap = new QComboBox(this->Details);
  this->Wrap->setObjectName("wrapMode");
  for (const char* w : kWraps)
  {
    this->Wrap->addItem(w);
  }
  form->addRow("Wrap", this->Wrap);
  this->Opacity = numberBox("opacity", 0, 1, 0.05, this->Details);
  form->addRow("Opacity", this->Opacity);
  this->Emission = numberBox("emission", 0, 1000, 0.1, this->Details);
  form->addRow("Emission", this->Emission);
  // Last, so that a reason appearing while a field is typed in moves no field under the
  // pointer: the next click lands where the user aimed (issue 38).
  form->addRow(this->Problem);

  return this->Details;
}

QGroupBox* pqCSGVMaterialEditor::buildAttributes()
{
  // Attributes.
  auto* attrs = new QGroupBox("Attributes", this);
  attrs->setObjectName("attributesBox");
  auto* al = new QVBoxLayout(attrs);
  auto* ar = new QHBoxLayout();
  auto* load = button("Load attributes...", "loadAttributes",
    "Add a CSV, whitespace table or SQLite file of per-label attributes (read where the data is)", attrs);
  auto* clear = button("Clear", "clearAttributes", "Forget the loaded attribute files", attrs);
  auto* refresh = button("Refresh", "refreshAttributes", "Ask for attribute names and ranges again", attrs);
  ar->addWidget(load);
  ar->addWidget(clear);
  ar->addWidget(refresh);
  al->addLayout(ar);
  this->FilesLabel = new QLabel(attrs);
  this->FilesLabel->setObjectName("attributeFiles");
  this->FilesLabel->setWordWrap(true);
  al->addWidget(this->FilesLabel);
  this->Computed = new QCheckBox("Computed attributes", attrs);
  this->Computed->setToolTip("voxel_count, surface_area, bbox_min/max_x/y/z and centroid_x/y/z, computed from the "
                             "compressed volume once per volume");
  this->Computed->setObjectName("computedAttributes");
  connect(this->Computed, &QCheckBox::toggled, this, [this]() { this->PendingUndo = "Computed attributes"; });
  al->addWidget(this->Computed);
  auto* derivedLabel = new QLabel("Derived attributes, one per line: name = SQL expression", attrs);
  derivedLabel->setWordWrap(true);
  al->addWidget(derivedLabel);
  this->DerivedEdit = new QPlainTextEdit(attrs);
  this->DerivedEdit->setObjectName("derivedAttributes");
  this->DerivedEdit->setMaximumHeight(60);
  al->addWidget(this->DerivedEdit);
  auto* dr = new QHBoxLayout();
  auto* applyDerived = button("Apply derived", "applyDerived", "Set the derived attributes", attrs);
  auto* exportColors = button("Export colours", "exportColors",
    "Export colours to a lookup table of this data's own (categorical: the materials' colours and "
    "region names), given to the Slices and Thresholds of this data coloured by the label array",
    attrs);
  dr->addWidget(applyDerived);
  dr->addWidget(exportColors);
  al->addLayout(dr);
  connect(load, &QPushButton::clicked, this, &pqCSGVMaterialEditor::loadAttributes);
  connect(clear, &QPushButton::clicked, this, &pqCSGVMaterialEditor::clearAttributes);
  connect(refresh, &QPushButton::clicked, this, &pqCSGVMaterialEditor::refreshAttributes);
  connect(applyDerived, &QPushButton::clicked, this, &pqCSGVMaterialEditor::applyDerived);
  connect(exportColors, &QPushButton::clicked, this, &pqCSGVMaterialEditor::exportColors);
  return attrs;
}

void pqCSGVMaterialEditor::connectDetails()
{
  connect(this->List, &QListWidget::currentRowChanged, this, &pqCSGVMaterialEditor::selectionChanged);
  connect(this->Add, &QPushButton::clicked, this, &pqCSGVMaterialEditor::addMaterial);
  connect(this->Remove, &QPushButton::clicked, this, &pqCSGVMaterialEditor::removeMaterial);
  connect(this->Duplicate, &QPushButton::clicked, this, &pqCSGVMaterialEditor::duplicateMaterial);
  connect(this->Up, &QPushButton::clicked, this, &pqCSGVMaterialEditor::moveMaterialUp);
  connect(this->Down, &QPushButton::clicked, this, &pqCSGVMaterialEditor::moveMaterialDown);
  connect(this->CopyFromView, &QPushButton::clicked, this, &pqCSGVMaterialEditor::copyMaterialsFromView);
  for (QLineEdit* e : { this->Name, this->FilterMin, this->FilterMax, this->ColormapName,
         this->ColorMin, this->ColorMax })
  {
    connect(e, &QLineEdit::editingFinished, this, &pqCSGVMaterialEditor::detailsEdited);
  }
  for (QComboBox* c : { this->FilterAttribute, this->ColorMode, this->ColorAttribute, this->Wrap })
  {
    WheelOnlyWhenFocused::guard(c);
    connect(c, QOverload<int>::of(&QComboBox::currentIndexChanged), this,
      &pqCSGVMaterialEditor::detailsEdited);
  }
  for (QDoubleSpinBox* s : { this->Opacity, this->Emission })
  {
    WheelOnlyWhenFocused::guard(s);
    // Without keyboard tracking, valueChanged comes when the user finishes (numberBox()).
    connect(s, QOverload<double>::of(&QDoubleSpinBox::valueChanged), this,
      &pqCSGVMaterialEditor::detailsEdited);
  }
  connect(this->ColorButton, &pqColorChooserButton::chosenColorChanged, this,
    &pqCSGVMaterialEditor::colorChosen);
  connect(this->ColorHex, &QLineEdit::editingFinished, this, &pqCSGVMaterialEditor::hexEdited);
  connect(this->PresetButton, &QPushButton::clicked, this, &pqCSGVMaterialEditor::choosePreset);

}

void pqCSGVMaterialEditor::linkProperties(vtkSMProxy* proxy)
{
  if (vtkSMProperty* p = proxy->GetProperty("CSGVMaterials"))
  {
    this->addPropertyLink(this, "materials", SIGNAL(materialsChanged()), p);
  }
  if (vtkSMProperty* p = proxy->GetProperty("CSGVAttributeFiles"))
  {
    this->addPropertyLink(this, "attributeFiles", SIGNAL(attributeFilesChanged()), p);
  }
  if (vtkSMProperty* p = proxy->GetProperty("CSGVDerivedAttributes"))
  {
    this->addPropertyLink(this, "derivedAttributes", SIGNAL(derivedAttributesChanged()), p);
  }
  if (vtkSMProperty* p = proxy->GetProperty("CSGVComputedAttributes"))
  {
    this->addPropertyLink(this->Computed, "checked", SIGNAL(toggled(bool)), p);
  }
}
