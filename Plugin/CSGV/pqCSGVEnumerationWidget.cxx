// SPDX-License-Identifier: MIT
#include "pqCSGVEnumerationWidget.h"

#include <vtkPVXMLElement.h>
#include <vtkSMEnumerationDomain.h>
#include <vtkSMProperty.h>

#include <QComboBox>
#include <QHBoxLayout>

namespace
{
/// The label the property's hints give an entry's text, or the text itself.
QString entryLabel(vtkSMProperty* property, const char* text)
{
  vtkPVXMLElement* hints = property->GetHints();
  for (unsigned int i = 0; hints && i < hints->GetNumberOfNestedElements(); ++i)
  {
    vtkPVXMLElement* e = hints->GetNestedElement(i);
    if (QString(e->GetName()) == "CSGVEntryLabel" &&
        QString(e->GetAttributeOrEmpty("text")) == text && e->GetAttribute("label"))
    {
      return QString(e->GetAttribute("label"));
    }
  }
  return QString(text);
}
} // namespace

pqCSGVEnumerationWidget::pqCSGVEnumerationWidget(vtkSMProxy* proxy, vtkSMProperty* property,
                                                 QWidget* parent)
  : Superclass(proxy, parent)
  , Combo(new QComboBox(this))
{
  this->Combo->setObjectName("Combo");
  auto* layout = new QHBoxLayout(this);
  layout->setContentsMargins(0, 0, 0, 0);
  layout->addWidget(this->Combo);
  if (auto* domain = property->FindDomain<vtkSMEnumerationDomain>())
  {
    for (unsigned int i = 0; i < domain->GetNumberOfEntries(); ++i)
    {
      const char* text = domain->GetEntryText(i);
      this->Combo->addItem(entryLabel(property, text), QString(text));
      // The name pvpython uses, for users who script what they clicked.
      this->Combo->setItemData(int(i), QString("Python: '%1'").arg(text), Qt::ToolTipRole);
    }
  }
  connect(this->Combo, QOverload<int>::of(&QComboBox::activated), this,
          &pqCSGVEnumerationWidget::valueChanged);
  this->addPropertyLink(this, "value", SIGNAL(valueChanged()), property);
}

pqCSGVEnumerationWidget::~pqCSGVEnumerationWidget() = default;

QString pqCSGVEnumerationWidget::value() const
{
  return this->Combo->currentData().toString();
}

void pqCSGVEnumerationWidget::setValue(const QString& text)
{
  this->Combo->setCurrentIndex(this->Combo->findData(text));
}
