// Volume correction (VolumeCorrection.h) and stripping the exterior (Stripping.h): exact volumes
// after the correction, geometry only (labels, connectivity and the box kept), angle bounds kept;
// the exterior removed and its cavities kept, as the certificate then sees them.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/Cleaving/Cleaver.h"
#include "Algorithms/Cleaving/Stripping.h"
#include "Algorithms/Cleaving/VolumeCorrection.h"
#include "Algorithms/Quality/Certificate.h"
#include "Algorithms/Quality/LabelTopology.h"
#include "Algorithms/Quality/MeshQuality.h"
#include "Fixtures/LabelShapes.h"
#include "Fixtures/MeshChecks.h"
#include "Fixtures/RandomLabels.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {

// n^3 voxels of 1 mm: 0 outside radius r1, 1 between r0 and r1, 2 inside r0 (voxel centres).
LabelVolume nested(int n, double r0, double r1) { return test::nestedBalls(n, r0, r1); }

struct Cleaved {
  BackgroundMesh bg;
  CleaveResult r;
  DomainBox box;
};

Cleaved cleaveIt(const LabelVolume& v, double cell) {
  NullProgress np;
  Cleaved c;
  const LabelMaterials mats(std::make_shared<const LabelVolume>(v), kDefaultBlendSigma);
  c.bg = generateRegularBcc(v.grid, BccParams{cell, 0.0}, np);
  c.r = cleave(c.bg, mats, CleaveParams{}, np);
  c.box = domainBoxOf(c.bg.mesh, v.grid.direction, v.grid.origin);
  return c;
}

std::vector<double> volumesOf(const TetMesh& m, const std::vector<int32_t>& labels) {
  std::vector<double> v;
  for (const auto& t : tallyMaterials(m, labels)) v.push_back(t.volume);
  return v;
}

} // namespace

TEST(VolumeCorrection, EveryMaterialReachesItsTargetAndOnlyVerticesMove) {
  const LabelVolume v = nested(24, 5.0, 9.0);
  Cleaved c = cleaveIt(v, 2.0);
  const std::vector<int32_t> labels{0, 1, 2};
  const std::vector<double> start = volumesOf(c.r.mesh, labels);
  // Targets off by a few percent in both directions; the total stays the box.
  std::vector<double> target{start[0] - 0.03 * start[1] + 0.01 * start[2], 1.03 * start[1], 0.99 * start[2]};
  const TetMesh before = c.r.mesh;
  NullProgress np;
  const QualityResult q0 = evaluateQuality(before, QualityParams{}, np);
  const VolumeCorrectionStats s = correctVolumes(c.r.mesh, labels, target, c.box, VolumeCorrectionParams{}, np);
  const std::vector<double> after = volumesOf(c.r.mesh, labels);
  for (size_t i = 0; i < labels.size(); ++i) {
    EXPECT_NEAR(after[i], target[i], 1e-3 * target[i]) << "label " << labels[i];
    EXPECT_NEAR(s.errorAfter[i], (after[i] - target[i]) / target[i], 1e-12);
  }
  EXPECT_GT(s.rounds, 0);
  EXPECT_GT(s.shift[1], 0.0); // the shell grew outward
  EXPECT_LT(s.shift[2], 0.0); // the core shrank
  // Geometry only: labels and tets as they were, every tet positive, the box filled exactly, and
  // no angle taken outside [10, 160] that was inside.
  EXPECT_EQ(c.r.mesh.tets, before.tets);
  EXPECT_EQ(c.r.mesh.materials, before.materials);
  const QualityResult q = evaluateQuality(c.r.mesh, QualityParams{}, np);
  test::expectValidClosedMesh(q);
  EXPECT_NEAR(q.volume, c.bg.boxVolume, 1e-9 * c.bg.boxVolume);
  EXPECT_GE(q.minDihedral, std::min(q0.minDihedral, 10.0) - 1e-9);
  EXPECT_LE(q.maxDihedral, std::max(q0.maxDihedral, 160.0) + 1e-9);
  for (size_t p = 0; p < before.points.size(); ++p) { // vertices on the box stay on its faces
    const uint8_t f = c.box.fixedAxes(before.points[p]);
    EXPECT_EQ(c.box.fixedAxes(c.r.mesh.points[p]) & f, f) << p;
  }
}

