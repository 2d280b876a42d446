// Fidelity benchmark: how well meshes keep their segmentation, measured by the mesh certificate
// (Algorithms/Quality/Certificate.h) on the head phantom (the default net's regular lattice and
// the adaptive net's octree, plus the levers: cell size and blend_sigma), Cleaver's spheres (the
// certificate compares with the argmax labels of the indicator functions) and random label
// volumes. Per run: output tets, meshing and certificate seconds, worst per-label volume error,
// components lost / lost_small / split / merged / spurious, spurious contact area, non-manifold interface
// edges and vertices, voxel agreement; each run before and after CleaveMesh's label repair, and
// the default and adaptive settings also with point contacts and volume_calibration 4 (with angles).
//
//   fidelity_benchmark [RESULTS_FILE] [SPHERES_DIR]
#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <thread>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/BackgroundMesh/OctreeBcc.h"
#include "Algorithms/Cleaving/Cleaver.h"
#include "Algorithms/Cleaving/LabelRepair.h"
#include "Algorithms/Cleaving/VolumeCalibration.h"
#include "Algorithms/Core/Phantom.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Algorithms/Quality/Certificate.h"
#include "Algorithms/Quality/MeshQuality.h"
#include "Algorithms/SizingField/SizingField.h"
#include "Fixtures/RandomLabels.h"

using namespace tetflow;

namespace {
double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

const char* kHeader =
    "# run                                      tets   mesh_s  cert_s  worst_vol_err      lost small split merged spur "
    "spur_contact_mm2  nm_edges nm_verts agree\n";

std::string qualityLine(const TetMesh& mesh) {
  NullProgress np;
  const QualityResult q = evaluateQuality(mesh, QualityParams{}, np);
  char buf[160];
  std::snprintf(buf, sizeof buf, "dihedral %.2f..%.2f deg, %lld tets below 10 deg", q.minDihedral, q.maxDihedral,
                static_cast<long long>(q.tetsBelow[1]));
  return buf;
}

std::string row(const std::string& what, const TetMesh& mesh, double meshSeconds, const LabelVolume& labels) {
  NullProgress np;
  const double a = now();
  const CertificateResult c = certifyMesh(mesh, labels, np);
  const double certSeconds = now() - a;
  char buf[512];
  std::snprintf(buf, sizeof buf, "%-38s %10zu %7.2f %7.2f %+8.2f%% (L%-3d) %5d %5d %5d %6d %4d %16.1f %9lld %8lld %.4f\n",
                what.c_str(), mesh.numTets(), meshSeconds, certSeconds, 100.0 * c.worstRelError, c.worstLabel, c.lost,
                c.lostSmall, c.split, c.merged, c.spurious, c.spuriousContactArea, static_cast<long long>(c.nonmanifoldEdges),
                static_cast<long long>(c.nonmanifoldVertices), c.agreement);
  return buf;
}

// A third row as Nets/adaptive_head.srn cleaves: volume_calibration 4 with the label repair,
// point contacts included.
std::string calibrated(const BackgroundMesh& bg, double bgSeconds, const MaterialSet& mats, const LabelVolume& labels,
                       bool stripZero) {
  NullProgress np;
  const double a = now();
  CleaveParams cp;
  if (stripZero) cp.strip_exterior = 0;
  LabelRepairParams rp;
  rp.points = true;
  VolumeCalibration cal;
  std::unique_ptr<OffsetMaterials> om;
  CleaveResult r = cleaveCalibrated(bg, mats, cp, 4, &rp, np, cal, om);
  repairLabels(r.mesh, *om, rp, np);
  const double seconds = bgSeconds + now() - a;
  return row("  + point contacts, calibration 4", r.mesh, seconds, labels) + "    " + qualityLine(r.mesh) + "\n";
}

// Two rows: the cleaved mesh, then the same after CleaveMesh's label repair (repair_labels).
std::string cleaveAndRepair(const std::string& what, const BackgroundMesh& bg, double bgSeconds,
                            const MaterialSet& mats, const LabelVolume& labels, bool stripZero) {
  NullProgress np;
  const double a = now();
  CleaveParams cp;
  if (stripZero) cp.strip_exterior = 0;
  CleaveResult r = cleave(bg, mats, cp, np);
  const double b = now();
  std::string out = row(what, r.mesh, bgSeconds + b - a, labels);
  repairLabels(r.mesh, mats, LabelRepairParams{}, np);
  return out + row("  + label repair", r.mesh, bgSeconds + now() - a, labels);
}

std::string regular(const std::string& what, const MaterialSet& mats, const LabelVolume& labels, double cell,
                    bool stripZero) {
  NullProgress np;
  const double a = now();
  const BackgroundMesh bg = generateRegularBcc(mats.grid(), BccParams{cell, 0.0}, np);
  return cleaveAndRepair(what, bg, now() - a, mats, labels, stripZero);
}

} // namespace

