// SPDX-License-Identifier: MIT
/**
 * @file CSGVHeldValue.h
 * @brief Setters of the readers' and filters' numeric properties that hold a value to its range
 * and say so: a value from Python or a state file outside the XML domain (which the Properties
 * panel enforces, pvpython does not) is held to the nearer end (NaN to the lower one), with a
 * warning naming the property and the value used, as the representation's properties do.
 * vtkSetClampMacro held them silently (found by an attack pass: Smoothing 2^31-1 meshed for 197 s,
 * MaxLabels 0 gave "more than MaxLabels (1)").
 */
#ifndef CSGVHeldValue_h
#define CSGVHeldValue_h

#include <cmath>
#include <sstream>
#include <string>
#include <type_traits>

namespace csgvvtk
{
/// `value` held to [lo, hi] (NaN: lo); `warning` names the property when the value changed.
template <class T>
T heldValue(const char* property, T value, T lo, T hi, std::string& warning)
{
  T held = value;
  if constexpr (std::is_floating_point<T>::value)
  {
    if (std::isnan(value))
    {
      held = lo;
    }
  }
  if (held < lo)
  {
    held = lo;
  }
  else if (held > hi)
  {
    held = hi;
  }
  if (!(held == value))
  {
    std::ostringstream o;
    o << property << " " << value << " is outside [" << lo << ", " << hi << "]: " << held << " is used";
    warning = o.str();
  }
  return held;
}
}

/// Defines CLASS::SetNAME, declared in the class's header as a plain method (the client-server
/// wrapper does not see through macros of ours): vtkSetClampMacro that warns when it holds the
/// value (heldValue).
#define csgvHeldSetter(cls, name, type, lo, hi)                                                    \
  void cls::Set##name(type value)                                                                  \
  {                                                                                                \
    std::string csgvWarning;                                                                       \
    const type csgvHeld = csgvvtk::heldValue<type>(#name, value, type(lo), type(hi), csgvWarning); \
    if (!csgvWarning.empty())                                                                      \
    {                                                                                              \
      vtkWarningMacro(<< csgvWarning);                                                             \
    }                                                                                              \
    if (!(this->name == csgvHeld))                                                                 \
    {                                                                                              \
      this->name = csgvHeld;                                                                       \
      this->Modified();                                                                            \
    }                                                                                              \
  }

#endif
