// SPDX-License-Identifier: MIT
#include "pqCSGVMaterialEditor.h"

#include "pqCSGVMaterialDocument.h"

#include <pqActiveObjects.h>
#include <pqColorChooserButton.h>
#include <pqFileDialog.h>
#include <pqPresetDialog.h>
#include <pqServer.h>
#include <pqUndoStack.h>
#include <pqView.h>
#include <vtkSMProperty.h>
#include <vtkSMPropertyGroup.h>
#include <vtkSMProxy.h>
#include <vtk_jsoncpp.h>

#include <QCheckBox>
#include <QComboBox>
#include <QDoubleSpinBox>
#include <QDoubleValidator>
#include <QFileInfo>
#include <QFormLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QJsonArray>
#include <QLabel>
#include <QLineEdit>
#include <QListWidget>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QTimer>
#include <QVBoxLayout>

#include <algorithm>
#include <cmath>
#include <utility>

namespace
{
using csgv::Material;
// Combo-box entries in the order of Material::ColorMode and Material::Wrap.
const char* const kModes[] = { "constant", "colormap", "random" };
const char* const kWraps[] = { "clamp", "repeat" };
const char* const kDefaultColormap = "Viridis (matplotlib)";

QString qstr(const std::string& s)
{
  return QString::fromStdString(s);
}

QColor qcolor(const std::array<float, 3>& rgb)
{
  return QColor::fromRgbF(rgb[0], rgb[1], rgb[2]);
}

QString number(double v)
{
  return QString::number(v, 'g', 12);
}

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
/// The attribute files by file name (the full paths in the tooltip): wherever the list changes,
/// the label reads the same.
void showAttributeFiles(QLabel* label, const QStringList& files)
{
  QStringList names;
  for (const QString& f : files)
  {
    names << QFileInfo(f).fileName();
  }
  label->setText(files.isEmpty() ? "No attribute files" : "Files: " + names.join(", "));
  label->setToolTip(files.join("\n"));
}

} // namespace

