// SPDX-License-Identifier: MIT
/// @file test_input_streaming.cpp
/// @brief Tests of the InputSource contract on every format, streaming NRRD/NIfTI, out-of-core relabelling input (fixtures written at test time by Testing/Core/inputs/ scripts).
#include "TestData.h"

#include "csgv/inputs/Inputs.h"

#include <gtest/gtest.h>