TEST(VolumeCorrection, NothingToCorrectChangesNothing) {
  const LabelVolume v = nested(20, 4.0, 7.0);
  Cleaved c = cleaveIt(v, 2.0);
  const std::vector<int32_t> labels{0, 1, 2};
  const std::vector<double> target = volumesOf(c.r.mesh, labels);
  const TetMesh before = c.r.mesh;
  NullProgress np;
  const VolumeCorrectionStats s = correctVolumes(c.r.mesh, labels, target, c.box, VolumeCorrectionParams{}, np);
  EXPECT_EQ(s.rounds, 0);
  EXPECT_EQ(c.r.mesh.points, before.points);
  // A label without a target (<= 0) is left to follow; sizes must agree; bad parameters are named.
  EXPECT_THROW_MSG(correctVolumes(c.r.mesh, labels, {1.0, 2.0}, c.box, VolumeCorrectionParams{}, np), InputError,
                   "one target per label");
  VolumeCorrectionParams bad;
  bad.rounds = 21;
  EXPECT_THROW_MSG(correctVolumes(c.r.mesh, labels, target, c.box, bad, np), InputError, "rounds");
}

TEST(Stripping, TheExteriorGoesTheCavitiesStayAndTheCertificateComparesWhatWasKept) {
  // Label 0 outside a ball of 1, and a cavity of 0 inside it (enclosed), plus a channel of 0 from
  // the outside into the ball (part of the exterior).
  LabelVolume v = nested(28, 4.0, 11.0);
  for (int k = 0; k < 28; ++k)
    for (int j = 0; j < 28; ++j)
      for (int i = 0; i < 28; ++i) {
        if (v.at(i, j, k) == 2) v.at(i, j, k) = 0; // the cavity
        if (std::abs(j - 13.5) < 1.1 && std::abs(k - 13.5) < 1.1 && i > 21) v.at(i, j, k) = 0; // the channel
      }
  int64_t cavity = 0;
  {
    const LabelVolume nb = nested(28, 4.0, 11.0);
    for (size_t x = 0; x < nb.data.size(); ++x) cavity += nb.data[x] == 2;
  }
  Cleaved c = cleaveIt(v, 1.5);
  NullProgress np;
  const StripStats s = stripExterior(c.r.mesh, v, nullptr, StripParams{0, false}, c.box, np);
  EXPECT_EQ(s.cavityVoxels, cavity);
  EXPECT_EQ(s.cavityComponents, 1);
  EXPECT_GT(s.strippedTets, 0);
  EXPECT_GT(s.keptTets, 0);
  EXPECT_NEAR(s.keptVolume, double(cavity), 0.1 * double(cavity));
  // Valid, every vertex used (the 2-voxel channel may pinch the surface at an edge: not asserted).
  const QualityResult q = evaluateQuality(c.r.mesh, QualityParams{}, np);
  EXPECT_TRUE(q.valid);
  EXPECT_EQ(q.unreferencedVertices, 0);
  // Nothing of the exterior is left: every kept tet of label 0 lies in the cavity (radius < 5).
  const Vec3 centre{13.5, 13.5, 13.5};
  for (size_t t = 0; t < c.r.mesh.numTets(); ++t) {
    if (c.r.mesh.materials[t] == 0) {
      ASSERT_LT(norm(tetCentroid(c.r.mesh, t) - centre), 5.5) << t;
    }
  }
  // The certificate sees the exterior stripped and compares the cavity.
  const CertificateResult cert = certifyMesh(c.r.mesh, v, np);
  ASSERT_EQ(cert.strippedLabels, std::vector<int32_t>{0});
  EXPECT_TRUE(cert.excludedLabels.empty());
  for (const auto& lc : cert.labels)
    if (lc.label == 0) {
      EXPECT_EQ(lc.voxels, cavity);
      EXPECT_EQ(lc.voxels + lc.strippedVoxels, s.exteriorVoxels + s.cavityVoxels);
      EXPECT_EQ(lc.imageComponents, 1);
      EXPECT_LT(std::abs(lc.relError), 0.1);
    }
  EXPECT_EQ(cert.lost + cert.split + cert.merged + cert.spurious, 0);
  EXPECT_TRUE(cert.spuriousContacts.empty());

  // strip_cavities: the label goes entirely and the certificate excludes it.
  Cleaved all = cleaveIt(v, 1.5);
  const StripStats s2 = stripExterior(all.r.mesh, v, nullptr, StripParams{0, true}, all.box, np);
  EXPECT_EQ(s2.keptTets, 0);
  for (int32_t m : all.r.mesh.materials) ASSERT_NE(m, 0);
  const CertificateResult cert2 = certifyMesh(all.r.mesh, v, np);
  EXPECT_EQ(cert2.excludedLabels, std::vector<int32_t>{0});
  EXPECT_TRUE(cert2.strippedLabels.empty());
}

