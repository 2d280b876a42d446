#pragma once
// Volume file reading and writing, format chosen by the file extension.
//
// Readers (all produce RawVolume; see RawVolume.h):
//   .nrrd / .nhdr        NrrdIO.h     raw, gzip and ascii encodings, all integer/float types,
//                                     both endians, detached data files
//   .nii / .nii.gz       VtkVolumeIO.h through VTK, q-/s-form origin and axes applied
//   .mha / .mhd          VtkVolumeIO.h through VTK
//   .vti                 VtkVolumeIO.h through VTK (XML image data)
//   .inr / .inr.gz       InrIO.h      INRIA images
// Writers: every one of the above formats (NRRD is the native one).
#include <string>
#include <vector>

#include "RawVolume.h"

namespace tetflow {

// Extensions understood by readVolume, for messages and file dialogs.
const std::vector<std::string>& volumeExtensions();

// Read any supported volume file. InputError names the file and problem (unknown extension lists
// the supported ones).
RawVolume readVolume(const std::string& path);
LabelVolume readLabelVolume(const std::string& path);
ScalarVolume readScalarVolume(const std::string& path);

// Write by extension, atomically (temp file + rename).
void writeVolume(const std::string& path, const RawVolume& v);

} // namespace tetflow
