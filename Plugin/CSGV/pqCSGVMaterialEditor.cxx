// SPDX-License-Identifier: MIT
#include "pqCSGVMaterialEditor.h"

#include "pqCSGVMaterialDocument.h"
#include "pqCSGVSharedAttributes.h"

#include <pqActiveObjects.h>
#include <pqApplicationCore.h>
#include <pqDataRepresentation.h>
#include <pqServerManagerModel.h>
#include <pqColorChooserButton.h>
#include <pqFileDialog.h>
#include <pqPresetDialog.h>
#include <pqServer.h>
#include <pqUndoStack.h>
#include <pqView.h>
#include <vtkCommand.h>
#include <vtkSMProperty.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMPropertyGroup.h>
#include <vtkSMProxy.h>
#include <vtk_jsoncpp.h>

#include <QHash>
#include <QCheckBox>
#include <QApplication>
#include <QComboBox>
#include <QEvent>
#include <QDoubleSpinBox>
#include <QDoubleValidator>
#include <QFileInfo>
#include <QFormLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QJsonArray>
#include <QJsonDocument>
#include <QJsonObject>
#include <QLabel>
#include <QLineEdit>
#include <QListWidget>
#include <QMenu>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QStyle>
#include <QTimer>
#include <QVBoxLayout>

#include <algorithm>
#include <cmath>
#include <map>
#include <cstring>
#include <utility>

