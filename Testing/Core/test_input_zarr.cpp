// SPDX-License-Identifier: MIT
/// @file test_input_zarr.cpp
/// @brief Tests of Zarr and OME-Zarr input (fixtures written at test time by Testing/Core/inputs/ scripts).
#include "TestData.h"

#include "csgv/inputs/Inputs.h"

#include <gtest/gtest.h>
