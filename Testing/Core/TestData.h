// SPDX-License-Identifier: MIT
#pragma once
/// @file TestData.h
/// @brief Access to the Volcanite fixtures and their source volumes for the core tests.

#include "csgv/codec/Container.h"
#include "csgv/codec/LabelVolume.h"
#include "csgv/inputs/Inputs.h"

#include <string>
#include <vector>

namespace csgvtest {

/// Absolute path of a file in shared/data/volcanite-0.6.
std::string fixture(const std::string& name);
/// Every `.csgv` fixture file name (sorted).
std::vector<std::string> allFixtureNames();
/// The source volume a fixture was written from ("synthA" or "denseB"), cached.
const csgv::LabelVolume& sourceVolume(const std::string& fixtureName);
/// Raw bytes of a fixture file.
std::vector<uint8_t> fixtureBytes(const std::string& name);
/// Parsed fixture (asserts success through gtest).
csgv::CompressedVolume loadFixture(const std::string& name);
/// A temporary directory unique to this test process, removed at exit.
std::string tempDir();

/// Independent, simple coarse-label reference: each level computed from the previous one by
/// brute force over the 2x2x2 children, written without sharing code with Core.
csgv::LabelVolume referenceCoarsen(const csgv::LabelVolume& fine);

/// Runs `Testing/Core/inputs/<script>` with Debian's python3 (numpy, h5py, tifffile, zarr) and
/// the given arguments; returns its exit status (0 = fixture written). Input-format tests write
/// their fixtures this way at test time; nothing large is committed.
int runFixtureScript(const std::string& script, const std::vector<std::string>& args);

/// Checks the InputSource contract (Inputs.h) on a source whose whole content is `expected`
/// (x fastest, full width): slabs of depth 1, 2, 5 and the whole depth, in increasing,
/// decreasing and shuffled order, each twice, all give the expected values (gtest failures name
/// the first differing voxel); uniform boxes (InputSource::uniformBoxes) of slabs and bands lie
/// inside them, are disjoint and hold their value. Every input format's tests call it on their
/// fixtures.
void expectSourceContract(csgv::InputSource& source, const std::vector<uint64_t>& expected);

/// Bytes of test files, and the helpers the input tests write them with.
using Bytes = std::vector<uint8_t>;
void writeBytes(const std::string& path, const Bytes& bytes);
Bytes textBytes(const std::string& s);
Bytes operator+(Bytes a, const Bytes& b);
/// A gzip stream (windowBits 31) of `raw`.
Bytes gzipBytes(const Bytes& raw);

/// Lowercase hex SHA-256.
std::string sha256Hex(const uint8_t* data, size_t size);

} // namespace csgvtest
