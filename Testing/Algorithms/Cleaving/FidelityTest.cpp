// Known-answer fidelity cases (issue "fidelity you can trust"): label volumes with thin or touchy
// structures, cleaved as CleaveMesh does by default (blend_sigma 0.5, label repair on) and judged by
// the certificate. Every case keeps exactly its components (none lost, split, merged or spurious),
// touches nothing the image does not touch, and stays valid; volume errors are asserted at the
// measured value plus a margin (measured figures in the comments, 2-core machine, same on any).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/BackgroundMesh/OctreeBcc.h"
#include "Algorithms/Cleaving/Cleaver.h"
#include "Algorithms/Cleaving/LabelRepair.h"
#include "Algorithms/Quality/Certificate.h"
#include "Algorithms/Quality/MeshQuality.h"
#include "Algorithms/SizingField/SizingField.h"
#include "Fixtures/RandomLabels.h"

namespace tetflow {
namespace {

// An n^3 volume of 1 mm voxels labelled by f(x, y, z), coordinates from the volume's centre.
LabelVolume makeVolume(int n, const std::function<int32_t(double, double, double)>& f) {
  LabelVolume v;
  GridGeometry g;
  g.dims = {n, n, n};
  v.allocate(g, 0);
  const double c = (n - 1) / 2.0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) v.at(i, j, k) = f(i - c, j - c, k - c);
  return v;
}

// Cleaves with CleaveMesh's defaults, checks validity and the topology rules, and returns the
// largest |relative volume error| over the labels.
double cleaveAndCertify(const LabelVolume& v, double cell) {
  NullProgress np;
  const auto vol = std::make_shared<const LabelVolume>(v);
  const LabelMaterials mats(vol, 0.5);
  const BackgroundMesh bg = generateRegularBcc(mats.grid(), BccParams{cell, 0.0}, np);
  CleaveResult r = cleave(bg, mats, CleaveParams{}, np);
  repairLabels(r.mesh, mats, LabelRepairParams{}, np);
  const QualityResult q = evaluateQuality(r.mesh, QualityParams{}, np);
  EXPECT_TRUE(q.valid);
  const CertificateResult c = certifyMesh(r.mesh, v, np);
  EXPECT_EQ(c.lost + c.lostSmall + c.split + c.merged + c.spurious, 0);
  EXPECT_TRUE(c.spuriousContacts.empty());
  EXPECT_TRUE(c.missingContacts.empty());
  double worst = 0.0;
  for (const auto& lc : c.labels) {
    EXPECT_EQ(lc.meshComponents, lc.imageComponents) << "label " << lc.label;
    worst = std::max(worst, std::abs(lc.relError));
  }
  return worst;
}

// Spherical shells around a core of radius 9 voxels: voxel centres with 9 <= r < 9 + t.
LabelVolume shell(double t) {
  return makeVolume(32, [t](double x, double y, double z) {
    const double r = std::sqrt(x * x + y * y + z * z);
    return r < 9 ? 2 : (r < 9 + t ? 1 : 0);
  });
}

TEST(Fidelity, ShellsOneToThreeVoxelsThickStayOneShell) {
  // Measured worst volume errors (the shell's) at 1-voxel cells: 7.5 %, 0.6 %, 0.6 %, 0.6 %.
  EXPECT_LT(cleaveAndCertify(shell(1.0), 1.0), 0.085);
  EXPECT_LT(cleaveAndCertify(shell(1.5), 1.0), 0.015);
  EXPECT_LT(cleaveAndCertify(shell(2.0), 1.0), 0.015);
  EXPECT_LT(cleaveAndCertify(shell(3.0), 1.0), 0.015);
  // At 2-voxel cells: 35.3 %, 22.0 %, 2.6 %, 2.5 %. The thin shells thin further on a coarse
  // lattice (the volume bound is open), but every one stays one closed shell.
  EXPECT_LT(cleaveAndCertify(shell(1.0), 2.0), 0.4);
  EXPECT_LT(cleaveAndCertify(shell(1.5), 2.0), 0.25);
  EXPECT_LT(cleaveAndCertify(shell(2.0), 2.0), 0.035);
  EXPECT_LT(cleaveAndCertify(shell(3.0), 2.0), 0.035);
}

TEST(Fidelity, ATubeStaysOneTube) {
  const LabelVolume tube = makeVolume(24, [](double x, double y, double) { return x * x + y * y < 2.25 ? 1 : 0; });
  EXPECT_LT(cleaveAndCertify(tube, 1.0), 0.13); // measured 12.1 % (the tube's)
  EXPECT_LT(cleaveAndCertify(tube, 2.0), 0.45); // measured 40.7 %, still one tube
}

TEST(Fidelity, TwoBlobsOneVoxelApartStayTwo) {
  const LabelVolume blobs = makeVolume(24, [](double x, double y, double z) {
    if (std::abs(y) <= 2.5 && std::abs(z) <= 2.5 && ((x >= -6.5 && x <= -0.5) || (x >= 1.5 && x <= 7.5))) return 1;
    return 0;
  });
  EXPECT_LT(cleaveAndCertify(blobs, 1.0), 0.04);  // measured 3.3 %
  EXPECT_LT(cleaveAndCertify(blobs, 2.0), 0.125); // measured 11.6 %, not merged
}

TEST(Fidelity, ACheckerboardCornerAndAnEdgeContactKeepTheirTopology) {
  // Octants in a checkerboard of two labels: each label's octants meet only along edges and at
  // the centre, so each label is one 26-connected component.
  const LabelVolume checker =
      makeVolume(16, [](double x, double y, double z) { return ((x > 0) + (y > 0) + (z > 0)) % 2 ? 1 : 2; });
  EXPECT_LT(cleaveAndCertify(checker, 1.0), 0.01); // measured 0.2 %
  EXPECT_LT(cleaveAndCertify(checker, 2.0), 0.01); // measured 0.6 %
  // Two blocks of one label touching along an edge only.
  const LabelVolume edge = makeVolume(16, [](double x, double y, double z) {
    return std::abs(z) < 4 && ((x < 0 && y < 0) || (x > 0 && y > 0)) ? 1 : 0;
  });
  EXPECT_LT(cleaveAndCertify(edge, 1.0), 0.01); // measured 0.8 %
}

// The adaptive pipeline with every default (ComputeSizingField -> octree_bcc -> CleaveMesh, as the
// modules' defaults are) on a 63^3 five-label segmentation with a 27-voxel material: every label and
// component is kept. A stand-in for the Mickey image of the issue, which is not available here.
// Random segmentations (Voronoi cells of 2..6 labels crossed by two one-voxel sheets) on a lattice
// of one voxel: every component kept, no wrong contact, every label within 3.5 % of its voxels
// (measured worst over seeds 11's first six volumes: -2.8 %). On 1.5-voxel cells the sheets are
// below the lattice and lose 9-40 % (fidelity benchmark); that is not asserted.
TEST(Fidelity, RandomSegmentationsWithOneVoxelSheetsKeepTheirTopologyOnAOneVoxelLattice) {
  std::mt19937 rng(11);
  for (int c = 0; c < 6; ++c) {
    const LabelVolume v = test::voronoiWithSheets(rng, 32);
    EXPECT_LE(cleaveAndCertify(v, 1.0), 0.035) << "case " << c;
  }
}

TEST(Fidelity, TheAdaptiveDefaultsKeepEveryComponentOfAFiveLabelSegmentation) {
  LabelVolume v = makeVolume(63, [](double x, double y, double z) {
    const double r = std::sqrt(x * x + y * y + z * z);
    int32_t L = r < 27 ? 2 : 0;                                  // a 2-voxel shell
    if (r < 25) L = 1;                                            // around a ball
    if (L == 1 && std::abs(z - 5) < 3 && x > -10 && x < 15) L = 3; // a slab in it
    if (L == 1 && (x - 8) * (x - 8) + (y + 8) * (y + 8) < 9) L = 4; // a rod, cut in two by the slab
    return L;
  });
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) v.at(20 + i, 40 + j, 20 + k) = 5; // 27 voxels
  NullProgress np;
  const auto vol = std::make_shared<const LabelVolume>(v);
  const LabelMaterials mats(vol, 0.5);
  const SizingFieldResult field = computeSizingField(mats, SizingFieldParams{}, np);
  const OctreeBccResult octree = generateOctreeBcc(mats.grid(), field.field, OctreeBccParams{}, np);
  CleaveResult r = cleave(octree.background, mats, CleaveParams{}, np);
  repairLabels(r.mesh, mats, LabelRepairParams{}, np);
  const QualityResult q = evaluateQuality(r.mesh, QualityParams{}, np);
  EXPECT_TRUE(q.valid);
  EXPECT_GE(q.minDihedral, 11.0); // measured 12.0
  const CertificateResult c = certifyMesh(r.mesh, v, np);
  EXPECT_EQ(c.lost + c.lostSmall + c.split + c.merged + c.spurious, 0);
  EXPECT_TRUE(c.spuriousContacts.empty());
  for (const auto& lc : c.labels) {
    EXPECT_EQ(lc.meshComponents, lc.imageComponents) << "label " << lc.label;
    // Measured: labels 0-4 within 1 %, the 27-voxel material -13.1 %.
    EXPECT_LT(std::abs(lc.relError), lc.label == 5 ? 0.15 : 0.01) << "label " << lc.label;
  }
}

} // namespace
} // namespace tetflow