pqCSGVMaterialEditor::pqCSGVMaterialEditor(vtkSMProxy* proxy, vtkSMPropertyGroup*, QWidget* parent)
  : Superclass(proxy, parent)
{
  this->setObjectName("CSGVMaterialEditor");
  this->setShowLabel(false);
  auto* top = new QVBoxLayout(this);
  top->setContentsMargins(0, 0, 0, 0);

  // Material list and its buttons.
  this->List = new QListWidget(this);
  this->List->setObjectName("materialList");
  this->List->setMaximumHeight(120);
  top->addWidget(new QLabel("Materials (a label takes the first material whose filter holds it):", this));
  top->addWidget(this->List);
  auto* row = new QHBoxLayout();
  this->Add = button("Add", "addMaterial", "Add a material before the selected one", this);
  this->Remove = button("Remove", "removeMaterial", "Remove the selected material", this);
  this->Duplicate = button("Duplicate", "duplicateMaterial", "Duplicate the selected material", this);
  this->Up = button("Up", "moveMaterialUp", "Move the selected material up (earlier wins)", this);
  this->Down = button("Down", "moveMaterialDown", "Move the selected material down", this);
  for (QPushButton* b : { this->Add, this->Remove, this->Duplicate, this->Up, this->Down })
  {
    row->addWidget(b);
  }
  top->addLayout(row);

  // Details of the selected material.
  this->Details = new QGroupBox("Material", this);
  this->Details->setObjectName("materialDetails");
  auto* form = new QFormLayout(this->Details);
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
  this->Opacity = new QDoubleSpinBox(this->Details);
  this->Opacity->setObjectName("opacity");
  this->Opacity->setRange(0, 1);
  this->Opacity->setSingleStep(0.05);
  this->Opacity->setDecimals(3);
  form->addRow("Opacity", this->Opacity);
  this->Emission = new QDoubleSpinBox(this->Details);
  this->Emission->setObjectName("emission");
  this->Emission->setRange(0, 1000);
  this->Emission->setSingleStep(0.1);
  this->Emission->setDecimals(3);
  form->addRow("Emission", this->Emission);
  top->addWidget(this->Details);

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
  this->Computed = new QCheckBox("Computed attributes (voxel count, surface area, bbox, centroid)", attrs);
  this->Computed->setObjectName("computedAttributes");
  al->addWidget(this->Computed);
  al->addWidget(new QLabel("Derived attributes, one per line: name = SQL expression", attrs));
  this->DerivedEdit = new QPlainTextEdit(attrs);
  this->DerivedEdit->setObjectName("derivedAttributes");
  this->DerivedEdit->setMaximumHeight(60);
  al->addWidget(this->DerivedEdit);
  auto* dr = new QHBoxLayout();
  auto* applyDerived = button("Apply derived", "applyDerived", "Set the derived attributes", attrs);
  auto* exportColors = button("Export colours to lookup table", "exportColors",
    "Make the label array's lookup table categorical with the materials' colours and region names, "
    "so Slice and Threshold show the same colours",
    attrs);
  dr->addWidget(applyDerived);
  dr->addWidget(exportColors);
  al->addLayout(dr);
  top->addWidget(attrs);
  this->Status = new QLabel(this);
  this->Status->setObjectName("status");
  this->Status->setWordWrap(true);
  top->addWidget(this->Status);

  connect(this->List, &QListWidget::currentRowChanged, this, &pqCSGVMaterialEditor::selectionChanged);
  connect(this->Add, &QPushButton::clicked, this, &pqCSGVMaterialEditor::addMaterial);
  connect(this->Remove, &QPushButton::clicked, this, &pqCSGVMaterialEditor::removeMaterial);
  connect(this->Duplicate, &QPushButton::clicked, this, &pqCSGVMaterialEditor::duplicateMaterial);
  connect(this->Up, &QPushButton::clicked, this, &pqCSGVMaterialEditor::moveMaterialUp);
  connect(this->Down, &QPushButton::clicked, this, &pqCSGVMaterialEditor::moveMaterialDown);
  for (QLineEdit* e : { this->Name, this->FilterMin, this->FilterMax, this->ColormapName,
         this->ColorMin, this->ColorMax })
  {
    connect(e, &QLineEdit::editingFinished, this, &pqCSGVMaterialEditor::detailsEdited);
  }
  for (QComboBox* c : { this->FilterAttribute, this->ColorMode, this->ColorAttribute, this->Wrap })
  {
    connect(c, QOverload<int>::of(&QComboBox::currentIndexChanged), this,
      &pqCSGVMaterialEditor::detailsEdited);
  }
  for (QDoubleSpinBox* s : { this->Opacity, this->Emission })
  {
    connect(s, QOverload<double>::of(&QDoubleSpinBox::valueChanged), this,
      &pqCSGVMaterialEditor::detailsEdited);
  }
  connect(this->ColorButton, &pqColorChooserButton::chosenColorChanged, this,
    &pqCSGVMaterialEditor::colorChosen);
  connect(this->ColorHex, &QLineEdit::editingFinished, this, &pqCSGVMaterialEditor::hexEdited);
  connect(this->PresetButton, &QPushButton::clicked, this, &pqCSGVMaterialEditor::choosePreset);
  connect(load, &QPushButton::clicked, this, &pqCSGVMaterialEditor::loadAttributes);
  connect(clear, &QPushButton::clicked, this, &pqCSGVMaterialEditor::clearAttributes);
  connect(refresh, &QPushButton::clicked, this, &pqCSGVMaterialEditor::refreshAttributes);
  connect(applyDerived, &QPushButton::clicked, this, &pqCSGVMaterialEditor::applyDerived);
  connect(exportColors, &QPushButton::clicked, this, &pqCSGVMaterialEditor::exportColors);

  this->Doc = csgv::defaultMaterials();
  this->rebuildList(0);
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
    connect(this->Computed, &QCheckBox::toggled, this,
      [this]() { QTimer::singleShot(0, this, &pqCSGVMaterialEditor::refreshAttributes); });
  }
}

pqCSGVMaterialEditor::~pqCSGVMaterialEditor() = default;

QString pqCSGVMaterialEditor::materials() const
{
  return this->Text;
}

int pqCSGVMaterialEditor::currentMaterial() const
{
  return this->List->currentRow();
}

