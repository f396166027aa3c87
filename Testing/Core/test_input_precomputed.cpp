// SPDX-License-Identifier: MIT
/// @file test_input_precomputed.cpp
/// @brief Tests of Neuroglancer precomputed input (fixtures written at test time by Testing/Core/inputs/ scripts).
#include "TestData.h"

#include "csgv/inputs/Inputs.h"

#include <gtest/gtest.h>
