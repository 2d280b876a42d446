// Lattice cleaving: validity, conformity, volume, angle bounds and fidelity on random label
// volumes, phantoms and Cleaver's spheres indicator functions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/Cleaving/Cleaver.h"
#include "Algorithms/Core/Phantom.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Algorithms/Quality/MeshQuality.h"
#include "Fixtures/RandomCleaverVolumes.h"
#include "Fixtures/MeshChecks.h"
#include "TestUtil.h"

using namespace tetflow;
using tetflow::test::randomVolume;

namespace {

// Smallest dihedral angle seen over all random cases must stay above this (measured minimum
// over the cases below: see README "Mesh quality"; the bound leaves a margin). Cuts placed where
// the functions cross (interface_points exact, the default on lattices) sit where the voxels put them rather than
// where a linear interpolation would spread them: measured [3.10, 171.2] against [4.95, 170.3].
// CleaveMesh's improvement brings both to [10, 160].
constexpr double kMinDihedralBound = 4.5, kMinDihedralBoundExact = 2.5;
constexpr double kMaxDihedralBound = 172.0, kMaxDihedralBoundExact = 174.0;

void boxOf(const GridGeometry& g, Vec3& lo, Vec3& hi) {
  for (int a = 0; a < 3; ++a) {
    lo[a] = g.origin[a] - 0.5 * g.spacing[a];
    hi[a] = g.origin[a] + (double(g.dims[a]) - 0.5) * g.spacing[a];
  }
}

struct Outcome {
  QualityResult q;
  CleaveResult r;
};

Outcome cleaveAndCheck(const std::shared_ptr<const LabelVolume>& vol, double cellSize, CleaveParams cp,
                       const std::string& what) {
  LabelMaterials mats(vol, 1.0);
  NullProgress np;
  const BackgroundMesh bg = generateRegularBcc(vol->grid, BccParams{cellSize, 0.0}, np);
  Outcome o;
  o.r = cleave(bg, mats, cp, np);
  o.q = evaluateQuality(o.r.mesh, QualityParams{}, np);
  SCOPED_TRACE(what);
  tetflow::test::expectValidClosedMesh(o.q);
  EXPECT_NEAR(o.q.volume, bg.boxVolume, 1e-9 * bg.boxVolume);
  EXPECT_EQ(tetflow::test::openMaterialSurfaceEdges(o.r.mesh), 0);
  return o;
}

} // namespace

TEST(BccLattice, CoversTheBoxExactly) {
  GridGeometry g;
  g.dims = {20, 13, 9};
  g.spacing = {0.5, 0.75, 1.25};
  g.origin = {3, -2, 10};
  NullProgress np;
  const BackgroundMesh bg = generateRegularBcc(g, BccParams{1.7, 0.3}, np);
  const QualityResult q = evaluateQuality(bg.mesh, QualityParams{}, np);
  EXPECT_TRUE(q.valid);
  EXPECT_TRUE(q.boundaryClosed);
  Vec3 lo, hi;
  boxOf(g, lo, hi);
  const double box = (hi[0] - lo[0] + 0.6) * (hi[1] - lo[1] + 0.6) * (hi[2] - lo[2] + 0.6);
  EXPECT_NEAR(q.volume, box, 1e-9 * box);
  EXPECT_NEAR(bg.boxVolume, box, 1e-9 * box);
  // Cells tile the box exactly: every vertex lies inside it (with the padding).
  for (const Vec3& p : bg.mesh.points)
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(p[a], lo[a] - 0.3 - 1e-9);
      EXPECT_LE(p[a], hi[a] + 0.3 + 1e-9);
    }
  // Interior lattice tets are BCC tets (60 and 90 degrees); the bisected ones at the box have 45.
  EXPECT_NEAR(q.maxDihedral, 90.0, 25.0);
  EXPECT_GT(q.minDihedral, 40.0);
  EXPECT_THROW_MSG(generateRegularBcc(g, BccParams{0.0, 0.0}, np), InputError, "cell_size");
  EXPECT_THROW_MSG(generateRegularBcc(g, BccParams{1.0, -1.0}, np), InputError, "padding");
}

TEST(BccLattice, RegularCubeCellsGiveExactBccAngles) {
  GridGeometry g;
  g.dims = {8, 8, 8};
  NullProgress np;
  const BackgroundMesh bg = generateRegularBcc(g, BccParams{2.0, 0.0}, np);
  EXPECT_EQ(bg.cells, (std::array<int64_t, 3>{4, 4, 4}));
  EXPECT_EQ(bg.mesh.numTets(), size_t(12 * 64 + 4 * 3 * 16));
}