void pqCSGVMaterialEditor::setMaterials(const QString& text)
{
  if (text == this->Text && !this->Text.isEmpty())
  {
    return;
  }
  this->Text = text;
  QString error;
  this->Doc = pqCSGV::parseDocument(text, &error);
  this->DocValid = error.isEmpty();
  this->Status->setText(
    this->DocValid ? QString() : "The material document is not valid (" + error + "); editing starts from the default.");
  const int row = this->List->currentRow();
  this->rebuildList(row < 0 ? 0 : row);
}

void pqCSGVMaterialEditor::setAttributeFiles(const QStringList& files)
{
  if (files == this->Files)
  {
    return;
  }
  this->Files = files;
  showAttributeFiles(this->FilesLabel, files);
  QTimer::singleShot(0, this, &pqCSGVMaterialEditor::refreshAttributes);
}

void pqCSGVMaterialEditor::setDerivedAttributes(const QStringList& pairs)
{
  if (pairs == this->Derived)
  {
    return;
  }
  this->Derived = pairs;
  QStringList lines;
  for (int i = 0; i + 1 < pairs.size(); i += 2)
  {
    lines << pairs[i] + " = " + pairs[i + 1];
  }
  this->DerivedEdit->setPlainText(lines.join("\n"));
  QTimer::singleShot(0, this, &pqCSGVMaterialEditor::refreshAttributes);
}

void pqCSGVMaterialEditor::showEvent(QShowEvent* e)
{
  this->Superclass::showEvent(e);
  if (qEnvironmentVariableIsSet("CSGV_PRINT_WIDGET_PATH"))
  {
    // The object path event files use (objectNames from the main window down).
    QStringList path;
    for (QObject* o = this; o; o = o->parent())
    {
      path.prepend(o->objectName().isEmpty() ? QString("<%1>").arg(o->metaObject()->className())
                                             : o->objectName());
    }
    qInfo("csgv widget path: %s", qPrintable(path.join('/')));
  }
  QTimer::singleShot(0, this, &pqCSGVMaterialEditor::refreshAttributes);
}

void pqCSGVMaterialEditor::refreshAttributes()
{
  const QJsonObject summary = pqCSGV::queryJson(this->proxy(), "summary");
  this->Attributes.clear();
  this->AttributeOrder.clear();
  for (const QJsonValue& v : summary.value("attributes").toArray())
  {
    const QJsonObject a = v.toObject();
    const QString name = a.value("name").toString();
    const double lo = a.value("min").isDouble() ? a.value("min").toDouble() : std::nan("");
    const double hi = a.value("max").isDouble() ? a.value("max").toDouble() : std::nan("");
    this->Attributes[name] = qMakePair(a.value("numeric").toBool(), qMakePair(lo, hi));
    this->AttributeOrder << name;
  }
  const QString error = summary.value("error").toString();
  if (!error.isEmpty() && error != "the input is empty")
  {
    this->Status->setText("Attributes: " + error);
  }
  else if (this->DocValid)
  {
    this->Status->setText(QString());
  }
  this->showDetails();
}

void pqCSGVMaterialEditor::fillAttributeCombo(QComboBox* combo, const QString& current, bool numericOnly)
{
  QStringList names;
  for (const QString& n : this->AttributeOrder)
  {
    if (!numericOnly || this->Attributes[n].first)
    {
      names << n;
    }
  }
  if (!names.contains("label"))
  {
    names.prepend("label");
  }
  if (!current.isEmpty() && !names.contains(current))
  {
    names << current; // named by the document, not (yet) known: keep it visible
  }
  combo->clear();
  combo->addItems(names);
  combo->setCurrentText(current.isEmpty() ? "label" : current);
}

void pqCSGVMaterialEditor::rebuildList(int select)
{
  const bool was = this->Updating;
  this->Updating = true;
  this->List->clear();
  const int count = int(this->Doc.materials.size());
  for (int i = 0; i < count; ++i)
  {
    const Material& m = this->Doc.materials[i];
    QString text = QString("%1. %2  [%3 %4..%5]")
                     .arg(i + 1)
                     .arg(qstr(m.name))
                     .arg(qstr(m.filterAttribute))
                     .arg(number(m.filterMin))
                     .arg(number(m.filterMax));
    auto* item = new QListWidgetItem(text, this->List);
    if (m.colorMode == Material::ColorMode::Constant)
    {
      QPixmap px(12, 12);
      px.fill(qcolor(m.rgb));
      item->setIcon(QIcon(px));
    }
  }
  if (count > 0)
  {
    this->List->setCurrentRow(std::max(0, std::min(select, count - 1)));
  }
  this->Updating = was;
  this->showDetails();
}

