// SPDX-License-Identifier: MIT
#include "pqCSGVClipBoxWidget.h"

#include "pqCSGVLabelArrayWidget.h"

#include <pqCoreUtilities.h>
#include <vtkCommand.h>
#include <vtkSMIntVectorProperty.h>
#include <vtkSMProxy.h>

#include <QGridLayout>
#include <QLabel>
#include <QSpinBox>

#include <climits>

pqCSGVClipBoxWidget::pqCSGVClipBoxWidget(vtkSMProxy* proxy, vtkSMProperty* property,
                                         QWidget* parent)
  : Superclass(proxy, parent)
{
  // The XML default maximum, "up to the last voxel".
  if (auto* ivp = vtkSMIntVectorProperty::SafeDownCast(property))
  {
    this->WholeMaximum = ivp->GetDefaultValue(1);
  }
  auto* layout = new QGridLayout(this);
  layout->setContentsMargins(0, 0, 0, 0);
  const char* axes[3] = { "X", "Y", "Z" };
  for (int i = 0; i < 6; ++i)
  {
    QSpinBox* box = new QSpinBox(this);
    box->setObjectName(QString("%1%2").arg(i % 2 ? "max" : "min").arg(axes[i / 2]));
    // Each value change re-renders the volume: apply when the user is done typing.
    box->setKeyboardTracking(false);
    box->setRange(0, INT_MAX);
    box->setToolTip(i % 2 ? tr("Last voxel drawn along %1").arg(axes[i / 2])
                          : tr("First voxel drawn along %1").arg(axes[i / 2]));
    connect(box, QOverload<int>::of(&QSpinBox::valueChanged), this,
            [this]()
            {
              this->Stored = this->clipBox();
              Q_EMIT this->clipBoxChanged();
            });
    this->Boxes[i] = box;
    layout->addWidget(box, i / 2, 1 + i % 2);
  }
  for (int a = 0; a < 3; ++a)
  {
    layout->addWidget(new QLabel(axes[a], this), a, 0);
  }
  this->updateExtent();
  this->addPropertyLink(this, "clipBox", SIGNAL(clipBoxChanged()), property);
  pqCSGVLabelArrayWidget::connectInputUpdates(proxy, this, SLOT(updateExtent()));
  // The extent depends on where the chosen label array lies (cells or points).
  if (vtkSMProperty* labelArray = proxy->GetProperty("CSGVLabelArray"))
  {
    pqCoreUtilities::connect(labelArray, vtkCommand::ModifiedEvent, this, SLOT(updateExtent()));
  }
}

pqCSGVClipBoxWidget::~pqCSGVClipBoxWidget() = default;

QList<QVariant> pqCSGVClipBoxWidget::clipBox() const
{
  if (!this->hasVoxels() && this->Stored.size() == 6)
  {
    return this->Stored; // boxes without a range say nothing about the property
  }
  QList<QVariant> values;
  for (int i = 0; i < 6; ++i)
  {
    int value = this->Boxes[i]->value();
    const int last = this->Dimensions[i / 2] - 1;
    // A maximum at the last voxel is stored as the default, "up to the last voxel".
    if (i % 2 == 1 && last >= 0 && value >= last)
    {
      value = this->WholeMaximum;
    }
    values.push_back(value);
  }
  return values;
}

void pqCSGVClipBoxWidget::setClipBox(const QList<QVariant>& values)
{
  if (values.size() != 6)
  {
    return;
  }
  this->Stored = values;
  for (int i = 0; i < 6; ++i)
  {
    const QSignalBlocker blocker(this->Boxes[i]);
    this->Boxes[i]->setValue(values[i].toInt()); // clamped to the extent by the spin box
  }
}

bool pqCSGVClipBoxWidget::hasVoxels() const
{
  return this->Dimensions[0] > 0 && this->Dimensions[1] > 0 && this->Dimensions[2] > 0;
}

void pqCSGVClipBoxWidget::updateExtent()
{
  this->Dimensions = pqCSGVLabelArrayWidget::voxelDimensions(this->proxy());
  // No voxels (an empty input: a file that failed to read): the boxes show a dash, disabled,
  // and the property keeps its values for when the input has voxels again.
  const bool voxels = this->hasVoxels();
  for (int i = 0; i < 6; ++i)
  {
    const int n = this->Dimensions[i / 2];
    const QSignalBlocker blocker(this->Boxes[i]);
    this->Boxes[i]->setRange(0, voxels ? n - 1 : 0);
    this->Boxes[i]->setSpecialValueText(voxels ? QString() : QString("-"));
    this->Boxes[i]->setEnabled(voxels);
  }
  if (this->Stored.size() == 6)
  {
    this->setClipBox(this->Stored);
  }
}
