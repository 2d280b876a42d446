#pragma once
// EEG electrode position files. The format is chosen by the extension (any case):
// .csv/.tsv/.txt (delimited text), .elc (ASA/EEProbe/FieldTrip) and .sfp (BESA/EEGLAB).
// Positions are returned in mm, in file order; Electrode::line is the 1-based line of the
// electrode's coordinates in the file.
//
// Common rules for all formats:
//  - Lines end in LF or CRLF; a UTF-8 byte order mark at the start is ignored. Blank lines and
//    lines whose first non-blank character is '#' are skipped (a '#' later in a line is not a
//    comment). Blanks (space, tab, CR, VT, FF) around lines and fields are ignored, and a field
//    enclosed in double quotes loses them.
//  - Numbers are decimal with '.' as the decimal point ("1.5", "-2e1", "+3"); NaN, infinity and
//    values beyond the double range are refused, as is a coordinate that is not finite after
//    scaling.
//  - Names must be non-empty, free of control characters, and unique (compared exactly, so "Fp1"
//    and "FP1" are different electrodes).
//  - unitScale > 0 multiplies every coordinate (and overrides the unit an .elc file states);
//    unitScale == 0 uses the format's unit (see below); negative or non-finite is refused.
//  - Files over 64 MiB or with more than 10^6 electrodes are refused (real ones hold a few kB).
//
// .csv / .tsv / .txt (all three parsed alike): one electrode per line, "name, x, y, z" or
//   "x, y, z" (then the name is "E<n>", n = its 1-based position in the result; a file may mix
//   both). The first non-comment line is a header, and skipped, when none of its fields is a
//   number ("name,x,y,z", "label\tx\ty\tz"). The separator is then decided once, from the first
//   data line: a tab if it holds one, else a semicolon, else a comma, else runs of blanks; every
//   data line is split with it. With tab/semicolon/comma, fields may contain spaces (so may
//   names); quoted fields holding the separator are not supported. A trailing empty field (a
//   separator at the end of a line) is ignored. Three fields whose first is not a number count
//   as a wrong number of fields (a value is missing). Unit: mm.
// .elc (ASA/EEProbe/FieldTrip ASCII): keyword lines, matched case-insensitively, with an optional
//   '=' after the keyword:
//     NumberPositions= N      optional; when given it must equal the number of positions
//     UnitPosition mm|cm|m    optional, default mm; another unit is an error unless unitScale > 0
//     Positions               alone on its line; then one line per electrode: "x y z",
//                             "Label: x y z", "Label : x y z" or "Label x y z"
//     Labels                  alone on its line; then the labels, whitespace separated, any
//                             number per line
//   A Positions or Labels section runs until the next keyword line (one starting with one of the
//   four keywords, or containing '=') or the end of the file. Names come from the Labels section
//   when there is one (labels on position lines are then ignored); without one every position
//   line must carry its label. The number of labels must equal the number of positions. Other
//   lines outside the sections (ReferenceLabel, NumberPolygons=, Polygons ...) are ignored; a
//   repeated keyword (second Positions section, ...) is an error.
// .sfp (BESA/EEGLAB): "name x y z" per line, blank separated, exactly four fields. The format
//   states no unit; mm is assumed (pass unitScale = 10 for a file in cm, 1000 for m). Fiducials
//   (names starting with "fid" in any case: FidNz, FidT9, FidT10 ...) are checked like the other
//   lines but left out of the result.
//
// Errors are InputError "<path>, line <n>: <what was found and expected; how to fix>" (without
// the line for problems of the whole file): missing or unreadable file, unknown extension (the
// message lists the supported ones), bad unitScale, wrong number of fields, a non-numeric or
// non-finite coordinate, a bad or duplicate name (both lines named; for .elc the lines of the
// labels), an .elc count mismatch (the NumberPositions or Labels line) or unknown unit, and a
// file holding no electrodes. Arbitrary bytes never crash or hang the reader.
#include <string>
#include <vector>

#include "../Core/Geometry.h"

namespace tetflow {

struct Electrode {
  std::string name;
  Vec3 position{0.0, 0.0, 0.0}; // mm
  int line = 0;                 // source line, 1-based
};

std::vector<Electrode> readElectrodes(const std::string& path, double unitScale = 0.0);

} // namespace tetflow
