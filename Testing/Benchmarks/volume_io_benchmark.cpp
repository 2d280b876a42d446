// Volume I/O benchmark: a 25-million-voxel 8-bit segmentation with labels {0,84,85,127,255} and
// 0.617 x 0.617 x 1.333 mm voxels, written as .inr.gz, .nrrd (gzip), .nii.gz and .mha
// (compressed), then read back in each format. Checks that dims, spacing, origin and per-label
// voxel counts agree, and times every read and write.
//
//   volume_io_benchmark [RESULTS_FILE] [WORK_FOLDER]
// Results: one line per format, also printed. Exit 1 when any format disagrees.
#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "Algorithms/IO/VolumeIO.h"
#include "Fixtures/SyntheticSegmentation.h"

using namespace tetflow;
namespace fs = std::filesystem;

int main(int argc, char** argv) {
  const std::string results = argc > 1 ? argv[1] : "volume_io_results.txt";
  const fs::path work = argc > 2 ? fs::path(argv[2]) : fs::temp_directory_path() / "tetflow_volume_io_bench";
  fs::create_directories(work);
  auto now = [] { return std::chrono::steady_clock::now(); };
  auto secs = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };

  const auto t0 = now();
  const LabelVolume seg = test::syntheticSegmentation(512, 512, 96); // 25,165,824 voxels
  const double genSecs = secs(t0, now());
  const auto counts = labelCounts(seg);
  const RawVolume raw = fromLabelVolume(seg);

  std::ostringstream out;
  out << "# volume_io_benchmark: " << seg.grid.voxelCount() << " voxels (512 x 512 x 96), uint8, labels";
  for (const auto& [l, n] : counts) out << ' ' << l;
  out << "; spacing 0.617 x 0.617 x 1.333 mm\n";
  out << "# machine: " << std::thread::hardware_concurrency() << " hardware threads, OpenMP max "
      << omp_get_max_threads() << "; synthetic volume generated in " << genSecs << " s\n";
  out << "# format    file_MB   write_s   read_s   same_geometry_and_counts\n";
  bool allOk = true;
  for (const char* name : {"seg.inr.gz", "seg.nrrd", "seg.nii.gz", "seg.mha"}) {
    const std::string f = (work / name).string();
    const auto w0 = now();
    writeVolume(f, raw);
    const double w = secs(w0, now());
    const auto r0 = now();
    const LabelVolume back = readLabelVolume(f);
    const double r = secs(r0, now());
    bool ok = back.grid.dims == seg.grid.dims && labelCounts(back) == counts;
    for (int a = 0; a < 3; ++a)
      ok = ok && std::abs(back.grid.spacing[a] - seg.grid.spacing[a]) < 1e-5 &&
           std::abs(back.grid.origin[a] - seg.grid.origin[a]) < 1e-4;
    allOk = allOk && ok;
    char line[256];
    std::snprintf(line, sizeof line, "%-11s %8.2f %9.3f %8.3f   %s\n", name + 4,
                  double(fs::file_size(f)) / 1e6, w, r, ok ? "yes" : "NO");
    out << line;
    fs::remove(f);
  }
  std::cout << out.str();
  std::ofstream(results) << out.str();
  return allOk ? 0 : 1;
}