void pqCSGVMaterialEditor::showDetails()
{
  const int i = this->List->currentRow();
  const int count = int(this->Doc.materials.size());
  const bool valid = i >= 0 && i < count;
  this->Details->setEnabled(valid);
  this->Remove->setEnabled(valid);
  this->Duplicate->setEnabled(valid);
  this->Up->setEnabled(valid && i > 0);
  this->Down->setEnabled(valid && i + 1 < count);
  if (!valid)
  {
    return;
  }
  const bool was = this->Updating;
  this->Updating = true;
  const Material& m = this->Doc.materials[i];
  this->Details->setTitle(QString("Material %1").arg(i + 1));
  this->Name->setText(qstr(m.name));
  this->fillAttributeCombo(this->FilterAttribute, qstr(m.filterAttribute), true);
  this->FilterMin->setText(number(m.filterMin));
  this->FilterMax->setText(number(m.filterMax));
  this->ColorMode->setCurrentIndex(int(m.colorMode));
  const QColor color = qcolor(m.rgb);
  this->ColorButton->setChosenColor(color);
  this->ColorHex->setText(color.name());
  this->ColormapName->setText(m.colormap.points.empty() ? qstr(m.colormap.name) : "(control points)");
  this->fillAttributeCombo(this->ColorAttribute, qstr(m.colorAttribute), true);
  this->ColorMin->setText(number(m.colorMin));
  this->ColorMax->setText(number(m.colorMax));
  this->Wrap->setCurrentIndex(int(m.wrap));
  this->Opacity->setValue(m.opacity);
  this->Emission->setValue(m.emission);
  const bool constant = m.colorMode == Material::ColorMode::Constant;
  const bool colormap = m.colorMode == Material::ColorMode::Colormap;
  this->ColorButton->setEnabled(constant);
  this->ColorHex->setEnabled(constant);
  this->ColormapName->setEnabled(!constant);
  this->PresetButton->setEnabled(!constant);
  this->ColorAttribute->setEnabled(colormap);
  this->ColorMin->setEnabled(colormap);
  this->ColorMax->setEnabled(colormap);
  this->Wrap->setEnabled(colormap);
  this->updateRanges();
  this->Updating = was;
}

void pqCSGVMaterialEditor::updateRanges()
{
  auto rangeText = [this](const QString& name) {
    if (!this->Attributes.contains(name))
    {
      return QString("data range: unknown (not on the server yet)");
    }
    const auto r = this->Attributes[name].second;
    if (std::isnan(r.first))
    {
      return QString("data range: no values");
    }
    return QString("data range: %1 .. %2").arg(number(r.first), number(r.second));
  };
  this->FilterRange->setText(rangeText(this->FilterAttribute->currentText()));
  this->ColorRange->setText(rangeText(this->ColorAttribute->currentText()));
}

void pqCSGVMaterialEditor::selectionChanged()
{
  if (!this->Updating)
  {
    this->showDetails();
  }
}

void pqCSGVMaterialEditor::commit(const QString& undoLabel)
{
  const QString text = pqCSGV::serialize(this->Doc);
  if (text == this->Text)
  {
    return;
  }
  this->Text = text;
  this->DocValid = true;
  BEGIN_UNDO_SET(undoLabel);
  Q_EMIT this->materialsChanged();
  END_UNDO_SET();
  if (pqView* v = this->view())
  {
    v->render();
  }
}

