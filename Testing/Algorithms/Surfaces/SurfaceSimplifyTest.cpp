// Tests for Algorithms/Surfaces/SurfaceSimplify and the crossing counts of BemSurfaces: smoothing and decimation of nested voxel
// surfaces keep them closed, manifold, uncrossed and near their volume, and reach the target.
#include "Algorithms/Surfaces/SurfaceSimplify.h"

#include <gtest/gtest.h>

#include <random>

#include "Algorithms/Quality/LabelTopology.h"
#include "Algorithms/Surfaces/BemRepair.h"
#include "Fixtures/VoxelMesh.h"

namespace tetflow {
namespace {

LabelVolume ballVolume(int n, std::mt19937& rng) {
  LabelVolume v;
  GridGeometry g;
  g.dims = {n, n, n};
  g.spacing = {1.0, 1.0, 1.0};
  g.origin = {0, 0, 0};
  v.allocate(g, 0);
  std::uniform_real_distribution<double> u(-0.12, 0.12);
  const double c = 0.5 * (n - 1);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const double r = std::hypot(i - c, j - c, k - c) / (0.5 * n - 1) + u(rng);
        v.at(i, j, k) = r < 0.5 ? 3 : r < 0.75 ? 2 : r < 1.0 ? 1 : 0;
      }
  return v;
}

// Three nested repaired surfaces of a random layered ball.
std::vector<TriSurface> nestedSurfaces(const TetMesh& m) {
  Progress progress;
  const auto nb = tetFaceNeighbours(m, progress);
  const VertexStars stars = vertexStars(m);
  std::vector<TriSurface> out;
  std::vector<std::vector<uint8_t>> unions;
  for (const std::vector<int32_t>& set : {std::vector<int32_t>{1, 2, 3}, {2, 3}, {3}}) {
    std::vector<uint8_t> inside = materialMask(m, set);
    UnionRepair fix = repairUnion(m, nb, stars, inside, unions.empty() ? nullptr : &unions.back(),
                                  out.empty() ? nullptr : &out.back());
    out.push_back(std::move(fix.surface));
    unions.push_back(std::move(inside));
  }
  return out;
}

TEST(SurfaceSimplify, SmoothingAndDecimationKeepNestedSurfacesClosedAndUncrossed) {
  std::mt19937 rng(7);
  Progress progress;
  for (int trial = 0; trial < 2; ++trial) {
    SCOPED_TRACE(trial);
    const TetMesh m = test::voxelMesh(ballVolume(16, rng));
    std::vector<TriSurface> s = nestedSurfaces(m);
    std::vector<double> volume, area;
    std::vector<int> components;
    for (const TriSurface& x : s) {
      const SurfaceCheck c = checkSurface(x);
      ASSERT_TRUE(c.closedManifoldOriented());
      volume.push_back(c.enclosedVolume);
      area.push_back(c.area);
      components.push_back(c.components);
      EXPECT_EQ(selfIntersections(x), 0);
    }
    EXPECT_EQ(crossingPairs(s[0], s[1]), 0);
    EXPECT_EQ(crossingPairs(s[1], s[2]), 0);
    auto others = [&](size_t i) {
      std::vector<const TriSurface*> o;
      for (size_t j = 0; j < s.size(); ++j)
        if (j != i) o.push_back(&s[j]);
      return o;
    };
    const int64_t target = 240;
    for (size_t i = 0; i < s.size(); ++i) {
      const SurfaceEditStats smooth = smoothSurface(s[i], others(i), 5, progress);
      EXPECT_GT(smooth.moves, 0);
      const SurfaceEditStats dec = decimateSurface(s[i], others(i), target, progress);
      EXPECT_GT(dec.collapses, 0);
    }
    for (size_t i = 0; i < s.size(); ++i) {
      SCOPED_TRACE(i);
      const SurfaceCheck c = checkSurface(s[i]);
      EXPECT_TRUE(c.closedManifoldOriented()) << c.nonManifoldEdges << " " << c.nonManifoldVertices;
      EXPECT_EQ(c.components, components[i]); // no piece vanishes or merges
      EXPECT_LE(c.triangles, target);
      EXPECT_GT(c.triangles, target / 2); // the collapses went on to the target, or near it
      EXPECT_EQ(selfIntersections(s[i]), 0);
      // Smoothing takes the staircase's corners off; the volume stays within a few percent.
      EXPECT_LT(c.area, area[i]);
      EXPECT_NEAR(c.enclosedVolume, volume[i], 0.08 * volume[i]);
      if (i + 1 < s.size()) {
        EXPECT_EQ(crossingPairs(s[i], s[i + 1]), 0);
      }
      // Points still come from the mesh's vertices (meshVertex kept for those that remain).
      for (size_t p = 0; p < s[i].points.size(); ++p) ASSERT_LT(size_t(s[i].meshVertex[p]), m.points.size());
    }
  }
}

TEST(SurfaceSimplify, CrossingsAreFoundWhenASurfaceIsPushedThroughAnother) {
  std::mt19937 rng(9);
  const TetMesh m = test::voxelMesh(ballVolume(14, rng));
  std::vector<TriSurface> s = nestedSurfaces(m);
  EXPECT_EQ(crossingPairs(s[0], s[1]), 0);
  EXPECT_EQ(selfIntersections(s[1]), 0);
  // Blow the middle surface up about its centre until it pokes through the outer one.
  Vec3 centre{0, 0, 0};
  for (const Vec3& p : s[1].points) centre = centre + p;
  centre = (1.0 / double(s[1].points.size())) * centre;
  for (Vec3& p : s[1].points) p = centre + 1.6 * (p - centre);
  EXPECT_GT(crossingPairs(s[0], s[1]), 0);
  // Fold one vertex of the outer surface through the surface's far side: it crosses itself.
  s[0].points[0] = s[0].points[0] + 3.0 * (centre - s[0].points[0]);
  EXPECT_GT(selfIntersections(s[0]), 0);
}

} // namespace
} // namespace tetflow
