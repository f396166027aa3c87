// SPDX-License-Identifier: MIT
#include "pqCSGVLabelArrayWidget.h"

#include "CSGVAdapter.h"

#include <pqApplicationCore.h>
#include <pqPipelineSource.h>
#include <pqServerManagerModel.h>
#include <vtkDataObject.h>
#include <vtkPVArrayInformation.h>
#include <vtkPVDataInformation.h>
#include <vtkPVDataSetAttributesInformation.h>
#include <vtkPVXMLElement.h>
#include <vtkSMProperty.h>
#include <vtkSMPropertyHelper.h>
#include <vtkSMSourceProxy.h>
#include <vtkType.h>

#include <QComboBox>
#include <QHBoxLayout>

#include <algorithm>

namespace
{
vtkPVDataInformation* inputInformation(vtkSMProxy* display)
{
  if (!display || !display->GetProperty("Input"))
  {
    return nullptr;
  }
  vtkSMPropertyHelper input(display, "Input");
  auto* source = vtkSMSourceProxy::SafeDownCast(input.GetAsProxy());
  return source ? source->GetDataInformation(input.GetOutputPort()) : nullptr;
}

bool isIntegerType(int type)
{
  switch (type)
  {
    case VTK_CHAR:
    case VTK_SIGNED_CHAR:
    case VTK_UNSIGNED_CHAR:
    case VTK_SHORT:
    case VTK_UNSIGNED_SHORT:
    case VTK_INT:
    case VTK_UNSIGNED_INT:
    case VTK_LONG:
    case VTK_UNSIGNED_LONG:
    case VTK_LONG_LONG:
    case VTK_UNSIGNED_LONG_LONG:
    case VTK_ID_TYPE:
      return true;
    default:
      return false;
  }
}

bool isFloatType(int type)
{
  return type == VTK_FLOAT || type == VTK_DOUBLE;
}

const QString kNotInInput = QStringLiteral(" (not in the input)");
} // namespace

pqCSGVLabelArrayWidget::pqCSGVLabelArrayWidget(vtkSMProxy* proxy, vtkSMProperty* property,
                                               QWidget* parent)
  : Superclass(proxy, parent)
  , Combo(new QComboBox(this))
{
  this->Combo->setObjectName("LabelArrayCombo");
  this->AutomaticTip =
    tr("The CSGV encoding when the input has one, else the first integer array (cell data first)");
  vtkPVXMLElement* hints = property->GetHints();
  if (vtkPVXMLElement* e = hints ? hints->FindNestedElementByName("CSGVLabelArrays") : nullptr)
  {
    this->Floats = QString(e->GetAttributeOrEmpty("floats")) == "1";
    if (e->GetAttribute("automatic"))
    {
      this->AutomaticTip = QString(e->GetAttribute("automatic"));
    }
  }
  this->Combo->setSizeAdjustPolicy(QComboBox::AdjustToMinimumContentsLengthWithIcon);
  auto* layout = new QHBoxLayout(this);
  layout->setContentsMargins(0, 0, 0, 0);
  layout->addWidget(this->Combo);
  this->refill();
  connect(this->Combo, QOverload<int>::of(&QComboBox::activated), this,
          &pqCSGVLabelArrayWidget::labelArrayChanged);
  this->addPropertyLink(this, "labelArray", SIGNAL(labelArrayChanged()), property);
  connectInputUpdates(proxy, this, SLOT(refill()));
}

pqCSGVLabelArrayWidget::~pqCSGVLabelArrayWidget() = default;

QString pqCSGVLabelArrayWidget::labelArray() const
{
  // An empty, not a null, string: ParaView's property links drop null strings.
  const QString name = this->Combo->currentData().toString();
  return name.isNull() ? QStringLiteral("") : name;
}

void pqCSGVLabelArrayWidget::setLabelArray(const QString& name)
{
  int index = this->Combo->findData(name);
  if (index < 0)
  {
    this->Combo->addItem(name + kNotInInput, name);
    index = this->Combo->count() - 1;
  }
  this->Combo->setCurrentIndex(index);
}