void pqCSGVMaterialEditor::detailsEdited()
{
  if (this->Updating)
  {
    return;
  }
  const int i = this->List->currentRow();
  if (i < 0 || i >= int(this->Doc.materials.size()))
  {
    return;
  }
  // A fresh material from the widgets: what the mode does not use takes Core's defaults, and a
  // field that does not read as a number falls back to its default too.
  const Material old = this->Doc.materials[i];
  Material m;
  auto numberOr = [](QLineEdit* e, double fallback) {
    bool ok = false;
    const double v = e->text().toDouble(&ok);
    return ok ? v : fallback;
  };
  auto attributeOf = [](QComboBox* c) {
    return c->currentText().isEmpty() ? std::string("label") : c->currentText().toStdString();
  };
  m.name = this->Name->text().toStdString();
  m.filterAttribute = attributeOf(this->FilterAttribute);
  m.filterMin = numberOr(this->FilterMin, m.filterMin);
  m.filterMax = numberOr(this->FilterMax, m.filterMax);
  m.colorMode = Material::ColorMode(std::max(0, this->ColorMode->currentIndex()));
  if (m.colorMode == Material::ColorMode::Constant)
  {
    const QColor col = this->ColorButton->chosenColor();
    m.rgb = { float(col.redF()), float(col.greenF()), float(col.blueF()) };
  }
  else
  {
    const QString name = this->ColormapName->text().trimmed();
    if (name == "(control points)" && !old.colormap.empty())
    {
      m.colormap = old.colormap;
    }
    else if (!name.isEmpty())
    {
      m.colormap.name = name.toStdString();
    }
    else if (m.colorMode == Material::ColorMode::Colormap)
    {
      m.colormap.name = kDefaultColormap; // a colormap colour needs one
    }
    if (m.colorMode == Material::ColorMode::Colormap)
    {
      m.colorAttribute = attributeOf(this->ColorAttribute);
      m.colorMin = numberOr(this->ColorMin, m.colorMin);
      m.colorMax = numberOr(this->ColorMax, m.colorMax);
      m.wrap = Material::Wrap(std::max(0, this->Wrap->currentIndex()));
    }
  }
  m.opacity = float(this->Opacity->value());
  m.emission = float(this->Emission->value());
  this->Doc.materials[i] = std::move(m);
  this->commit("Edit material");
  this->rebuildList(i);
}

void pqCSGVMaterialEditor::colorChosen()
{
  if (this->Updating)
  {
    return;
  }
  this->ColorHex->setText(this->ColorButton->chosenColor().name());
  this->detailsEdited();
}

void pqCSGVMaterialEditor::hexEdited()
{
  if (this->Updating)
  {
    return;
  }
  const QColor c(this->ColorHex->text().trimmed());
  if (!c.isValid())
  {
    this->Status->setText("Not a colour: " + this->ColorHex->text());
    return;
  }
  const bool was = this->Updating;
  this->Updating = true;
  this->ColorButton->setChosenColor(c);
  this->Updating = was;
  this->detailsEdited();
}

void pqCSGVMaterialEditor::addMaterial()
{
  std::vector<Material>& mats = this->Doc.materials;
  const int at = std::min(std::max(0, this->List->currentRow()), int(mats.size()));
  // Core's default material (every non-zero label, opaque), but constant white, so the new one
  // is easy to tell apart from the random colours it overrides.
  Material m;
  m.name = QString("material %1").arg(mats.size() + 1).toStdString();
  m.colorMode = Material::ColorMode::Constant;
  mats.insert(mats.begin() + at, m);
  this->commit("Add material");
  this->rebuildList(at);
}

void pqCSGVMaterialEditor::removeMaterial()
{
  std::vector<Material>& mats = this->Doc.materials;
  const int i = this->List->currentRow();
  if (i < 0 || i >= int(mats.size()))
  {
    return;
  }
  mats.erase(mats.begin() + i);
  this->commit("Remove material");
  this->rebuildList(i);
}

void pqCSGVMaterialEditor::duplicateMaterial()
{
  std::vector<Material>& mats = this->Doc.materials;
  const int i = this->List->currentRow();
  if (i < 0 || i >= int(mats.size()))
  {
    return;
  }
  Material copy = mats[i];
  copy.name += " copy";
  mats.insert(mats.begin() + i + 1, copy);
  this->commit("Duplicate material");
  this->rebuildList(i + 1);
}

