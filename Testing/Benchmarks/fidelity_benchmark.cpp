// Fidelity benchmark: how well meshes keep their segmentation, judged by the mesh certificate
// (Algorithms/Quality/Certificate.h), before and after the fidelity steps of issue 25, with the
// time of each part.
//
//   before   the pipeline as it was: a lattice not refined at thin layers, interface points by
//            linear interpolation (the seed), label repair without point contacts, the label
//            stripped entirely (cavities too), no volume correction;
//   after    every module's default: lattices refined where a layer separates labels that do
//            not touch near the edge, interface points where the functions cross (BCC), repair with point contacts,
//            the exterior stripped (cavities kept), volume correction, the final fragments pass.
// Both with blend_sigma 0.3 and the label-preserving improvement, as CleaveMesh runs them.
//
// Inputs: the head phantom (2 mm voxels, one-voxel CSF) on regular lattices of 3 to 6 mm (every
// 0.5 mm), on the octree and the particle background of the adaptive nets; the layered head
// (1 mm, 182 x 218 x 182, six labels, air cavities; Testing/Fixtures/LayeredHead.h, from
// mricron-data) on a 4 mm lattice and the octree; a liver-sized smooth organ (438 x 353 x 165
// voxels, nothing to repair) on a 4.3 mm lattice. With --random, instead: random segmentations
// (Voronoi cells and two one-voxel sheets, 40^3 in a stripped margin) on lattices of 2 to 6 voxels
// at random offsets, before, after, and after with refine_thin_layers all (a sheet inside one
// Voronoi cell separates nothing, so the default does not refine for it).
// Per run: tets, worst per-label volume error (every label compared) and which label, the worst
// over labels of >= 1000 voxels (the bound), the voxel agreement (voxel centres inside
// their own label's tets, over the compared labels), components lost / split / merged / spurious, spurious contact area, dihedral range, and the
// seconds of the background, the cleave (cleaving, stripping, improvement), the repair, the
// correction, the certificate.
//
//   fidelity_benchmark [RESULTS_FILE] [--quick | --organ | --random]
//   fidelity_benchmark --write-organ OUT.nrrd    (the organ below, as a file)
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
#include "Algorithms/BackgroundMesh/Particles.h"
#include "Algorithms/BackgroundMesh/ThinLayers.h"
#include "Algorithms/Cleaving/CleavePipeline.h"
#include "Algorithms/Core/Phantom.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Algorithms/MeshImprovement/MeshImprovement.h"
#include "Algorithms/Quality/Certificate.h"
#include "Algorithms/Quality/MeshQuality.h"
#include "Algorithms/SizingField/SizingField.h"
#include "Fixtures/LayeredHead.h"
#include "Fixtures/RandomLabels.h"

using namespace tetflow;

