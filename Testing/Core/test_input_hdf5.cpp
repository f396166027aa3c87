// SPDX-License-Identifier: MIT
/// @file test_input_hdf5.cpp
/// @brief Tests of HDF5 input (fixtures written at test time by Testing/Core/inputs/ scripts).
#include "TestData.h"

#include "csgv/inputs/Inputs.h"

#include <gtest/gtest.h>