int main(int argc, char** argv) {
  const std::string results = argc > 1 ? argv[1] : "fidelity_results.txt";
  const std::string spheresDir = argc > 2 ? argv[2] : TETFLOW_TEST_DATA;
  std::ostringstream out;
  out << "# fidelity_benchmark on " << std::thread::hardware_concurrency() << " hardware threads (OpenMP "
      << omp_get_max_threads() << "); mesh_s = background + cleave seconds\n";
  NullProgress np;

  // Head phantom, as the default net (regular 4 mm, blend_sigma 0.3) and the levers around it.
  const Phantom ph = makePhantom(PhantomParams{});
  auto vol = std::make_shared<const LabelVolume>(ph.volume);
  out << "head phantom 97^3 voxels of 2 mm, labels 1 scalp, 2 skull, 3 CSF (one voxel), 4 brain; air stripped:\n"
      << kHeader;
  std::cout << out.str() << std::flush;
  for (double sigma : {1.0, 0.5, 0.3}) {
    const LabelMaterials head(vol, sigma);
    for (double cell : {4.0, 3.0, 2.0}) {
      char w[128];
      const char* which = sigma == 1.0 ? " (old default)" : sigma == 0.5 ? " (previous default)" : " (default)";
      std::snprintf(w, sizeof w, "regular %.0f mm, blend_sigma %.1f%s", cell, sigma, cell == 4.0 ? which : "");
      std::string r = regular(w, head, *vol, cell, true);
      if (cell == 4.0 && sigma == 0.5) {
        const double a = now();
        const BackgroundMesh bg = generateRegularBcc(head.grid(), BccParams{cell, 0.0}, np);
        r += calibrated(bg, now() - a, head, *vol, true);
      }
      out << r;
      std::cout << r << std::flush;
    }
  }
  // The adaptive net (sizing field rate 1, Lipschitz 0.5, sizes 4..32 -> octree_bcc -> cleave),
  // and the same field down to 2 mm with blend_sigma 0.5.
  for (const auto& [minSize, sigma] : {std::pair{4.0, 1.0}, std::pair{4.0, 0.5}, std::pair{2.0, 0.5}}) {
    const LabelMaterials head(vol, sigma);
    SizingFieldParams sp;
    sp.lipschitz = 0.5;
    sp.min_size = minSize;
    sp.max_size = 32;
    const double a = now();
    const SizingFieldResult f = computeSizingField(head, sp, np);
    const OctreeBccResult o = generateOctreeBcc(head.grid(), f.field, OctreeBccParams{}, np);
    char w[128];
    std::snprintf(w, sizeof w, "octree min %.0f, blend_sigma %.1f%s", minSize, sigma,
                  minSize == 4.0 ? (sigma == 1.0 ? " (old adaptive)" : " (adaptive)") : "");
    const double bgSeconds = now() - a;
    std::string lines = cleaveAndRepair(w, o.background, bgSeconds, head, *vol, true);
    if (minSize == 4.0 && sigma == 0.5) lines += calibrated(o.background, bgSeconds, head, *vol, true);
    out << lines;
    std::cout << lines << std::flush;
  }

  // Spheres: indicator functions; the labels are their argmax per voxel.
  std::vector<ScalarVolume> vols;
  for (int i = 1; i <= 4; ++i) vols.push_back(readScalarVolume(spheresDir + "/spheres" + std::to_string(i) + ".nrrd"));
  LabelVolume argmax;
  argmax.allocate(vols[0].grid, 0);
  for (size_t v = 0; v < argmax.data.size(); ++v) {
    int best = 0;
    for (int m = 1; m < 4; ++m)
      if (vols[size_t(m)].data[v] > vols[size_t(best)].data[v]) best = m;
    argmax.data[v] = best + 1;
  }
  const IndicatorMaterials spheres(std::move(vols), {1, 2, 3, 4});
  out << "spheres1..4 (28^3 indicator functions; certificate against their argmax labels):\n" << kHeader;
  for (double cell : {2.0, 1.0, 0.5}) {
    char w[64];
    std::snprintf(w, sizeof w, "regular %.1f voxels", cell);
    out << regular(w, spheres, argmax, cell, false);
  }

  // Random label volumes: Voronoi cells plus one-voxel sheets, 32^3, the default blend_sigma 0.5,
  // lattice cells of 1 and 1.5 voxels (the same six volumes at both).
  for (double cell : {1.0, 1.5}) {
    char w[160];
    std::snprintf(w, sizeof w, "random label volumes (32^3 Voronoi cells of 2-6 labels plus two one-voxel sheets), regular %.1f voxels:\n", cell);
    out << w << kHeader;
    std::mt19937 rng(11);
    for (int c = 0; c < 6; ++c) {
      auto lv = std::make_shared<const LabelVolume>(test::voronoiWithSheets(rng, 32));
      const LabelMaterials mats(lv, 0.5);
      out << regular("random seed 11 case " + std::to_string(c), mats, *lv, cell, false);
    }
  }

  std::cout << out.str().substr(out.str().find("spheres1..4"));
  std::ofstream(results) << out.str();
  return 0;
}
