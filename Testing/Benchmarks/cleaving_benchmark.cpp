// Cleaving benchmark (issue 4 targets):
//  - speed and memory: regular-lattice cleave of the head phantom producing >= 2 M tets;
//    throughput = output tets / seconds of the cleave() call (sample .. stencil), both cores;
//    memory = peak resident set during background + cleave, minus the resident set with only
//    the input volume loaded, per output tet (VmHWM reset through /proc/self/clear_refs);
//  - quality: Cleaver's spheres1..4 indicator functions at several lattice cell sizes
//    (min / max dihedral angle, tets below 10 degrees, validity).
//
//   cleaving_benchmark [RESULTS_FILE] [SPHERES_DIR]
#include <omp.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/Cleaving/Cleaver.h"
#include "Algorithms/Core/Phantom.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Algorithms/Quality/MeshQuality.h"

using namespace tetflow;

namespace {
long statusKb(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(key, 0) == 0) return std::stol(line.substr(std::string(key).size()));
  return -1;
}
void resetPeak() { std::ofstream("/proc/self/clear_refs") << "5"; }
double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
} // namespace

int main(int argc, char** argv) {
  const std::string results = argc > 1 ? argv[1] : "cleaving_results.txt";
  const std::string spheres = argc > 2 ? argv[2] : std::string(TETFLOW_TEST_DATA);
  std::ostringstream out;
  out << "# cleaving_benchmark on " << std::thread::hardware_concurrency() << " hardware threads (OpenMP "
      << omp_get_max_threads() << ")\n";

  // --- speed and memory: head phantom ---
  PhantomParams pp; // default head: radius 92 mm, 2 mm voxels
  const Phantom ph = makePhantom(pp);
  auto vol = std::make_shared<const LabelVolume>(ph.volume);
  LabelMaterials mats(vol, 1.0);
  NullProgress warm;
  resetPeak();
  const long baseKb = statusKb("VmRSS:");
  const double t0 = now();
  BackgroundMesh bg = generateRegularBcc(vol->grid, BccParams{3.0, 0.0}, warm);
  const double t1 = now();
  NullProgress progress;
  CleaveResult r = cleave(bg, mats, CleaveParams{}, progress);
  const double t2 = now();
  const long peakKb = statusKb("VmHWM:");
  const double tets = double(r.mesh.numTets());
  NullProgress qp;
  const QualityResult q = evaluateQuality(r.mesh, QualityParams{}, qp);
  out << "head phantom " << vol->grid.dims[0] << "^3 voxels of 2 mm, cell_size 3 mm: background "
      << bg.mesh.numTets() << " tets in " << (t1 - t0) << " s; cleave " << r.mesh.numTets()
      << " tets in " << (t2 - t1) << " s = " << tets / (t2 - t1) << " tets/s\n";
  for (const auto& s : progress.stageTimes()) out << "  stage " << s.name << ": " << s.seconds << " s\n";
  out << "  peak memory beyond the input volume: " << (peakKb - baseKb) / 1024.0 << " MiB = "
      << 1024.0 * double(peakKb - baseKb) / tets << " bytes per output tet\n";
  out << "  quality: valid " << (q.valid ? "yes" : "NO") << ", dihedral [" << q.minDihedral << ", "
      << q.maxDihedral << "], tets below 10 deg " << q.tetsBelow[1] << "\n";

  // --- quality: spheres indicator functions ---
  std::vector<ScalarVolume> v;
  for (int i = 1; i <= 4; ++i) v.push_back(readScalarVolume(spheres + "/spheres" + std::to_string(i) + ".nrrd"));
  IndicatorMaterials sm(std::move(v));
  out << "spheres1..4 (28^3, 4 materials), default alphas:\n";
  out << "# cell_size  tets  min_dihedral  max_dihedral  below_10deg  valid  seconds\n";
  for (double cell : {3.0, 2.0, 1.5, 1.0, 0.75, 0.5}) {
    NullProgress np;
    const BackgroundMesh sbg = generateRegularBcc(sm.grid(), BccParams{cell, 0.0}, np);
    const double a = now();
    const CleaveResult sr = cleave(sbg, sm, CleaveParams{}, np);
    const double b = now();
    const QualityResult sq = evaluateQuality(sr.mesh, QualityParams{}, np);
    char line[200];
    std::snprintf(line, sizeof line, "%-10g %9zu %12.2f %12.2f %11lld   %s  %.3f\n", cell, sr.mesh.numTets(),
                  sq.minDihedral, sq.maxDihedral, (long long)sq.tetsBelow[1], sq.valid ? "yes" : "NO", b - a);
    out << line;
  }
  std::cout << out.str();
  std::ofstream(results) << out.str();
  return q.valid ? 0 : 1;
}
