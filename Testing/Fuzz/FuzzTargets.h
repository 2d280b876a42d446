// The fuzz targets' inputs as plain functions: libFuzzer's entry points call them in a fuzzing build
// (one program per target), and fuzz_corpus calls them in a normal build (one program for all).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace tetflow::fuzz {

// ReaderFuzzer.cpp: the readers' formats (nrrd, nifti, metaimage, inr, vti, vtu, vtk, msh, tetgen).
bool isReaderFormat(const std::string& format);
void initReaders();
void fuzzReaderInput(const std::string& format, const uint8_t* data, size_t size);

// SrnFuzzer.cpp: the .srn loader (load, save, load again).
void fuzzSrnInput(const uint8_t* data, size_t size);

} // namespace tetflow::fuzz