TEST(Cleaver, RandomLabelVolumesGiveValidConformingMeshes) {
  for (bool exact : {false, true}) {
    double worstMin = 180, worstMax = 0;
    int cases = 0;
    CleaveParams cp;
    cp.interface_points = exact ? CleaveParams::InterfacePoints::Exact : CleaveParams::InterfacePoints::Linear;
    for (int kind = 0; kind < 4; ++kind)
      for (unsigned seed = 1; seed <= unsigned(test::sanitizerCases(6)); ++seed)
        for (double cell : {1.0, 1.7, 2.6}) {
          const auto vol = randomVolume(kind, 1000 * kind + seed);
          const std::string what = "kind " + std::to_string(kind) + " seed " + std::to_string(seed) + " cell " +
                                   std::to_string(cell) + (exact ? " exact" : " linear");
          const Outcome o = cleaveAndCheck(vol, cell, cp, what);
          worstMin = std::min(worstMin, o.q.minDihedral);
          worstMax = std::max(worstMax, o.q.maxDihedral);
          EXPECT_GE(o.q.minDihedral, exact ? kMinDihedralBoundExact : kMinDihedralBound) << what;
          EXPECT_LE(o.q.maxDihedral, exact ? kMaxDihedralBoundExact : kMaxDihedralBound) << what;
          ++cases;
        }
    std::printf("random label volumes (%s interfaces): %d cases, dihedral angles in [%.2f, %.2f] degrees\n",
                exact ? "exact" : "linear", cases, worstMin, worstMax);
  }
}

TEST(Cleaver, AlphaZeroIsPlainStencillingAndStillValid) {
  for (unsigned seed = 1; seed <= 4; ++seed) {
    const auto vol = randomVolume(0, 77 + seed);
    CleaveParams cp;
    cp.alpha_short = 0.0;
    cp.alpha_long = 0.0;
    cp.optimize_angles = false; // plain: no warps, no vertex optimization
    const Outcome o = cleaveAndCheck(vol, 1.6, cp, "alpha 0 seed " + std::to_string(seed));
    // No warps: every lattice vertex keeps its position (only exact-boundary snaps happen).
    EXPECT_EQ(o.r.stats.warpedVertices, 0);
  }
}

TEST(Cleaver, HeadPhantomVolumesConvergeAndInterfacesLieOnTheSpheres) {
  PhantomParams pp;
  pp.kind = PhantomKind::Head;
  // Layers 6 mm thick: resolved by every lattice below (2 cells or more across).
  pp.radius = 30;
  pp.skull_radius = 24;
  pp.csf_radius = 18;
  pp.brain_radius = 12;
  pp.voxel_size = 0.75;
  const Phantom ph = makePhantom(pp);
  const auto vol = std::make_shared<const LabelVolume>(ph.volume);
  double previousErr = 1e9;
  for (double cell : {4.0, 2.5, 1.5}) {
    const Outcome o = cleaveAndCheck(vol, cell, CleaveParams{}, "head cell " + std::to_string(cell));
    // Volume of every material against the voxels it came from.
    double err = 0;
    for (const auto& m : o.r.materials)
      err = std::max(err, std::abs(m.meshVolume - m.inputVolume) / m.inputVolume);
    std::printf("head phantom cell %.1f mm: %zu tets, max relative volume error %.4f, dihedral [%.2f, %.2f]\n",
                cell, o.r.mesh.numTets(), err, o.q.minDihedral, o.q.maxDihedral);
    EXPECT_LT(err, previousErr) << "cell " << cell;
    previousErr = err;
    // Vertices between two layers lie near the sphere that separates them.
    const TetMesh& m = o.r.mesh;
    std::vector<std::set<int32_t>> mats(m.points.size());
    for (size_t t = 0; t < m.tets.size(); ++t)
      for (int32_t v : m.tets[t]) mats[v].insert(m.materials[t]);
    const double radii[] = {30, 24, 18, 12}; // between labels (0,1), (1,2), (2,3), (3,4)
    double worst = 0;
    for (size_t v = 0; v < m.points.size(); ++v) {
      if (mats[v].size() != 2) continue;
      const int32_t a = *mats[v].begin(), b = *mats[v].rbegin();
      if (b != a + 1) continue;
      worst = std::max(worst, std::abs(norm(m.points[v]) - radii[a]));
    }
    std::printf("  interface vertices within %.3f mm of their sphere\n", worst);
    EXPECT_LT(worst, 0.5 * cell) << "cell " << cell;
  }
  EXPECT_LT(previousErr, 0.03);
}

TEST(Cleaver, LostMaterialIsReportedNotSilent) {
  PhantomParams pp;
  pp.kind = PhantomKind::Blob;
  pp.radius = 6;
  pp.voxel_size = 1.0;
  const Phantom ph = makePhantom(pp);
  const auto vol = std::make_shared<const LabelVolume>(ph.volume);
  const Outcome coarse = cleaveAndCheck(vol, 6.0, CleaveParams{}, "blob coarse");
  ASSERT_EQ(coarse.r.materials.size(), 3u);
  EXPECT_TRUE(coarse.r.materials[2].lost());
  EXPECT_DOUBLE_EQ(coarse.r.materials[2].inputVolume, 7.0);
  Report rep;
  writeCleaveReport(coarse.r, rep);
  EXPECT_EQ(std::get<std::string>(*rep.find("materials_lost")), "2");
  const Outcome fine = cleaveAndCheck(vol, 0.8, CleaveParams{}, "blob fine");
  EXPECT_FALSE(fine.r.materials[2].lost());
}

