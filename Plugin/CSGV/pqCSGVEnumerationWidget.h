// SPDX-License-Identifier: MIT
/**
 * @class pqCSGVEnumerationWidget
 * @brief A drop-down for an enumeration whose pvpython names are short (panel_widget
 * "csgv_enumeration"): the GUI shows a label per entry from the property's hints, pvpython keeps
 * the EnumerationDomain's text.
 *
 * ParaView's own enumeration widget shows the domain's text, which is also the string pvpython
 * accepts (`display.CSGVShading = 'pt'`). Labels for people are given beside it:
 * `<Hints><CSGVEntryLabel text="pt" label="Path tracing"/>...</Hints>`; an entry without one
 * shows its text. Entries and their order come from the domain.
 */
#ifndef pqCSGVEnumerationWidget_h
#define pqCSGVEnumerationWidget_h

#include "pqPropertyWidget.h"

class QComboBox;

class pqCSGVEnumerationWidget : public pqPropertyWidget
{
  Q_OBJECT
  Q_PROPERTY(QString value READ value WRITE setValue NOTIFY valueChanged)
  typedef pqPropertyWidget Superclass;

public:
  pqCSGVEnumerationWidget(vtkSMProxy* proxy, vtkSMProperty* property, QWidget* parent = nullptr);
  ~pqCSGVEnumerationWidget() override;

  /// The entry's text in the domain: ParaView's property links read and write enumerations by
  /// their text, as pvpython does.
  QString value() const;
  void setValue(const QString& text);

Q_SIGNALS:
  void valueChanged();

private:
  QComboBox* Combo;
};

#endif
