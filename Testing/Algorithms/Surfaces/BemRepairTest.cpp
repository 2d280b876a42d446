// Tests for Algorithms/Surfaces/BemRepair: pinched unions become manifold, inner unions stop
// touching the enclosing surface, the unions stay nested, and the enclosed volume moves by exactly
// the tets the repair reports, on hand-made pinches and on random nested blobs (fixed seeds).
#include "Algorithms/Surfaces/BemRepair.h"

#include <gtest/gtest.h>

#include <random>

#include "Algorithms/Quality/LabelTopology.h"
#include "Fixtures/VoxelMesh.h"

namespace tetflow {
namespace {

LabelVolume emptyVolume(int n) {
  LabelVolume v;
  GridGeometry g;
  g.dims = {n, n, n};
  g.spacing = {1.0, 1.5, 0.8};
  g.origin = {2, -1, 4};
  v.allocate(g, 0);
  return v;
}

double maskVolume(const TetMesh& m, const std::vector<uint8_t>& inside) {
  double s = 0;
  for (size_t t = 0; t < m.numTets(); ++t)
    if (inside[t]) s += m.tetVolume(t);
  return s;
}

struct Repaired {
  std::vector<uint8_t> inside;
  UnionRepair fix;
};

// Repairs the unions of `sets` outer to inner, each inside the one before, and checks what
// every repair must give.
std::vector<Repaired> repairNested(const TetMesh& m, const std::vector<std::vector<int32_t>>& sets) {
  Progress progress;
  const auto nb = tetFaceNeighbours(m, progress);
  const VertexStars stars = vertexStars(m);
  std::vector<Repaired> out;
  for (const auto& set : sets) {
    Repaired r;
    r.inside = materialMask(m, set);
    const double before = maskVolume(m, r.inside);
    r.fix = repairUnion(m, nb, stars, r.inside, out.empty() ? nullptr : &out.back().inside,
                        out.empty() ? nullptr : &out.back().fix.surface);
    const SurfaceCheck c = checkSurface(r.fix.surface);
    EXPECT_TRUE(c.closedManifoldOriented()) << c.nonManifoldEdges << " edges, " << c.nonManifoldVertices << " vertices";
    EXPECT_EQ(r.fix.defectsLeft, 0);
    EXPECT_EQ(r.fix.touchesLeft, 0);
    // The surface encloses the repaired union, which is the old one plus and minus the reported tets.
    EXPECT_NEAR(c.enclosedVolume, maskVolume(m, r.inside), 1e-9 * std::max(1.0, maskVolume(m, r.inside)));
    // Added and removed count against the materials' union (the cut to the enclosing one included).
    EXPECT_NEAR(maskVolume(m, r.inside), before + r.fix.volumeAdded - r.fix.volumeRemoved, 1e-9 * std::max(1.0, before));
    if (!out.empty()) {
      EXPECT_EQ(sharedVertices(out.back().fix.surface, r.fix.surface), 0);
      size_t outside = 0;
      for (size_t t = 0; t < r.inside.size(); ++t) outside += r.inside[t] && !out.back().inside[t];
      EXPECT_EQ(outside, 0u) << "tets outside the enclosing union";
    }
    out.push_back(std::move(r));
  }
  return out;
}

TEST(BemRepair, TwoCubesMeetingAtACornerBecomeManifold) {
  LabelVolume v = emptyVolume(4);
  v.at(1, 1, 1) = v.at(2, 2, 2) = 1;
  const TetMesh m = test::voxelMesh(v);
  const auto r = repairNested(m, {{1}});
  EXPECT_GT(r[0].fix.pinchesMended, 0);
  EXPECT_GT(r[0].fix.tetsAdded + r[0].fix.tetsRemoved, 0);
  // Only the tets around the corner moved: far less than a voxel (1.2 mm^3) each way.
  EXPECT_LT(r[0].fix.volumeAdded + r[0].fix.volumeRemoved, 1.2);
}

TEST(BemRepair, AnInnerSurfaceTouchingTheOuterOneThroughAHoleMovesInward) {
  // Three nested boxes (labels 1, 2, 3); the middle layer has a one-voxel hole where 3 meets 1.
  LabelVolume v = emptyVolume(10);
  for (int k = 0; k < 10; ++k)
    for (int j = 0; j < 10; ++j)
      for (int i = 0; i < 10; ++i) v.at(i, j, k) = std::min({i, j, k, 9 - i, 9 - j, 9 - k, 3});
  v.at(2, 5, 5) = 3;
  const TetMesh m = test::voxelMesh(v);
  Progress progress;
  const auto nb = tetFaceNeighbours(m, progress);
  EXPECT_GT(sharedVertices(unionBoundary(m, {2, 3}, nb), unionBoundary(m, {3}, nb)), 0);
  const auto r = repairNested(m, {{1, 2, 3}, {2, 3}, {3}});
  EXPECT_EQ(r[0].fix.tetsAdded + r[0].fix.tetsRemoved, 0); // nothing to do: nothing done
  EXPECT_GT(r[2].fix.touchesMended, 0);
  EXPECT_GT(r[2].fix.tetsRemoved, 0);
}

TEST(BemRepair, RandomNestedBlobsBecomeManifoldAndNested) {
  std::mt19937 rng(11);
  int pinched = 0;
  for (int trial = 0; trial < 16; ++trial) {
    SCOPED_TRACE(trial);
    const int n = 9;
    LabelVolume v = emptyVolume(n);
    // Even trials reach the grid's faces (pinches on the mesh boundary can only be carved).
    const int lo = trial % 2 ? 1 : 0, hi = trial % 2 ? n - 1 : n;
    std::uniform_real_distribution<double> u(0, 1);
    for (int k = lo; k < hi; ++k)
      for (int j = lo; j < hi; ++j)
        for (int i = lo; i < hi; ++i) {
          const double r = std::hypot(i - 4.0, j - 4.0, k - 4.0) / 4.5 + 0.35 * (u(rng) - 0.5);
          v.at(i, j, k) = r < 0.45 ? 3 : r < 0.7 ? 2 : r < 1.0 ? 1 : 0;
        }
    const TetMesh m = test::voxelMesh(v);
    Progress progress;
    const auto nb = tetFaceNeighbours(m, progress);
    if (checkSurface(unionBoundary(m, {2, 3}, nb)).nonManifoldVertices > 0) ++pinched;
    repairNested(m, {{1, 2, 3}, {2, 3}, {3}});
  }
  EXPECT_GT(pinched, 4); // the random layers do pinch
}

} // namespace
} // namespace tetflow
