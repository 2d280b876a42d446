// fuzz_corpus TARGET PATH...: the fuzz targets in a normal (non-fuzzing) build, all in one program.
// Runs every file of the given files or folders once through target TARGET (a reader's format or
// srn), so the seed corpora and every input a fuzzing run found (added to Testing/Fuzz/corpus as
// regression cases) are part of the ordinary suite. Exit 0 when all ran, 2 for bad arguments; a
// finding aborts the process as it does under libFuzzer.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "Fuzz/FuzzTargets.h"

int main(int argc, char** argv) {
  namespace fuzz = tetflow::fuzz;
  const std::string target = argc > 1 ? argv[1] : "";
  if (target != "srn" && !fuzz::isReaderFormat(target)) {
    std::fprintf(stderr, "usage: fuzz_corpus TARGET PATH... (TARGET: srn, nrrd, nifti, metaimage, inr, vti, vtu, "
                         "vtk, msh or tetgen; got '%s')\n", target.c_str());
    return 2;
  }
  fuzz::initReaders();
  namespace fs = std::filesystem;
  std::vector<fs::path> files;
  for (int i = 2; i < argc; ++i) {
    const fs::path p = argv[i];
    if (fs::is_directory(p)) {
      for (const auto& e : fs::recursive_directory_iterator(p))
        if (e.is_regular_file()) files.push_back(e.path());
    } else if (fs::is_regular_file(p)) {
      files.push_back(p);
    } else {
      std::fprintf(stderr, "%s: no such file or folder\n", argv[i]);
      return 2;
    }
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) {
    std::fprintf(stderr, "no input files\n");
    return 2;
  }
  for (const auto& f : files) {
    std::ifstream in(f, std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto* data = reinterpret_cast<const uint8_t*>(bytes.data());
    if (target == "srn")
      fuzz::fuzzSrnInput(data, bytes.size());
    else
      fuzz::fuzzReaderInput(target, data, bytes.size());
  }
  std::printf("%zu inputs ran\n", files.size());
  return 0;
}