// Stripping on its own finds the label's components from its runs (no analysis of the whole
// image): on random label volumes with cavities, tubes and box contacts, it strips exactly what it
// strips with the full analysis (analyzeLabelImage, which the label repair passes it), and counts
// the same exterior and cavity voxels.
TEST(Stripping, TheLabelsOwnComponentsGiveWhatTheWholeImageAnalysisGives) {
  std::mt19937 rng(7);
  NullProgress np;
  int withCavities = 0;
  for (int c = 0; c < 8; ++c) {
    SCOPED_TRACE("case " + std::to_string(c));
    LabelVolume v = test::voronoiWithSheets(rng, 12 + int(rng() % 8));
    const int32_t L = int32_t(rng() % 3);
    // Blobs of L inside, some of them cavities.
    for (int b = 0; b < 3; ++b) {
      const int64_t ci = 2 + int64_t(rng() % uint32_t(v.grid.dims[0] - 4)), cj = 2 + int64_t(rng() % uint32_t(v.grid.dims[1] - 4)),
                    ck = 2 + int64_t(rng() % uint32_t(v.grid.dims[2] - 4));
      for (int64_t k = ck - 1; k <= ck + 1; ++k)
        for (int64_t j = cj - 1; j <= cj + 1; ++j)
          for (int64_t i = ci - 1; i <= ci + 1; ++i) v.at(i, j, k) = L;
    }
    const LabelImageTopology full = analyzeLabelImage(v, np);
    for (const auto& comp : full.comps) withCavities += comp.label == L && !comp.touchesBox ? 1 : 0;
    Cleaved a = cleaveIt(v, 1.5), b = cleaveIt(v, 1.5), c2 = cleaveIt(v, 1.5);
    // a computes the face neighbours it needs and hands them back, b is given them, c2 strips the
    // whole label with them given: each gets those of the stripped mesh back.
    std::vector<int32_t> nbA, nbB = tetFaceNeighbours(b.r.mesh, np), nbC = tetFaceNeighbours(c2.r.mesh, np);
    const StripStats sa = stripExterior(a.r.mesh, v, nullptr, StripParams{L, false}, a.box, np, nullptr, &nbA);
    const StripStats sb = stripExterior(b.r.mesh, v, &full, StripParams{L, false}, b.box, np, nullptr, &nbB);
    stripExterior(c2.r.mesh, v, nullptr, StripParams{L, true}, c2.box, np, nullptr, &nbC);
    EXPECT_EQ(sa.exteriorVoxels, sb.exteriorVoxels);
    EXPECT_EQ(sa.cavityVoxels, sb.cavityVoxels);
    EXPECT_EQ(sa.cavityComponents, sb.cavityComponents);
    EXPECT_EQ(sa.strippedTets, sb.strippedTets);
    EXPECT_EQ(a.r.mesh.tets, b.r.mesh.tets);
    EXPECT_EQ(a.r.mesh.materials, b.r.mesh.materials);
    if (sa.cavityVoxels > 0) {
      EXPECT_EQ(nbA, tetFaceNeighbours(a.r.mesh, np));
    } else {
      EXPECT_TRUE(nbA.empty()); // every tet of the label went: no face adjacency was needed
    }
    EXPECT_EQ(nbB, tetFaceNeighbours(b.r.mesh, np));
    EXPECT_EQ(nbC, tetFaceNeighbours(c2.r.mesh, np));
  }
  EXPECT_GT(withCavities, 3); // the cases do have cavities
}
