// SPDX-License-Identifier: MIT
// TEMPORARY weak stand-ins until Inputs.cpp lands; its strong definitions override these.
#include "csgv/Inputs.h"
namespace csgv {
__attribute__((weak)) const char* labelTypeName(LabelType) { return "uint32"; }
__attribute__((weak)) bool isSignedType(LabelType t) { return t == LabelType::I8 || t == LabelType::I16 || t == LabelType::I32 || t == LabelType::I64; }
__attribute__((weak)) Result<InputVolume> readNrrd(const std::string&, uint64_t) { return Status::error("not yet"); }
__attribute__((weak)) Result<InputVolume> readNifti(const std::string&, uint64_t) { return Status::error("not yet"); }
__attribute__((weak)) Result<InputVolume> readInput(const std::string&, uint64_t) { return Status::error("not yet"); }
}