void pqCSGVMaterialEditor::moveMaterialUp()
{
  std::vector<Material>& mats = this->Doc.materials;
  const int i = this->List->currentRow();
  if (i <= 0 || i >= int(mats.size()))
  {
    return;
  }
  std::swap(mats[i], mats[i - 1]);
  this->commit("Move material");
  this->rebuildList(i - 1);
}

void pqCSGVMaterialEditor::moveMaterialDown()
{
  std::vector<Material>& mats = this->Doc.materials;
  const int i = this->List->currentRow();
  if (i < 0 || i + 1 >= int(mats.size()))
  {
    return;
  }
  std::swap(mats[i], mats[i + 1]);
  this->commit("Move material");
  this->rebuildList(i + 1);
}

void pqCSGVMaterialEditor::loadAttributes()
{
  pqServer* server = pqActiveObjects::instance().activeServer();
  pqFileDialog dialog(server, this, "Load per-label attributes", QString(),
    "Attribute tables (*.csv *.tsv *.txt *.db3 *.sqlite *.sqlite3 *.db);;All files (*)");
  dialog.setObjectName("CSGVAttributeFileDialog");
  dialog.setFileMode(pqFileDialog::ExistingFiles);
  if (dialog.exec() != QDialog::Accepted)
  {
    return;
  }
  QStringList files = this->Files;
  for (const QString& f : dialog.getSelectedFiles())
  {
    if (!files.contains(f))
    {
      files << f;
    }
  }
  this->Files = files;
  showAttributeFiles(this->FilesLabel, files);
  BEGIN_UNDO_SET("Load attributes");
  Q_EMIT this->attributeFilesChanged();
  END_UNDO_SET();
  this->refreshAttributes();
  if (pqView* v = this->view())
  {
    v->render();
  }
}

void pqCSGVMaterialEditor::clearAttributes()
{
  if (this->Files.isEmpty())
  {
    return;
  }
  this->Files.clear();
  showAttributeFiles(this->FilesLabel, this->Files);
  BEGIN_UNDO_SET("Clear attributes");
  Q_EMIT this->attributeFilesChanged();
  END_UNDO_SET();
  this->refreshAttributes();
}

void pqCSGVMaterialEditor::applyDerived()
{
  QStringList pairs;
  for (const QString& line : this->DerivedEdit->toPlainText().split('\n'))
  {
    const int eq = line.indexOf('=');
    if (eq <= 0)
    {
      continue;
    }
    pairs << line.left(eq).trimmed() << line.mid(eq + 1).trimmed();
  }
  if (pairs == this->Derived)
  {
    return;
  }
  this->Derived = pairs;
  BEGIN_UNDO_SET("Derived attributes");
  Q_EMIT this->derivedAttributesChanged();
  END_UNDO_SET();
  this->refreshAttributes();
  if (pqView* v = this->view())
  {
    v->render();
  }
}

void pqCSGVMaterialEditor::choosePreset()
{
  pqPresetDialog dialog(this, pqPresetDialog::SHOW_NON_INDEXED_COLORS_ONLY);
  dialog.setObjectName("CSGVPresetDialog");
  dialog.setCustomizableLoadAnnotations(false);
  dialog.setCustomizableLoadOpacities(false);
  dialog.setCustomizableUsePresetRange(false);
  const QString current = this->ColormapName->text();
  if (!current.isEmpty())
  {
    dialog.setCurrentPreset(current.toUtf8().constData());
  }
  connect(&dialog, &pqPresetDialog::applyPreset, this, [this](const Json::Value& preset) {
    if (preset.isMember("Name"))
    {
      this->ColormapName->setText(QString::fromStdString(preset["Name"].asString()));
      if (this->ColorMode->currentText() == "constant")
      {
        this->ColorMode->setCurrentText("colormap"); // detailsEdited() runs from the combo
      }
      else
      {
        this->detailsEdited();
      }
    }
  });
  dialog.exec();
}

void pqCSGVMaterialEditor::exportColors()
{
  BEGIN_UNDO_SET("Export label colours");
  const QString message = pqCSGV::exportLabelColors(this->proxy());
  END_UNDO_SET();
  this->Status->setText(message);
  if (pqView* v = this->view())
  {
    v->render();
  }
}
