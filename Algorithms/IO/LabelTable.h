#pragma once
// Label tables: the names (and optionally conductivities) of a segmentation's label values, in
// the formats that come with segmentations. The format is told by the content:
//   ITK-SNAP label description file: "IDX R G B A VIS MSH "name"" per line ('#' comments);
//   FreeSurfer colour table (FreeSurferColorLUT.txt, SimNIBS charm's *_LUT.txt, 3D Slicer's
//     .ctbl): "label name R G B A" per line, the name without spaces ('#' comments);
//   CSV (',' or ';') or TSV (tab): "label, name[, conductivity in S/m]" per row; a first row whose
//     label is not an integer is a header; names may be in double quotes.
// Refused (InputError naming the file and line): a line that fits none of them, a label that is
// not a 32-bit integer, a label listed twice, an empty name, a conductivity that is not a
// positive finite number, and a file with no entry.
#include <cstdint>
#include <map>
#include <string>

namespace tetflow {

struct LabelTable {
  std::map<int32_t, std::string> names;
  std::map<int32_t, double> conductivities; // S/m (CSV/TSV third column)
  std::string format;                       // "ITK-SNAP", "FreeSurfer", "CSV" or "TSV"
};

LabelTable readLabelTable(const std::string& path);

// The label table that comes with the volume file `volumePath` by a known convention, or "" when
// there is none. For "DIR/NAME.EXT" (EXT as long as a volume format's: .nii.gz, .seg.nrrd, ...)
// the first that exists of: DIR/NAME_LUT.txt (SimNIBS charm), DIR/NAME.lut, DIR/NAME.ctbl
// (3D Slicer), DIR/NAME.label, DIR/NAME.txt (ITK-SNAP's export beside the image),
// DIR/NAME.csv, DIR/NAME.tsv.
std::string labelTableBeside(const std::string& volumePath);

} // namespace tetflow