namespace {
double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

// Stage seconds by name prefix.
struct Timer : Progress {
  double of(const std::string& prefix) const {
    double s = 0;
    for (const auto& st : stageTimes())
      if (st.name.rfind(prefix, 0) == 0) s += st.seconds;
    return s;
  }
};

enum class Background { Regular, Octree, Particles };

struct Setup {
  bool after = true;
  Background kind = Background::Regular;
  double cell = 4.0;          // mm (regular)
  double padding = 0.0;       // mm (regular)
  std::optional<int32_t> strip;
  SizingFieldParams sizing;   // octree / particles
  EdgeTopology::Mode thin = EdgeTopology::Mode::Separating; // after: refine_thin_layers
};

const char* kHeader =
    "# run                                              tets  worst_vol_err (label)  err_1000  agree  lost split merged spur "
    "spur_contact_mm2  dihedral_deg       bg_s  cleave_s repair_s correct_s cert_s\n";

std::string runOne(const std::string& what, const LabelVolume& labels, const Setup& s) {
  auto vol = std::make_shared<const LabelVolume>(labels);
  const LabelMaterials mats(vol, kDefaultBlendSigma);
  NullProgress np;
  // Background.
  double t0 = now();
  BackgroundMesh bg;
  std::optional<EdgeTopology> thin;
  if (s.after) thin.emplace(labels, s.thin);
  if (s.kind == Background::Regular) {
    bg = s.after ? generateThinLayerBcc(labels.grid, BccParams{s.cell, s.padding}, OctreeBccParams{}, *thin, np).background
                 : generateRegularBcc(labels.grid, BccParams{s.cell, s.padding}, np);
  } else {
    const SizingFieldResult f = computeSizingField(mats, s.sizing, np);
    if (s.kind == Background::Octree)
      bg = generateOctreeBcc(labels.grid, f.field, OctreeBccParams{}, np, nullptr, thin ? &*thin : nullptr).background;
    else
      bg = generateParticleMesh(labels.grid, f.field, ParticleParams{}, np).background;
  }
  const double bgSeconds = now() - t0;
  // CleaveMesh.
  Timer timer;
  CleavePipelineParams pp;
  pp.strip = s.strip;
  if (!s.after) {
    pp.cleave.interface_points = CleaveParams::InterfacePoints::Linear;
    pp.repairParams.points = false;
    pp.stripCavities = true;
    pp.correct = false;
  }
  t0 = now();
  CleavePipelineResult r = cleavePipeline(bg, mats, pp, timer);
  improveMesh(r.cleaved.mesh, ImproveParams{}, timer, &r.faceNeighbours);
  if (s.after) finishLabels(r.cleaved.mesh, mats, r, timer);
  const double total = now() - t0;
  const double repair = timer.of("repair") + timer.of("image topology");
  const double correct = timer.of("correct");
  const double cleaveOnly = total - repair - correct;
  // Certificate and quality.
  t0 = now();
  const CertificateResult c = certifyMesh(r.cleaved.mesh, labels, np);
  const double certSeconds = now() - t0;
  const QualityResult q = evaluateQuality(r.cleaved.mesh, QualityParams{}, np);
  double worst = 0.0, worstLarge = 0.0; // over every label; over labels of >= 1000 voxels (the bound)
  int32_t worstLabel = -1;
  for (const auto& lc : c.labels) {
    if (lc.excluded) continue;
    if (std::abs(lc.relError) > std::abs(worst)) {
      worst = lc.relError;
      worstLabel = lc.label;
    }
    if (lc.voxels >= 1000 && std::abs(lc.relError) > std::abs(worstLarge)) worstLarge = lc.relError;
  }
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "%-46s %10zu %+9.2f%% (L%-3d) %+7.2f%% %6.3f %5d %5d %6d %4d %16.1f  [%5.1f, %5.1f] %8.2f %8.2f %8.2f %8.2f %7.2f\n",
                what.c_str(), r.cleaved.mesh.numTets(), 100.0 * worst, worstLabel, 100.0 * worstLarge, c.agreement, c.lost, c.split, c.merged, c.spurious,
                c.spuriousContactArea, q.minDihedral, q.maxDihedral, bgSeconds, cleaveOnly, repair, correct, certSeconds);
  return buf;
}

// A smooth organ filling about a third of a liver-sized box (438 x 353 x 165 voxels of 0.8 x 0.8
// x 2 mm): one label in the background, a bumpy ellipsoid. Nothing thin, nothing to repair.
LabelVolume organ() {
  LabelVolume v;
  GridGeometry g;
  g.dims = {438, 353, 165};
  g.spacing = {0.8, 0.8, 2.0};
  v.allocate(g, 0);
#pragma omp parallel for schedule(static)
  for (int64_t k = 0; k < g.dims[2]; ++k)
    for (int64_t j = 0; j < g.dims[1]; ++j)
      for (int64_t i = 0; i < g.dims[0]; ++i) {
        const double x = (double(i) - 219) / 170, y = (double(j) - 176) / 130, z = (double(k) - 82) / 65;
        const double bump = 0.08 * std::sin(7 * x) * std::cos(5 * y) + 0.06 * std::sin(4 * z + 3 * x);
        v.at(i, j, k) = x * x + y * y + z * z < 1.0 + bump ? 1 : 0;
      }
  return v;
}

} // namespace