TEST(Cleaver, StripExteriorRemovesTheBackground) {
  PhantomParams pp;
  pp.kind = PhantomKind::Sphere;
  pp.radius = 8;
  pp.voxel_size = 1.0;
  const Phantom ph = makePhantom(pp);
  auto vol = std::make_shared<const LabelVolume>(ph.volume);
  LabelMaterials mats(vol, 1.0);
  NullProgress np;
  const BackgroundMesh bg = generateRegularBcc(vol->grid, BccParams{1.5, 0.0}, np);
  CleaveParams cp;
  cp.strip_exterior = 0;
  const CleaveResult r = cleave(bg, mats, cp, np);
  for (int32_t m : r.mesh.materials) EXPECT_EQ(m, 1);
  const QualityResult q = evaluateQuality(r.mesh, QualityParams{}, np);
  EXPECT_TRUE(q.valid);
  // The sphere's surface is the boundary now: no holes (a voxelised surface may touch itself
  // along an edge, which is why manifoldness is not asserted).
  EXPECT_EQ(q.openBoundaryEdges, 0);
  EXPECT_EQ(q.unreferencedVertices, 0);
  EXPECT_NEAR(q.volume, 4.0 / 3.0 * M_PI * 512, 0.05 * 4.0 / 3.0 * M_PI * 512);
}

TEST(Cleaver, SpheresIndicatorFunctions) {
  std::vector<ScalarVolume> v;
  for (int i = 1; i <= 4; ++i)
    v.push_back(readScalarVolume(std::string(TETFLOW_TEST_DATA) + "/spheres" + std::to_string(i) + ".nrrd"));
  IndicatorMaterials mats(std::move(v));
  NullProgress np;
  for (double cell : {1.0, 2.0}) {
    const BackgroundMesh bg = generateRegularBcc(mats.grid(), BccParams{cell, 0.0}, np);
    const CleaveResult r = cleave(bg, mats, CleaveParams{}, np);
    const QualityResult q = evaluateQuality(r.mesh, QualityParams{}, np);
    EXPECT_TRUE(q.valid);
    EXPECT_NEAR(q.volume, bg.boxVolume, 1e-9 * bg.boxVolume);
    EXPECT_EQ(tetflow::test::openMaterialSurfaceEdges(r.mesh), 0);
    EXPECT_GE(q.minDihedral, kMinDihedralBound);
    for (const auto& m : r.materials) EXPECT_FALSE(m.lost()) << m.label;
  }
}

TEST(Cleaver, CancellingFromAWorkerThreadThrowsCancelled) {
  // The first progress report comes from inside the parallel sampling loop; cancelling there must
  // end the run with Cancelled after the loop (an exception inside an OpenMP region would abort).
  struct CancelOnFirstReport : Progress {
    void onReport(double) override { requestCancel(); }
  };
  PhantomParams pp;
  pp.kind = PhantomKind::Sphere;
  pp.radius = 20;
  const Phantom ph = makePhantom(pp);
  auto vol = std::make_shared<const LabelVolume>(ph.volume);
  LabelMaterials mats(vol, 1.0);
  NullProgress np;
  const BackgroundMesh bg = generateRegularBcc(vol->grid, BccParams{1.0, 0.0}, np);
  CancelOnFirstReport cancel;
  EXPECT_THROW(cleave(bg, mats, CleaveParams{}, cancel), Cancelled);
}

TEST(Cleaver, BadParametersAreInputErrors) {
  PhantomParams pp;
  pp.kind = PhantomKind::Sphere;
  pp.radius = 4;
  const Phantom ph = makePhantom(pp);
  auto vol = std::make_shared<const LabelVolume>(ph.volume);
  LabelMaterials mats(vol, 1.0);
  NullProgress np;
  const BackgroundMesh bg = generateRegularBcc(vol->grid, BccParams{2.0, 0.0}, np);
  CleaveParams cp;
  cp.alpha_long = 0.5;
  EXPECT_THROW_MSG(cleave(bg, mats, cp, np), InputError, "alpha");
  EXPECT_THROW_MSG(LabelMaterials(vol, 0.0), InputError, "blend_sigma");
}

TEST(Cleaver, AggressiveAlphasStillGiveValidMeshes) {
  // Beyond the defaults warps could flatten background tets; they are cut back instead.
  for (unsigned seed = 1; seed <= 3; ++seed) {
    const auto vol = randomVolume(0, 500 + seed);
    CleaveParams cp;
    cp.alpha_short = 0.49;
    cp.alpha_long = 0.49;
    cleaveAndCheck(vol, 1.3, cp, "alpha 0.49 seed " + std::to_string(seed));
  }
}
