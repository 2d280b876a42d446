#pragma once
// NRRD volumes (http://teem.sourceforge.net/nrrd/format.html), our own reader and writer
// (VTK's reader misreads small fastest axes and VTK has no writer; PLATFORM.md).
//
// Reader: NRRD0001..NRRD0005 magic; attached (.nrrd) or detached (.nhdr + "data file:", relative
// to the header's folder); encodings raw, gzip/gz, ascii/text/txt; every integer and float type
// spelling of the spec; endian little/big; "line skip" and "byte skip" (incl. -1 with raw);
// geometry from "space directions" + "space origin" (direction columns normalised, spacing = their
// lengths) or from "spacings"/"axis mins"; dimension 3 (a leading axis of size 1 is dropped, and
// dimension 2 becomes one slice). Anything else is refused with an InputError naming the file,
// the header line number and the field.
#include <string>

#include "RawVolume.h"

namespace tetflow {

enum class NrrdEncoding : int { Raw = 0, Gzip = 1, Ascii = 2 };

RawVolume readNrrd(const std::string& path);

// Writes an attached .nrrd (or, for a .nhdr path, the header plus a sibling data file named
// "<stem>.raw" / "<stem>.raw.gz"), little-endian, with "space directions"/"space origin".
// Atomic: temp file + rename.
void writeNrrd(const std::string& path, const RawVolume& v, NrrdEncoding enc = NrrdEncoding::Gzip);

} // namespace tetflow
