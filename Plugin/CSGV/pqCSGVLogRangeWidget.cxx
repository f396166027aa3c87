// SPDX-License-Identifier: MIT
#include "pqCSGVLogRangeWidget.h"

#include <vtkPVXMLElement.h>
#include <vtkSMDoubleRangeDomain.h>
#include <vtkSMIntRangeDomain.h>
#include <vtkSMIntVectorProperty.h>
#include <vtkSMProperty.h>

#include <QDoubleSpinBox>
#include <QHBoxLayout>
#include <QSignalBlocker>
#include <QSlider>
#include <QSpinBox>

#include <algorithm>
#include <cmath>

namespace
{
/// Digits after the point of a double property's box.
constexpr int kDecimals = 2;
} // namespace

double pqCSGVLogRangeWidget::positionOf(double value, double minimum, double maximum)
{
  const double span = maximum - minimum;
  if (!(span > 0) || !std::isfinite(value))
  {
    return 0;
  }
  const double v = std::min(std::max(value, minimum), maximum);
  return std::log1p(v - minimum) / std::log1p(span);
}

double pqCSGVLogRangeWidget::valueAt(double position, double minimum, double maximum)
{
  const double span = maximum - minimum;
  if (!(span > 0))
  {
    return minimum;
  }
  const double t = std::min(std::max(position, 0.0), 1.0);
  return std::min(maximum, minimum + std::expm1(t * std::log1p(span)));
}

pqCSGVLogRangeWidget::pqCSGVLogRangeWidget(vtkSMProxy* proxy, vtkSMProperty* property,
                                           QWidget* parent)
  : Superclass(proxy, parent)
  , Slider(new QSlider(Qt::Horizontal, this))
{
  this->Integer = vtkSMIntVectorProperty::SafeDownCast(property) != nullptr;
  if (auto* ints = property->FindDomain<vtkSMIntRangeDomain>())
  {
    this->Minimum = ints->GetMinimumExists(0) ? ints->GetMinimum(0) : 0;
    this->Maximum = ints->GetMaximumExists(0) ? ints->GetMaximum(0) : this->Minimum + 1;
  }
  else if (auto* doubles = property->FindDomain<vtkSMDoubleRangeDomain>())
  {
    this->Minimum = doubles->GetMinimumExists(0) ? doubles->GetMinimum(0) : 0;
    this->Maximum = doubles->GetMaximumExists(0) ? doubles->GetMaximum(0) : this->Minimum + 1;
  }
  this->Maximum = std::max(this->Maximum, this->Minimum);

  this->Slider->setObjectName("LogSlider");
  this->Slider->setRange(0, kSteps);
  this->Slider->setPageStep(kSteps / 12);
  if (this->Integer)
  {
    auto* box = new QSpinBox(this);
    box->setRange(int(this->Minimum), int(this->Maximum));
    connect(box, QOverload<int>::of(&QSpinBox::valueChanged), this, [this](int v) {
      this->showValue(v, true);
      Q_EMIT this->valueChanged();
    });
    this->Box = box;
  }
  else
  {
    auto* box = new QDoubleSpinBox(this);
    box->setDecimals(kDecimals);
    box->setRange(this->Minimum, this->Maximum);
    connect(box, QOverload<double>::of(&QDoubleSpinBox::valueChanged), this, [this](double v) {
      this->showValue(v, true);
      Q_EMIT this->valueChanged();
    });
    this->Box = box;
  }
  this->Box->setObjectName("LogValue");
  // One width for every such box, whatever its range: the sliders' right ends line up.
  {
    QDoubleSpinBox widest;
    widest.setDecimals(kDecimals);
    widest.setRange(0, 16777216.0);
    this->Box->setFixedWidth(widest.sizeHint().width());
  }
  // The value the minimum stands for, when the property's hints name one (0: "automatic").
  vtkPVXMLElement* hints = property->GetHints();
  if (vtkPVXMLElement* e = hints ? hints->FindNestedElementByName("CSGVMinimumText") : nullptr)
  {
    this->Box->setSpecialValueText(QString(e->GetAttributeOrEmpty("text")));
  }
  // Typed digits apply on Enter or when the box loses focus, not one by one.
  this->Box->setKeyboardTracking(false);
  this->Box->setToolTip(tr("%1 to %2").arg(this->Minimum).arg(this->Maximum));
  this->Slider->setToolTip(tr("Logarithmic scale: each factor of two takes the same length"));

  // Dragging shows the value in the box; it applies on release. Clicks and keys apply at once.
  connect(this->Slider, &QSlider::valueChanged, this, [this](int position) {
    const double v = this->roundedValue(valueAt(double(position) / kSteps, this->Minimum, this->Maximum));
    this->showValue(v, false);
    if (!this->Slider->isSliderDown())
    {
      Q_EMIT this->valueChanged();
    }
  });
  connect(this->Slider, &QSlider::sliderReleased, this, &pqCSGVLogRangeWidget::valueChanged);

  auto* layout = new QHBoxLayout(this);
  layout->setContentsMargins(0, 0, 0, 0);
  layout->addWidget(this->Slider, 1);
  layout->addWidget(this->Box);
  this->addPropertyLink(this, "value", SIGNAL(valueChanged()), property);
}

pqCSGVLogRangeWidget::~pqCSGVLogRangeWidget() = default;

double pqCSGVLogRangeWidget::value() const
{
  return this->Value;
}

void pqCSGVLogRangeWidget::setValue(double value)
{
  this->showValue(value, true);
}

double pqCSGVLogRangeWidget::roundedValue(double value) const
{
  if (this->Integer)
  {
    return std::round(value);
  }
  const double scale = std::pow(10.0, kDecimals);
  return std::round(value * scale) / scale;
}

void pqCSGVLogRangeWidget::showValue(double value, bool moveSlider)
{
  this->Value = value;
  {
    const QSignalBlocker blocker(this->Box);
    if (auto* ints = qobject_cast<QSpinBox*>(this->Box))
    {
      ints->setValue(int(std::lround(std::min(std::max(value, -2147483648.0), 2147483647.0))));
    }
    else if (auto* doubles = qobject_cast<QDoubleSpinBox*>(this->Box))
    {
      doubles->setValue(value);
    }
  }
  if (moveSlider)
  {
    const QSignalBlocker blocker(this->Slider);
    this->Slider->setValue(
      int(std::lround(kSteps * positionOf(value, this->Minimum, this->Maximum))));
  }
}
