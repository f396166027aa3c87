// SPDX-License-Identifier: MIT
// Deliberate layer violation: the layering self-test expects CheckLayering.cmake to reject this tree.
#include <vtkObject.h>