int main(int argc, char** argv) {
  std::string results = "fidelity_results.txt";
  bool quick = false, organOnly = false, randomOnly = false;
  for (int a = 1; a < argc; ++a) {
    const std::string s = argv[a];
    if (s == "--quick") quick = true;
    else if (s == "--organ") organOnly = true;
    else if (s == "--random") randomOnly = true;
    else if (s == "--write-organ" && a + 1 < argc) { // the organ as a file, for pipeline_targets.sh
      writeVolume(argv[a + 1], fromLabelVolume(organ()));
      return 0;
    } else results = s;
  }
  std::ostringstream out;
  auto emit = [&](const std::string& s) {
    out << s;
    std::cout << s << std::flush;
  };
  emit("# fidelity_benchmark on " + std::to_string(std::thread::hardware_concurrency()) + " hardware threads (OpenMP " +
       std::to_string(omp_get_max_threads()) +
       "); cleave_s = cleaving, stripping and improvement; repair_s = label repair with its image analysis (which "
       "stripping uses too); worst_vol_err over every label compared\n");

  const Phantom ph = makePhantom(PhantomParams{});
  if (!organOnly && !randomOnly) {
  // Head phantom: the default net at every cell size, before and after; the adaptive nets.
  emit("head phantom 97^3 voxels of 2 mm, labels 1 scalp, 2 skull, 3 CSF (one voxel), 4 brain; air (0) stripped:\n");
  emit(kHeader);
  for (double cell = 3.0; cell <= 6.0; cell += 0.5)
    for (bool after : {false, true}) {
      if (quick && cell != 4.0) continue;
      Setup s;
      s.after = after;
      s.cell = cell;
      s.strip = 0;
      char w[96];
      std::snprintf(w, sizeof w, "default net, cell %.1f mm, %s", cell, after ? "after" : "before");
      emit(runOne(w, ph.volume, s));
    }
  for (Background kind : {Background::Octree, Background::Particles})
    for (bool after : {false, true}) {
      if (quick && kind == Background::Particles) continue;
      Setup s;
      s.after = after;
      s.kind = kind;
      s.strip = 0;
      s.sizing.lipschitz = 0.5;
      s.sizing.min_size = 4;
      s.sizing.max_size = 32;
      emit(runOne(std::string(kind == Background::Octree ? "adaptive (octree), " : "particles, ") +
                      (after ? "after" : "before"),
                  ph.volume, s));
    }

  // The layered head at 1 mm.
  std::string why;
  if (mricronAtlasesPresent(mricronTemplatesDir(), &why)) {
    for (int variant : {0, 1}) {
      if (quick && variant > 0) continue;
      LayeredHeadParams hp;
      hp.variant = variant;
      const LabelVolume head = makeLayeredHead(mricronTemplatesDir(), hp);
      emit("layered head variant " + std::to_string(variant) +
           ", 1 mm, 182 x 218 x 182, labels 0 air (outside and cavities), 1 scalp, 2 skull, 3 CSF, 4 grey, 5 white; "
           "air stripped:\n");
      emit(kHeader);
      for (bool after : {false, true}) {
        Setup s;
        s.after = after;
        s.strip = 0;
        emit(runOne(std::string("default net, cell 4 mm, ") + (after ? "after" : "before"), head, s));
        s.kind = Background::Octree;
        s.sizing.lipschitz = 0.5;
        s.sizing.min_size = 4;
        s.sizing.max_size = 32;
        emit(runOne(std::string("adaptive (octree), ") + (after ? "after" : "before"), head, s));
      }
    }
  } else {
    emit("layered head: skipped (" + why + ")\n");
  }

  } // !organOnly && !randomOnly
  // Random segmentations at every cell size from 2 to 6 voxels, at random offsets.
  if (randomOnly) {
  emit("random segmentations (40^3 Voronoi cells of 2-6 labels plus two one-voxel sheets, in a 2-voxel margin of "
       "label 99, stripped), regular lattices at random paddings:\n");
  emit(kHeader);
  std::mt19937 rng(25);
  for (int c = 0; c < (quick ? 1 : 3); ++c) {
    const LabelVolume base = test::voronoiWithSheets(rng, 40);
    LabelVolume v;
    GridGeometry g = base.grid;
    for (int a = 0; a < 3; ++a) g.dims[size_t(a)] += 4;
    v.allocate(g, 99);
    for (int64_t k = 0; k < base.grid.dims[2]; ++k)
      for (int64_t j = 0; j < base.grid.dims[1]; ++j)
        for (int64_t i = 0; i < base.grid.dims[0]; ++i) v.at(i + 2, j + 2, k + 2) = base.at(i, j, k);
    for (double cell = 2.0; cell <= 6.0; cell += 0.5)
      for (int o = 0; o < 2; ++o) {
        const double padding = double(rng() % 1000) / 1000.0;
        for (int run = 0; run < 3; ++run) {
          if (quick && (o > 0 || cell > 3.0)) continue;
          Setup s;
          s.after = run > 0;
          s.cell = cell;
          s.padding = padding;
          s.strip = 99;
          if (run == 2) s.thin = EdgeTopology::Mode::All;
          char w[96];
          std::snprintf(w, sizeof w, "case %d, cell %.1f, padding %.3f, %s", c, cell, padding,
                        run == 0 ? "before" : run == 1 ? "after" : "after, all");
          emit(runOne(w, v, s));
        }
      }
  }

  } // randomOnly
  // A liver-sized organ: nothing to repair; what the repair costs then.
  if (!quick && !randomOnly) {
    emit("liver-sized organ (438 x 353 x 165 voxels of 0.8 x 0.8 x 2 mm, one smooth label), regular 4.3 mm, "
         "background stripped:\n");
    emit(kHeader);
    const LabelVolume v = organ();
    for (bool after : {false, true}) {
      Setup s;
      s.after = after;
      s.cell = 4.3;
      s.strip = 0;
      emit(runOne(std::string("organ, ") + (after ? "after" : "before"), v, s));
    }
  }
  std::ofstream(results) << out.str();
  return 0;
}
