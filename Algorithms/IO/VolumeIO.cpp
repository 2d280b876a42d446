#include "VolumeIO.h"

#include "../Core/Errors.h"
#include "FileUtil.h"
#include "InrIO.h"
#include "NrrdIO.h"
#include "VtkVolumeIO.h"

namespace tetflow {

const std::vector<std::string>& volumeExtensions() {
  static const std::vector<std::string> exts = {".nrrd", ".nhdr", ".nii", ".nii.gz", ".mha",
                                                ".mhd",  ".inr",  ".inr.gz", ".vti"};
  return exts;
}

namespace {
std::string supportedList() {
  std::string s;
  for (const auto& e : volumeExtensions()) s += (s.empty() ? "" : " ") + e;
  return s;
}
} // namespace

RawVolume readVolume(const std::string& path) {
  const std::string ext = fileExtension(path);
  if (ext == ".nrrd" || ext == ".nhdr") return readNrrd(path);
  if (ext == ".nii" || ext == ".nii.gz") return readNifti(path);
  if (ext == ".mha" || ext == ".mhd") return readMetaImage(path);
  if (ext == ".inr" || ext == ".inr.gz") return readInr(path);
  if (ext == ".vti") return readVti(path);
  throw InputError(path + ": unknown volume format '" + ext + "'; supported: " + supportedList());
}

LabelVolume readLabelVolume(const std::string& path) { return toLabelVolume(readVolume(path), path); }

ScalarVolume readScalarVolume(const std::string& path) {
  return toScalarVolume(readVolume(path), path);
}

void writeVolume(const std::string& path, const RawVolume& v) {
  const std::string ext = fileExtension(path);
  if (ext == ".nrrd" || ext == ".nhdr") return writeNrrd(path, v);
  if (ext == ".nii" || ext == ".nii.gz") return writeNifti(path, v);
  if (ext == ".mha" || ext == ".mhd") return writeMetaImage(path, v);
  if (ext == ".inr" || ext == ".inr.gz") return writeInr(path, v);
  if (ext == ".vti") return writeVti(path, v);
  throw InputError(path + ": unknown volume format '" + ext + "'; supported: " + supportedList());
}

} // namespace tetflow
