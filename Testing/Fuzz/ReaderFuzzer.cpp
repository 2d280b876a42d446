// The file readers' fuzz target: nrrd, nifti, metaimage, inr, vti (volumes, read and converted to
// labels as ReadLabelVolume does) or vtu, vtk, tetgen, msh (meshes, read as ReadMesh does). A reader
// may refuse an input only with InputError; any other exception, crash, leak, hang or huge
// allocation is a finding. For TetGen the input is split at its first NUL byte into the .node and
// .ele files. In a fuzzing build TETFLOW_FUZZ_FORMAT picks the reader at compile time and this file
// defines libFuzzer's entry points; in a normal build fuzz_corpus (CorpusMain.cpp) calls
// fuzzReaderInput with the format it is given (Testing/CMakeLists.txt).
#include <cstdint>
#include <algorithm>
#include <cstring>
#include <string>

#include <vtkObject.h>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/IO/MeshIO.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Fuzz/FuzzFile.h"
#include "Fuzz/FuzzTargets.h"

using namespace tetflow;

namespace {

void readVolumeFile(const std::string& path) {
  const LabelVolume v = readLabelVolume(path);
  (void)v;
}

void readMeshFile(const std::string& path) {
  const TetMesh m = readMesh(path);
  for (size_t t = 0; t < m.numTets(); ++t)
    for (int k = 0; k < 4; ++k)
      if (m.tets[t][k] < 0 || size_t(m.tets[t][k]) >= m.numPoints()) std::abort(); // index out of range
}

void fuzzOne(const std::string& f, const uint8_t* data, size_t size) {
  const bool gz = fuzz::gzipped(data, size);
  if (f == "nrrd") return readVolumeFile(fuzz::writeInput("in.nrrd", data, size));
  if (f == "nifti") return readVolumeFile(fuzz::writeInput(gz ? "in.nii.gz" : "in.nii", data, size));
  if (f == "metaimage") return readVolumeFile(fuzz::writeInput("in.mha", data, size));
  if (f == "inr") return readVolumeFile(fuzz::writeInput(gz ? "in.inr.gz" : "in.inr", data, size));
  if (f == "vti") return readVolumeFile(fuzz::writeInput("in.vti", data, size));
  if (f == "vtu") return readMeshFile(fuzz::writeInput("in.vtu", data, size));
  if (f == "vtk") return readMeshFile(fuzz::writeInput("in.vtk", data, size));
  if (f == "msh") return readMeshFile(fuzz::writeInput("in.msh", data, size));
  if (f == "tetgen") {
    const uint8_t* nul = static_cast<const uint8_t*>(std::memchr(data, 0, size));
    const size_t split = nul ? size_t(nul - data) : size;
    fuzz::writeInput("in.node", data, split);
    fuzz::writeInput("in.ele", data + std::min(size, split + 1), size - std::min(size, split + 1));
    return readMeshFile((fuzz::scratchDir() / "in.ele").string());
  }
  std::abort(); // unknown format: callers pass one of isReaderFormat's
}

} // namespace

bool fuzz::isReaderFormat(const std::string& f) {
  for (const char* known : {"nrrd", "nifti", "metaimage", "inr", "vti", "vtu", "vtk", "msh", "tetgen"})
    if (f == known) return true;
  return false;
}

void fuzz::initReaders() {
  vtkObject::GlobalWarningDisplayOff(); // the readers collect VTK's messages themselves
}

void fuzz::fuzzReaderInput(const std::string& format, const uint8_t* data, size_t size) {
  try {
    fuzzOne(format, data, size);
  } catch (const InputError&) {
    // refused with a message: the expected outcome for a damaged file
  }
}

#ifdef TETFLOW_FUZZ_FORMAT
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::initReaders();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fuzz::fuzzReaderInput(TETFLOW_FUZZ_FORMAT, data, size);
  return 0;
}
#endif
