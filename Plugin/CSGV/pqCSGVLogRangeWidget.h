// SPDX-License-Identifier: MIT
/**
 * @class pqCSGVLogRangeWidget
 * @brief A number over a wide range (panel_widget "csgv_log_range"): a slider on a logarithmic
 * scale beside a spin box, for an int or double property with a range domain.
 *
 * ParaView's own slider is linear: over Frames Per Still Render's 1-4096, or the time budget's
 * 0-600 s, the useful values (16 frames, 3 s) sit at the slider's far left and a pixel of the
 * slider jumps by dozens. Here the slider's position t in [0, 1] stands for
 * min + (max - min + 1)^t - 1: every factor of two takes the same length, and the minimum (often
 * 0, "automatic") is the left end. The spin box takes any value of the range; typing applies on
 * Enter or when the box loses focus, as ParaView's own line edits do. `<Hints><CSGVMinimumText
 * text="automatic"/></Hints>` shows that text for the minimum (0 standing for automatic).
 */
#ifndef pqCSGVLogRangeWidget_h
#define pqCSGVLogRangeWidget_h

#include "pqPropertyWidget.h"

class QAbstractSpinBox;
class QSlider;

class pqCSGVLogRangeWidget : public pqPropertyWidget
{
  Q_OBJECT
  Q_PROPERTY(double value READ value WRITE setValue NOTIFY valueChanged)
  typedef pqPropertyWidget Superclass;

public:
  pqCSGVLogRangeWidget(vtkSMProxy* proxy, vtkSMProperty* property, QWidget* parent = nullptr);
  ~pqCSGVLogRangeWidget() override;

  double value() const;
  void setValue(double value);

  /// The slider's position in [0, 1] for `value`, and back (the scale above).
  static double positionOf(double value, double minimum, double maximum);
  static double valueAt(double position, double minimum, double maximum);

  /// Slider steps between the ends.
  static constexpr int kSteps = 1000;

Q_SIGNALS:
  void valueChanged();

private:
  void showValue(double value, bool moveSlider);
  double roundedValue(double value) const;

  QSlider* Slider;
  QAbstractSpinBox* Box;
  double Minimum = 0;
  double Maximum = 1;
  bool Integer = false;
  double Value = 0;
};

#endif
