// SPDX-License-Identifier: MIT
/**
 * @class pqCSGVMaterialEditor
 * @brief The material editor of the Segmentation Volume representation: a property-group widget
 * (panel_widget "csgv_material_editor") over CSGVMaterials, CSGVAttributeFiles,
 * CSGVDerivedAttributes and CSGVComputedAttributes.
 *
 * It edits Core's material document (csgv/materials/Materials.h) and writes it into the same
 * server-manager properties pvpython sets (through pqPropertyLinks), so undo
 * and redo, state files and Python trace work and every edit shows at once (display properties
 * apply immediately). Attribute names and data ranges come from the rendering process through
 * misc/CSGVQuery, so the editor also works when the data lives on a pvserver; they are asked
 * again whenever an attribute property reaches it.
 *
 * Text and number boxes take effect when the user finishes (Enter or focus out), never
 * mid-word, and a box being typed in is not rewritten under the cursor. A material Core cannot
 * draw as it stands (csgv::materialProblem: a half-finished interval, an attribute the volume
 * lacks) stays in the document, is marked in the list and explained beside its details; the
 * representation leaves it out and draws the rest.
 *
 * Every widget has a stable objectName (for tests and recorded event files): materialList,
 * addMaterial, removeMaterial, duplicateMaterial, moveMaterialUp, moveMaterialDown,
 * materialName, filterAttribute, filterMin, filterMax, filterRange, colorMode, colorButton,
 * colorHex, colormapName, choosePreset, colorAttribute, colorMin, colorMax, colorRange,
 * wrapMode, opacity, emission, materialProblem, loadAttributes, clearAttributes, attributeFiles,
 * computedAttributes, derivedAttributes, applyDerived, refreshAttributes, exportColors, status.
 */
#ifndef pqCSGVMaterialEditor_h
#define pqCSGVMaterialEditor_h

#include "pqPropertyWidget.h"

#include "csgv/materials/Materials.h"

#include <vtkWeakPointer.h>

#include <cmath>

#include <QMap>
#include <QPair>
#include <QPointer>
#include <QStringList>

class QCheckBox;
class QComboBox;
class QDoubleSpinBox;
class QGroupBox;
class QLabel;
class QLineEdit;
class QListWidget;
class QPlainTextEdit;
class QPushButton;
class QTimer;
class QVBoxLayout;
class pqColorChooserButton;
class pqView;
class vtkObject;
class vtkSMPropertyGroup;

class pqCSGVMaterialEditor : public pqPropertyWidget
{
  Q_OBJECT
  Q_PROPERTY(QString materials READ materials WRITE setMaterials NOTIFY materialsChanged)
  Q_PROPERTY(QStringList attributeFiles READ attributeFiles WRITE setAttributeFiles NOTIFY
      attributeFilesChanged)
  Q_PROPERTY(QStringList derivedAttributes READ derivedAttributes WRITE setDerivedAttributes
      NOTIFY derivedAttributesChanged)
  typedef pqPropertyWidget Superclass;

public:
  pqCSGVMaterialEditor(vtkSMProxy* proxy, vtkSMPropertyGroup* group, QWidget* parent = nullptr);
  ~pqCSGVMaterialEditor() override;

  QString materials() const;
  QStringList attributeFiles() const { return this->Files; }
  QStringList derivedAttributes() const { return this->Derived; }
  /// Index of the material shown in the details (-1: none).
  int currentMaterial() const;
  /// Pushes the edits as pqPropertyWidget does, in an undo step named after the edit (the
  /// Properties panel applies later than the edit's own undo set: every step read "Property
  /// Changed", GUI pass 11).
  void apply() override;

public Q_SLOTS:
  void setMaterials(const QString& text);
  void setAttributeFiles(const QStringList& files);
  void setDerivedAttributes(const QStringList& pairs);
  /// Asks the rendering process for attribute names and ranges again.
  void refreshAttributes();

  void addMaterial();
  void removeMaterial();
  void duplicateMaterial();
  void moveMaterialUp();
  void moveMaterialDown();
  void loadAttributes();
  void clearAttributes();
  void choosePreset();
  void exportColors();
  /// Copies the materials of this data's Segmentation Volume in another view (a menu when
  /// several views show it), as one undoable edit.
  void copyMaterialsFromView();

Q_SIGNALS:
  void materialsChanged();
  void attributeFilesChanged();
  void derivedAttributesChanged();

protected:
  void showEvent(QShowEvent* e) override;

private Q_SLOTS:
  void selectionChanged();
  void detailsEdited();
  void colorChosen();
  void hexEdited();
  void applyDerived();

private:
  // The widgets, section by section (pqCSGVMaterialEditorLayout.cxx).
  void buildList(QVBoxLayout* top);
  QGroupBox* buildDetails();
  QGroupBox* buildAttributes();
  void connectDetails();
  void linkProperties(vtkSMProxy* proxy);

