// Adaptive meshing benchmark (seed chapter 5): sizing field -> graded octree BCC background ->
// cleaving, against regular BCC lattices, on the head phantom and Cleaver's spheres1..4.
// Per run: seconds of each step, background and output tets, dihedral range, tets below 10
// degrees, and each material's volume error against the input (voxel counts x voxel volume, or
// argmax voxels for indicator functions), all on both cores.
//
//   adaptive_benchmark [RESULTS_FILE] [SPHERES_DIR]
#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/BackgroundMesh/OctreeBcc.h"
#include "Algorithms/Cleaving/Cleaver.h"
#include "Algorithms/Core/Phantom.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Algorithms/Quality/MeshQuality.h"
#include "Algorithms/SizingField/SizingField.h"

using namespace tetflow;

namespace {
double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// One row: background, cleave, quality and per-material volume errors (percent).
std::string row(const std::string& what, double prepSeconds, const BackgroundMesh& bg, double bgSeconds,
                const MaterialSet& mats, bool stripZero) {
  NullProgress np;
  CleaveParams cp;
  if (stripZero) cp.strip_exterior = 0;
  const double a = now();
  const CleaveResult r = cleave(bg, mats, cp, np);
  const double cleaveSeconds = now() - a;
  const QualityResult q = evaluateQuality(r.mesh, QualityParams{}, np);
  char buf[512];
  std::snprintf(buf, sizeof buf, "%-34s %6.2f %6.2f %6.2f %10zu %10zu %7.2f %7.2f %6lld %-5s", what.c_str(), prepSeconds,
                bgSeconds, cleaveSeconds, bg.mesh.numTets(), r.mesh.numTets(), q.minDihedral, q.maxDihedral,
                static_cast<long long>(q.tetsBelow[1]), q.valid ? "yes" : "NO");
  std::string s = buf;
  for (const auto& m : r.materials) {
    if (stripZero && m.label == 0) continue;
    std::snprintf(buf, sizeof buf, " %d:%+.1f%%", m.label, 100.0 * (m.meshVolume - m.inputVolume) / m.inputVolume);
    s += buf;
  }
  return s + "\n";
}

// A sizing-field configuration, optionally with uniform_interfaces (materials given to the octree).
struct FieldRun {
  SizingFieldParams params;
  bool uniform = false;
};

void compare(std::ostringstream& out, const MaterialSet& mats, bool stripZero, const std::vector<FieldRun>& fields,
             const std::vector<double>& regularCells) {
  out << "# run                                 field  backg  cleave  backg_tets   out_tets  min_deg max_deg <10deg valid  volume error per material\n";
  NullProgress np;
  for (const FieldRun& run : fields) {
    const SizingFieldParams& sp = run.params;
    const double a = now();
    const SizingFieldResult f = computeSizingField(mats, sp, np);
    const double b = now();
    const OctreeBccResult o = generateOctreeBcc(mats.grid(), f.field, OctreeBccParams{}, np, run.uniform ? &mats : nullptr);
    const double c = now();
    std::ostringstream w;
    w << "octree rate " << sp.sampling_rate << " L " << sp.lipschitz << " min " << sp.min_size << (run.uniform ? " uniform" : "");
    out << row(w.str(), b - a, o.background, c - b, mats, stripZero);
    out << "    field " << f.minSize << ".." << f.maxSize << " mm, " << f.interfaceSamples << " interface / "
        << f.medialSamples << " medial samples; octree " << o.stats.levels << " levels, finest leaf "
        << o.stats.finestCellSize << " mm";
    if (run.uniform)
      out << "; uniform interfaces: " << o.stats.interfaceSplits << " splits in " << o.stats.interfaceRounds
          << " rounds, graded tets left on interfaces " << o.stats.gradedInterfaceTets;
    out << "\n";
  }
  for (double cell : regularCells) {
    const double a = now();
    const BackgroundMesh bg = generateRegularBcc(mats.grid(), BccParams{cell, 0.0}, np);
    std::ostringstream w;
    w << "regular cell " << cell;
    out << row(w.str(), 0.0, bg, now() - a, mats, stripZero);
  }
}
} // namespace

int main(int argc, char** argv) {
  const std::string results = argc > 1 ? argv[1] : "adaptive_results.txt";
  const std::string spheresDir = argc > 2 ? argv[2] : TETFLOW_TEST_DATA;
  std::ostringstream out;
  out << "# adaptive_benchmark on " << std::thread::hardware_concurrency() << " hardware threads (OpenMP "
      << omp_get_max_threads() << "); seconds of the sizing field, the background and the cleave\n";

  PhantomParams pp;
  const Phantom ph = makePhantom(pp);
  auto vol = std::make_shared<const LabelVolume>(ph.volume);
  const LabelMaterials head(vol, 1.0);
  out << "head phantom " << vol->grid.dims[0] << "^3 voxels of 2 mm (air stripped; the CSF is a 2 mm shell, one voxel):\n";
  std::vector<FieldRun> hf(5);
  hf[0].params.min_size = 2;
  hf[1].params.min_size = 2;
  hf[1].uniform = true;
  hf[2].params.min_size = 4;
  hf[3].params.min_size = 4;
  hf[3].uniform = true;
  hf[4].params.min_size = 4;
  hf[4].params.lipschitz = 0.5;
  for (auto& f : hf) f.params.max_size = 32;
  compare(out, head, true, hf, {2.0, 2.5, 3.0, 4.0});
  std::cout << out.str() << std::flush;

  std::vector<ScalarVolume> vols;
  for (int i = 1; i <= 4; ++i) vols.push_back(readScalarVolume(spheresDir + "/spheres" + std::to_string(i) + ".nrrd"));
  const IndicatorMaterials spheres(std::move(vols), {1, 2, 3, 4});
  out << "spheres1..4 (28^3 indicator functions, 4 materials, nothing stripped):\n";
  std::vector<FieldRun> sf(4);
  for (auto& f : sf) f.params.sampling_rate = 2;
  sf[0].params.min_size = 0.5;
  sf[1].params.min_size = 0.5;
  sf[1].uniform = true;
  sf[2].params.min_size = 0.75;
  sf[3].params.min_size = 0.75;
  sf[3].uniform = true;
  compare(out, spheres, false, sf, {0.5, 0.75, 1.0});

  std::cout << out.str().substr(out.str().find("spheres1..4"));
  std::ofstream(results) << out.str();
  return 0;
}