void pqCSGVLabelArrayWidget::refill()
{
  const QString current = this->labelArray();
  const QSignalBlocker blocker(this->Combo);
  this->Combo->clear();
  this->Combo->addItem(tr("(automatic)"), QStringLiteral(""));
  this->Combo->setItemData(0, this->AutomaticTip, Qt::ToolTipRole);
  for (const auto& array : labelArrays(this->proxy(), this->Floats))
  {
    if (this->Combo->findData(array.first) < 0)
    {
      this->Combo->addItem(array.first, array.first);
      this->Combo->setItemData(this->Combo->count() - 1,
                               array.second ? tr("cell data") : tr("point data"), Qt::ToolTipRole);
    }
  }
  this->setLabelArray(current);
}

QVector<QPair<QString, bool>> pqCSGVLabelArrayWidget::integerArrays(vtkSMProxy* display)
{
  return labelArrays(display, false);
}

QVector<QPair<QString, bool>> pqCSGVLabelArrayWidget::labelArrays(vtkSMProxy* display, bool floats)
{
  QVector<QPair<QString, bool>> arrays;
  vtkPVDataInformation* info = inputInformation(display);
  if (!info)
  {
    return arrays;
  }
  // Integer arrays first, then (when asked) floats: the order findLabelArray chooses in.
  for (int wantInteger = 1; wantInteger >= (floats ? 0 : 1); --wantInteger)
  {
    for (int association : { vtkDataObject::CELL, vtkDataObject::POINT })
    {
      vtkPVDataSetAttributesInformation* attributes = info->GetAttributeInformation(association);
      for (int i = 0; attributes && i < attributes->GetNumberOfArrays(); ++i)
      {
        vtkPVArrayInformation* array = attributes->GetArrayInformation(i);
        const char* name = array->GetName();
        const int type = array->GetDataType();
        // VTK's own arrays (vtkGhostType, vtkOriginalCellIds...) are not labels.
        if (name && QString(name).startsWith("vtk") == false &&
            array->GetNumberOfComponents() == 1 &&
            (wantInteger ? isIntegerType(type) : isFloatType(type)))
        {
          arrays.push_back({ QString(name), association == vtkDataObject::CELL });
        }
      }
    }
  }
  return arrays;
}

std::array<int, 3> pqCSGVLabelArrayWidget::voxelDimensions(vtkSMProxy* display)
{
  std::array<int, 3> dims{ { 0, 0, 0 } };
  vtkPVDataInformation* info = inputInformation(display);
  if (!info || info->GetNumberOfPoints() == 0)
  {
    return dims;
  }
  const QString chosen = display->GetProperty("CSGVLabelArray")
                           ? QString(vtkSMPropertyHelper(display, "CSGVLabelArray").GetAsString())
                           : QString();
  // The representation's choice (vtkCSGVRepresentation): a named array cell data first, else
  // the encoding, else the first integer array, cell data first.
  bool cells = true;
  const QVector<QPair<QString, bool>> arrays = integerArrays(display);
  bool named = false;
  for (const auto& array : arrays)
  {
    if (array.first == chosen)
    {
      cells = array.second;
      named = true;
      break;
    }
  }
  const bool encoded =
    info->GetArrayInformation(csgvvtk::kEncodingName, vtkDataObject::FIELD) != nullptr;
  if (!named && !encoded && !arrays.isEmpty())
  {
    cells = arrays.front().second;
  }
  const int* extent = info->GetExtent();
  for (int a = 0; a < 3; ++a)
  {
    dims[a] = std::max(0, extent[2 * a + 1] - extent[2 * a] + (cells ? 0 : 1));
  }
  return dims;
}

void pqCSGVLabelArrayWidget::connectInputUpdates(vtkSMProxy* display, QObject* receiver,
                                                 const char* slot)
{
  if (!display || !display->GetProperty("Input"))
  {
    return;
  }
  auto* model = pqApplicationCore::instance()->getServerManagerModel();
  if (auto* source =
        model->findItem<pqPipelineSource*>(vtkSMPropertyHelper(display, "Input").GetAsProxy()))
  {
    QObject::connect(source, SIGNAL(dataUpdated(pqPipelineSource*)), receiver, slot);
  }
}
