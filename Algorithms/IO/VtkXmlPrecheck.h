// Checks the sizes a VTK XML file (.vtu, .vti) announces against the file before VTK allocates
// them. VTK 9.1's XML reader trusts its block headers: a damaged compressed-block size makes
// vtkXMLDataParser::ReadBlock ask for a new[] of up to 2^64 bytes, which throws std::bad_alloc in a
// normal build but aborts the process under AddressSanitizer (and can take all memory before the
// OOM killer steps in on a machine that overcommits). So, before the reader runs:
//   - every Piece's NumberOfPoints / NumberOfCells (and WholeExtent / Extent of image data) must fit
//     in what the file could hold once decompressed;
//   - every binary DataArray's header (raw or base64, inline or appended, UInt32 or UInt64 words,
//     either byte order) must lie in the file, and its announced byte counts must fit in it: the
//     raw size of an uncompressed array, and for a compressed one the number of blocks, each
//     block's compressed size (their sum within the bytes that follow) and the uncompressed size
//     (at most kMaxExpansion times the compressed bytes).
// Anything the check does not understand is left to VTK, which reports it as an error.
#pragma once

#include <string>

namespace tetflow {

// No compressor VTK ships expands data by more than this (zlib ~1032:1, LZ4 ~255:1, LZMA a few
// thousand to one on constant data).
inline constexpr double kVtkXmlMaxExpansion = 8192.0;

// Throws InputError naming the file, the element and the size that does not fit.
void precheckVtkXml(const std::string& path);

} // namespace tetflow
