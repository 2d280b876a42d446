// TetLocator (Algorithms/FEM/TetLocator.h) gives locatePoint's answer: random points inside,
// outside, on vertices and on faces of random meshes, before and after its grid is built.
#include <gtest/gtest.h>

#include <random>

#include "Algorithms/FEM/TetLocator.h"
#include "FemTestMeshes.h"

using namespace tetflow;
using tetflow::test::kuhnBox;
using tetflow::test::perturbInterior;

TEST(TetLocator, GivesLocatePointsAnswerEverywhere) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const std::array<int, 3> n{3 + int(seed), 4 + int(seed % 3), 2 + int(seed % 4)};
    const Vec3 lo{-1.0, 2.0, 0.5}, hi{-1.0 + 1.3 * n[0], 2.0 + 0.7 * n[1], 0.5 + 2.1 * n[2]};
    TetMesh m = kuhnBox(n, lo, hi, [](int, int, int) { return 1; });
    perturbInterior(m, lo, hi, 0.7, 0.2, seed);
    const TetLocator loc(m);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-0.2, 1.2);
    std::uniform_int_distribution<size_t> anyVertex(0, m.numPoints() - 1), anyTet(0, m.numTets() - 1);
    int inside = 0;
    for (int i = 0; i < 400; ++i) {
      Vec3 p;
      if (i % 4 == 1) {
        p = m.points[anyVertex(rng)]; // a vertex: many tets contain it
      } else if (i % 4 == 2) { // a point on a face
        const auto& t = m.tets[anyTet(rng)];
        const double a = u(rng) * 0.5 + 0.1, b = (1 - a) * 0.5;
        p = a * m.points[size_t(t[0])] + b * m.points[size_t(t[1])] + (1 - a - b) * m.points[size_t(t[2])];
      } else {
        for (int c = 0; c < 3; ++c) p[size_t(c)] = lo[c] + u(rng) * (hi[c] - lo[c]);
      }
      const auto want = locatePoint(m, p);
      const auto got = loc.locate(p);
      ASSERT_EQ(want.has_value(), got.has_value()) << "seed " << seed << " point " << i;
      if (!want) continue;
      ++inside;
      EXPECT_EQ(got->tet, want->tet) << "seed " << seed << " point " << i;
      for (int a = 0; a < 4; ++a) EXPECT_EQ(got->bary[size_t(a)], want->bary[size_t(a)]);
    }
    EXPECT_TRUE(loc.built());
    EXPECT_GT(inside, 200);
  }
}

TEST(TetLocator, AFlatOrEmptyMeshAndNonFinitePointsAreNotFound) {
  TetMesh empty;
  const TetLocator none(empty);
  for (int i = 0; i < 6; ++i) EXPECT_FALSE(none.locate({0, 0, 0}));
  TetMesh m = kuhnBox({2, 2, 2}, {0, 0, 0}, {1, 1, 1}, [](int, int, int) { return 1; });
  const TetLocator loc(m);
  for (int i = 0; i < 6; ++i) {
    EXPECT_FALSE(loc.locate({std::nan(""), 0.5, 0.5}));
    EXPECT_FALSE(loc.locate({0.5, 0.5, 1.5}));
    EXPECT_TRUE(loc.locate({0.5, 0.5, 1.0}));
  }
}