  void commit(const QString& undoLabel);
  void rebuildList(int select);
  void showDetails();
  void fillAttributeCombo(QComboBox* combo, const QString& current, bool numericOnly);
  void updateRanges();
  /// The data range of an attribute as the rendering process reported it; false when unknown.
  bool dataRange(const std::string& attribute, double& lo, double& hi) const;
  /// New intervals where the user switched attributes or colour mode: the data range of the
  /// attribute now named, so the material keeps drawing something sensible.
  void adoptDataRanges(const csgv::Material& old, csgv::Material& m) const;
  /// The range of `attribute` over the labels present that `old`'s filter holds (the
  /// representation's `span` query); false when none has a value.
  bool spanOfLabels(const csgv::Material& old, const std::string& attribute, double& lo, double& hi) const;
  /// After material `row` changed its filter attribute (Doc holds the new one, `old` the one
  /// before): label 0 (empty space) that no material drew before and the new interval takes (its
  /// value of the new attribute lies inside: the background filled the box) is hidden again with
  /// Core's hideLabel, a "hidden 0" material first. Returns the materials inserted before `row`.
  int keepLabelZeroEmpty(int row, const csgv::Material& old);
  /// csgv::materialProblem() with the attribute names the rendering process reported.
  QString problemOf(const csgv::Material& m) const;
  /// Observer of the representation: refreshes the attributes once an attribute property has
  /// been pushed to the rendering process (not before, when the query would miss it).
  void propertyPushed(vtkObject*, unsigned long, void* name);
  /// Observer of the representation: its data was updated (a new file, a reader's failure): the
  /// attributes and whether there is anything to draw are asked again.
  void dataUpdated(vtkObject*, unsigned long, void*);
  /// The view updated: at a time the attributes were not asked at, they are asked again.
  void viewUpdated();
  /// The view's time (NaN without a view).
  double viewTime() const;
  /// Shows an edit's message in the status line; it stays until the next message (a refresh
  /// clears only what a refresh said: StatusFromRefresh).
  void say(const QString& text);

  /// Core's document (its defaults and checks live there); the widgets edit it, commit() writes it.
  csgv::MaterialDocument Doc;
  bool DocValid = true;
  QString Text; ///< the property's text as last set or committed
  QString PendingUndo; ///< the name of the edit the next apply() pushes
  bool Shown = false; ///< a document was set (the first shows the display's last material)
  QStringList Files;
  QStringList Derived;
  /// Set by Apply derived: the next attribute refresh says what the derived attributes became.
  bool ReportDerived = false;
  /// name -> (numeric, [min, max]) from the rendering process
  QMap<QString, QPair<bool, QPair<double, double>>> Attributes;
  QStringList AttributeOrder;
  bool Updating = false;
  vtkWeakPointer<vtkSMProxy> Observed; ///< the proxy whose property pushes propertyPushed() sees
  unsigned long ObserverTag = 0;
  unsigned long DataObserverTag = 0;
  /// The view showing the representation, and its time at the last refresh: a change of time
  /// updates the view, not the representation (no UpdateDataEvent), yet may bring other data.
  QPointer<pqView> View;
  double RefreshedTime = std::nan("");
  bool StatusFromRefresh = false; ///< the status line shows what refreshAttributes found
  QTimer* RefreshTimer; ///< coalesces the refreshes several pushed properties ask for

  QListWidget* List;
  QPushButton *Add, *Remove, *Duplicate, *Up, *Down, *CopyFromView;
  QGroupBox* Details;
  QLineEdit* Name;
  QComboBox* FilterAttribute;
  QLineEdit *FilterMin, *FilterMax;
  QLabel* FilterRange;
  QComboBox* ColorMode;
  pqColorChooserButton* ColorButton;
  QLineEdit* ColorHex;
  QLineEdit* ColormapName;
  QPushButton* PresetButton;
  QComboBox* ColorAttribute;
  QLineEdit *ColorMin, *ColorMax;
  QLabel* ColorRange;
  QLabel* Problem;
  QComboBox* Wrap;
  QDoubleSpinBox* Opacity;
  QDoubleSpinBox* Emission;
  QLabel* FilesLabel;
  QCheckBox* Computed;
  QPlainTextEdit* DerivedEdit;
  QLabel* Status;
};

#endif
