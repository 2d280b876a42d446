#pragma once
// INRIA image format (.inr, .inr.gz) as written by CGAL / MedINRIA / Cleaver tools.
// Header: "#INRIMAGE-4#{" newline, KEY=VALUE lines (XDIM YDIM ZDIM VDIM TYPE PIXSIZE SCALE CPU
// VX VY VZ, optional TX TY TZ origin), padded with newlines to a multiple of 256 bytes, closed
// by "##}" newline; then the voxels, x fastest. TYPE "unsigned fixed" / "signed fixed" / "float";
// PIXSIZE "8 bits" ... "64 bits"; CPU decm/alpha/pc (little endian) or sun/sgi (big endian).
// The whole file may be gzip-compressed (.inr.gz). VDIM must be 1.
#include <string>

#include "RawVolume.h"

namespace tetflow {

RawVolume readInr(const std::string& path);
// Writes .inr, or gzip-compressed when the path ends in .gz. Atomic.
void writeInr(const std::string& path, const RawVolume& v);

} // namespace tetflow