namespace
{
using csgv::Material;
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

/// Shows a value in a line edit unless the user is typing in it (focused and changed since the
/// last commit): a refresh must not rewrite a half-typed number.
void showText(QLineEdit* e, const QString& text)
{
  if (!(e->hasFocus() && e->isModified()))
  {
    e->setText(text);
  }
}

/// The same for a spin box: while its text differs from its value, the user is typing.
void showValue(QDoubleSpinBox* b, double value)
{
  if (!(b->hasFocus() && b->text() != b->textFromValue(b->value())))
  {
    b->setValue(value);
  }
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

pqCSGVMaterialEditor::~pqCSGVMaterialEditor()
{
  if (this->Observed)
  {
    this->Observed->RemoveObserver(this->ObserverTag);
    this->Observed->RemoveObserver(this->DataObserverTag);
  }
}

void pqCSGVMaterialEditor::say(const QString& text)
{
  this->Status->setText(text);
  this->StatusFromRefresh = false;
}

void pqCSGVMaterialEditor::dataUpdated(vtkObject*, unsigned long, void*)
{
  this->RefreshTimer->start();
}

double pqCSGVMaterialEditor::viewTime() const
{
  return this->View ? vtkSMPropertyHelper(this->View->getProxy(), "ViewTime").GetAsDouble() : std::nan("");
}

void pqCSGVMaterialEditor::viewUpdated()
{
  const double now = this->viewTime();
  if (!(now == this->RefreshedTime))
  {
    this->RefreshTimer->start();
  }
}

void pqCSGVMaterialEditor::propertyPushed(vtkObject*, unsigned long, void* name)
{
  // UpdatePropertyEvent comes before the proxy sends the values: refresh from the event loop.
  const char* property = static_cast<const char*>(name);
  for (const char* attributes : { "CSGVAttributeFiles", "CSGVDerivedAttributes", "CSGVComputedAttributes" })
  {
    if (property && std::strcmp(property, attributes) == 0)
    {
      this->RefreshTimer->start();
    }
  }
}

QString pqCSGVMaterialEditor::materials() const
{
  return this->Text;
}

int pqCSGVMaterialEditor::currentMaterial() const
{
  return this->List->currentRow();
}

namespace
{
/// The material each display's editor showed last: ParaView makes a new editor whenever the
/// Properties panel rebuilds the display's section (the active source changing and back, as a
/// selection can make it), and the new one started at material 1 (GUI pass 11: after a pick the
/// Opacity and Colour the user was editing belonged to another material).
QHash<vtkSMProxy*, int>& lastRows()
{
  static QHash<vtkSMProxy*, int> rows;
  return rows;
}
} // namespace

void pqCSGVMaterialEditor::setMaterials(const QString& text)
{
  if (text == this->Text && !this->Text.isEmpty())
  {
    return;
  }
  const bool first = !this->Shown; // this editor's first document: the display's last material
  this->Shown = true;
  this->Text = text;
  QString error;
  this->Doc = pqCSGV::parseDocument(text, &error);
  this->DocValid = error.isEmpty();
  this->say(
    this->DocValid ? QString() : "The material document is not valid (" + error + "); editing starts from the default.");
  const int row = this->List->currentRow();
  this->rebuildList(first || row < 0 ? lastRows().value(this->proxy(), 0) : row);
}

void pqCSGVMaterialEditor::setAttributeFiles(const QStringList& files)
{
  if (files == this->Files)
  {
    return;
  }
  this->Files = files;
  showAttributeFiles(this->FilesLabel, files);
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
  this->RefreshTimer->start();
}

void pqCSGVMaterialEditor::refreshAttributes()
{
  if (!this->isVisible())
  {
    // Hidden (the display is shown as Outline, Surface...): nothing to ask the representation,
    // which may not even hold labels; showEvent refreshes.
    return;
  }
  this->RefreshedTime = this->viewTime();
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
  if (summary.value("empty").toBool())
  {
    // The output of a file that failed to read, or of a filter that produced nothing: the
    // materials stay editable for data to come, but the user learns why nothing is drawn.
    this->Status->setText(tr("The input is empty: there are no labels to draw. When a file "
                             "failed to read, the Output Messages say why."));
    this->StatusFromRefresh = true;
  }
  else if (!error.isEmpty())
  {
    this->Status->setText("Attributes: " + error);
    this->StatusFromRefresh = true;
  }
  else if (this->ReportDerived)
  {
    // Feedback for Apply derived: each attribute with what it holds (or that it is missing,
    // when its expression failed: the error above names why).
    QStringList parts;
    for (int i = 0; i + 1 < this->Derived.size(); i += 2)
    {
      const QString& name = this->Derived[i];
      const auto it = this->Attributes.constFind(name);
      if (it == this->Attributes.constEnd())
      {
        parts << name + " (not derived)";
      }
      else if (!it->first)
      {
        parts << name + " (text)";
      }
      else
      {
        parts << QString("%1 (%2 to %3)").arg(name).arg(it->second.first).arg(it->second.second);
      }
    }
    this->say(parts.isEmpty() ? QString("Derived attributes cleared")
                              : "Derived attributes applied: " + parts.join(", "));
  }
  else if (this->DocValid && this->StatusFromRefresh)
  {
    // What the last refresh said (an error, an empty input) no longer holds; what an edit said
    // (a colour that was not one, a copy, a hidden label 0) stays until the next one.
    this->say(QString());
  }
  this->ReportDerived = false;
  this->rebuildList(this->List->currentRow()); // which materials can be drawn may have changed
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
    const QString problem = this->problemOf(m);
    if (!problem.isEmpty())
    {
      text += "  (not drawn: " + problem + ")";
    }
    auto* item = new QListWidgetItem(text, this->List);
    if (!problem.isEmpty())
    {
      item->setIcon(this->style()->standardIcon(QStyle::SP_MessageBoxWarning));
      item->setForeground(QColor(192, 0, 0));
      item->setToolTip("Not drawn until fixed: " + problem);
    }
    else if (m.colorMode == Material::ColorMode::Constant)
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
  const QString problem = this->problemOf(m);
  this->Problem->setText("Not drawn until fixed: " + problem);
  this->Problem->setVisible(!problem.isEmpty());
  showText(this->Name, qstr(m.name));
  this->fillAttributeCombo(this->FilterAttribute, qstr(m.filterAttribute), true);
  showText(this->FilterMin, number(m.filterMin));
  showText(this->FilterMax, number(m.filterMax));
  this->ColorMode->setCurrentIndex(int(m.colorMode));
  const QColor color = qcolor(m.rgb);
  this->ColorButton->setChosenColor(color);
  showText(this->ColorHex, color.name());
  showText(this->ColormapName, m.colormap.points.empty() ? qstr(m.colormap.name) : "(control points)");
  this->fillAttributeCombo(this->ColorAttribute, qstr(m.colorAttribute), true);
  showText(this->ColorMin, number(m.colorMin));
  showText(this->ColorMax, number(m.colorMax));
  this->Wrap->setCurrentIndex(int(m.wrap));
  showValue(this->Opacity, m.opacity);
  showValue(this->Emission, m.emission);
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

bool pqCSGVMaterialEditor::dataRange(const std::string& attribute, double& lo, double& hi) const
{
  const QString name = qstr(attribute);
  if (!this->Attributes.contains(name))
  {
    return false;
  }
  lo = this->Attributes[name].second.first;
  hi = this->Attributes[name].second.second;
  return std::isfinite(lo) && std::isfinite(hi);
}

bool pqCSGVMaterialEditor::spanOfLabels(const Material& old, const std::string& attribute, double& lo, double& hi) const
{
  QJsonObject request;
  request["attribute"] = QString::fromStdString(attribute);
  request["filter"] = QString::fromStdString(old.filterAttribute);
  request["min"] = old.filterMin;
  request["max"] = old.filterMax;
  const QJsonObject span = pqCSGV::queryJson(
    this->proxy(), "span " + QString::fromUtf8(QJsonDocument(request).toJson(QJsonDocument::Compact)));
  if (!span.value("min").isDouble() || !span.value("max").isDouble())
  {
    return false; // no label had both, or no answer: the data range
  }
  lo = span.value("min").toDouble();
  hi = span.value("max").toDouble();
  return std::isfinite(lo) && std::isfinite(hi);
}

int pqCSGVMaterialEditor::keepLabelZeroEmpty(int row, const Material& old)
{
  // Label 0's value of each attribute the document names (the span of the labels [0, 0]: NaN
  // where label 0 is not in the volume or has no value).
  std::map<std::string, double> values;
  auto value = [&](const std::string& attribute) {
    if (attribute == "label")
    {
      return 0.0;
    }
    auto it = values.find(attribute);
    if (it == values.end())
    {
      Material zero;
      zero.filterAttribute = "label";
      zero.filterMin = 0;
      zero.filterMax = 0;
      double lo = 0, hi = 0;
      it = values.emplace(attribute, this->spanOfLabels(zero, attribute, lo, hi) ? lo : std::nan("")).first;
    }
    return it->second;
  };
  auto drawsZero = [&](const csgv::MaterialDocument& doc) {
    const csgv::MaterialDocument drawn = csgv::drawableMaterials(doc, nullptr, nullptr);
    const csgv::MaterialEvaluator e(drawn, [&](const std::string& a, uint32_t) { return value(a); });
    const int m = e.materialOf(0);
    return m >= 0 && drawn.materials[size_t(m)].opacity > 0;
  };
  csgv::MaterialDocument before = this->Doc;
  before.materials[size_t(row)] = old;
  if (drawsZero(before) || !drawsZero(this->Doc))
  {
    return 0;
  }
  const size_t count = this->Doc.materials.size();
  csgv::hideLabel(this->Doc, 0, value);
  const Material& now = this->Doc.materials[size_t(row) + (this->Doc.materials.size() - count)];
  this->say(QString("Label 0 (empty space) has %1 = %2, inside the new interval: the material "
                                "\"hidden 0\" first keeps it empty, as it was.")
                          .arg(QString::fromStdString(now.filterAttribute))
                          .arg(value(now.filterAttribute)));
  return int(this->Doc.materials.size() - count);
}

void pqCSGVMaterialEditor::adoptDataRanges(const Material& old, Material& m) const
{
  double lo = 0, hi = 0;
  if (m.filterAttribute != old.filterAttribute &&
    (this->spanOfLabels(old, m.filterAttribute, lo, hi) || this->dataRange(m.filterAttribute, lo, hi)))
  {
    // The old interval meant nothing for the new attribute: the new one spans the labels the
    // material took, so it keeps them while the user types its own (issue 38, item 5: taking the
    // whole data range showed every label in this material's colour mid-edit), and a material
    // that took every label takes the whole range. On `label`, 0 stays empty space as in Core's
    // default filter.
    m.filterMin = m.filterAttribute == "label" ? std::max(lo, Material().filterMin) : lo;
    m.filterMax = std::max(m.filterMin, hi);
  }
  const bool colormapNow = m.colorMode == Material::ColorMode::Colormap;
  const bool newColorInput = old.colorMode != Material::ColorMode::Colormap || m.colorAttribute != old.colorAttribute;
  if (colormapNow && newColorInput && this->dataRange(m.colorAttribute, lo, hi) && lo < hi)
  {
    m.colorMin = lo;
    m.colorMax = hi;
  }
}

QString pqCSGVMaterialEditor::problemOf(const Material& m) const
{
  // Until the rendering process has answered, attributes are not judged (nullptr).
  std::vector<std::string> known;
  for (const QString& n : this->AttributeOrder)
  {
    known.push_back(n.toStdString());
  }
  return qstr(csgv::materialProblem(m, known.empty() ? nullptr : &known));
}

void pqCSGVMaterialEditor::selectionChanged()
{
  if (!this->Updating)
  {
    if (this->List->currentRow() >= 0)
    {
      lastRows()[this->proxy()] = this->List->currentRow();
    }
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
  this->PendingUndo = undoLabel;
  BEGIN_UNDO_SET(undoLabel);
  Q_EMIT this->materialsChanged();
  END_UNDO_SET();
  if (pqView* v = this->view())
  {
    v->render();
  }
}

void pqCSGVMaterialEditor::apply()
{
  BEGIN_UNDO_SET(this->PendingUndo.isEmpty() ? QString("Property Changed") : this->PendingUndo);
  this->links().accept();
  END_UNDO_SET();
  this->PendingUndo.clear();
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
  this->adoptDataRanges(old, m);
  const bool newFilter = m.filterAttribute != old.filterAttribute;
  this->Doc.materials[i] = std::move(m);
  const int row = newFilter ? i + this->keepLabelZeroEmpty(i, old) : i;
  // What was typed is committed: showDetails() may now write the boxes in canonical form.
  for (QLineEdit* e : { this->Name, this->FilterMin, this->FilterMax, this->ColorHex, this->ColormapName,
         this->ColorMin, this->ColorMax })
  {
    e->setModified(false);
  }
  this->commit("Edit material");
  this->rebuildList(row);
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
    this->say("Not a colour: " + this->ColorHex->text());
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
  // Adding must not change the picture: the new material takes the filter and look of the one it
  // goes before, so it takes exactly the labels that one took, as they looked; editing it then
  // changes those labels. In an empty list nothing was drawn, so it starts transparent.
  Material m;
  if (at < int(mats.size()))
  {
    m = mats[at];
  }
  else
  {
    m.opacity = 0;
  }
  m.name = QString("material %1").arg(at + 1).toStdString();
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
  // Where the data lies (attribute tables usually lie beside it), not the working directory.
  pqFileDialog dialog(server, this, "Load per-label attributes", pqCSGV::dataFolder(this->proxy()),
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
  this->PendingUndo = "Load attributes";
  BEGIN_UNDO_SET("Load attributes");
  Q_EMIT this->attributeFilesChanged();
  END_UNDO_SET();
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
  this->PendingUndo = "Clear attributes";
  BEGIN_UNDO_SET("Clear attributes");
  Q_EMIT this->attributeFilesChanged();
  END_UNDO_SET();
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
  this->ReportDerived = true;
  this->PendingUndo = "Derived attributes";
  BEGIN_UNDO_SET("Derived attributes");
  Q_EMIT this->derivedAttributesChanged();
  END_UNDO_SET();
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
  this->say(message);
  if (pqView* v = this->view())
  {
    v->render();
  }
}

void pqCSGVMaterialEditor::copyMaterialsFromView()
{
  // The same data's Segmentation Volumes in other views, named by their view.
  pqServerManagerModel* model = pqApplicationCore::instance()->getServerManagerModel();
  QList<QPair<QString, vtkSMProxy*>> others;
  for (vtkSMProxy* other : pqCSGVSharedAttributes::siblings(this->proxy()))
  {
    auto* representation = model->findItem<pqDataRepresentation*>(other);
    pqView* view = representation ? representation->getView() : nullptr;
    if (view)
    {
      others << qMakePair(view->getSMName(), other);
    }
  }
  if (others.isEmpty())
  {
    this->say("No other view shows this data: show it in another view first.");
    return;
  }
  QPair<QString, vtkSMProxy*> from = others.front();
  if (others.size() > 1)
  {
    QMenu menu(this);
    menu.setObjectName("copyMaterialsMenu");
    for (int i = 0; i < others.size(); ++i)
    {
      menu.addAction(others[i].first)->setData(i);
    }
    QAction* chosen = menu.exec(this->CopyFromView->mapToGlobal(QPoint(0, this->CopyFromView->height())));
    if (!chosen)
    {
      return;
    }
    from = others[chosen->data().toInt()];
  }
  QString error;
  const csgv::MaterialDocument doc =
    pqCSGV::parseDocument(QString::fromUtf8(vtkSMPropertyHelper(from.second, "CSGVMaterials").GetAsString()), &error);
  if (!error.isEmpty())
  {
    this->say("The materials in " + from.first + " are not valid (" + error + "); nothing was copied.");
    return;
  }
  this->Doc = doc;
  this->DocValid = true;
  this->rebuildList(0);
  this->commit("Copy materials from " + from.first);
  this->say(QString("Copied %1 material(s) from %2.").arg(this->Doc.materials.size()).arg(from.first));
}
