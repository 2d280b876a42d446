#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/Cleaving/Cleaver.h"
#include "Algorithms/Core/Phantom.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {

struct Check {
  double minVol = 1e300, total = 0;
  int64_t nonpositive = 0, overshared = 0, boundaryOffBox = 0;
  double minDihedral = 180, maxDihedral = 0;
};

double dihedralMin(const Vec3 p[4], double& maxOut) {
  static const int e[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2}, {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};
  double mn = 180;
  maxOut = 0;
  for (const auto& x : e) {
    const Vec3 a = p[x[0]], b = p[x[1]], c = p[x[2]], d = p[x[3]];
    const Vec3 ab = b - a;
    const Vec3 n1 = cross(ab, c - a), n2 = cross(ab, d - a);
    const double cs = dot(n1, n2) / (norm(n1) * norm(n2));
    const double ang = std::acos(std::clamp(cs, -1.0, 1.0)) * 180.0 / M_PI;
    mn = std::min(mn, ang);
    maxOut = std::max(maxOut, ang);
  }
  return mn;
}

Check check(const TetMesh& m, const Vec3& lo, const Vec3& hi) {
  Check c;
  std::map<std::array<int32_t, 3>, int> faces;
  for (size_t t = 0; t < m.tets.size(); ++t) {
    const auto& q = m.tets[t];
    const double v = m.tetVolume(t);
    c.minVol = std::min(c.minVol, v);
    c.total += v;
    if (v <= 0) ++c.nonpositive;
    const Vec3 p[4] = {m.points[q[0]], m.points[q[1]], m.points[q[2]], m.points[q[3]]};
    double mx;
    c.minDihedral = std::min(c.minDihedral, dihedralMin(p, mx));
    c.maxDihedral = std::max(c.maxDihedral, mx);
    for (int f = 0; f < 4; ++f) {
      std::array<int32_t, 3> k;
      int n = 0;
      for (int i = 0; i < 4; ++i)
        if (i != f) k[n++] = q[i];
      std::sort(k.begin(), k.end());
      ++faces[k];
    }
  }
  for (const auto& [k, n] : faces) {
    if (n > 2) ++c.overshared;
    if (n == 1) {
      // A boundary face must lie on one side of the box.
      bool on = false;
      for (int a = 0; a < 3 && !on; ++a)
        for (double s : {lo[a], hi[a]}) {
          bool all = true;
          for (int32_t v : k) all = all && std::abs(m.points[v][a] - s) < 1e-9 * (hi[a] - lo[a]);
          on = on || all;
        }
      if (!on) ++c.boundaryOffBox;
    }
  }
  return c;
}

void boxOf(const GridGeometry& g, Vec3& lo, Vec3& hi) {
  for (int a = 0; a < 3; ++a) {
    lo[a] = g.origin[a] - 0.5 * g.spacing[a];
    hi[a] = g.origin[a] + (g.dims[a] - 0.5) * g.spacing[a];
  }
}

} // namespace

TEST(BccLattice, CoversTheBoxExactlyWithGoodTets) {
  GridGeometry g;
  g.dims = {20, 13, 9};
  g.spacing = {0.5, 0.75, 1.25};
  g.origin = {3, -2, 10};
  NullProgress np;
  const BackgroundMesh bg = generateRegularBcc(g, BccParams{1.7, 0.0}, np);
  Vec3 lo, hi;
  boxOf(g, lo, hi);
  const Check c = check(bg.mesh, lo, hi);
  EXPECT_EQ(c.nonpositive, 0);
  EXPECT_EQ(c.overshared, 0);
  EXPECT_EQ(c.boundaryOffBox, 0);
  EXPECT_NEAR(c.total, (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]), 1e-9 * c.total);
  EXPECT_NEAR(c.total, bg.boxVolume, 1e-9 * c.total);
}

TEST(Cleaver, SphereIsValidAndConformingWithBoundedAngles) {
  PhantomParams pp;
  pp.kind = PhantomKind::Head;
  pp.radius = 20;
  pp.skull_radius = 17;
  pp.csf_radius = 15;
  pp.brain_radius = 13;
  pp.voxel_size = 1.0;
  const Phantom ph = makePhantom(pp);
  auto vol = std::make_shared<const LabelVolume>(ph.volume);
  LabelMaterials mats(vol, 1.0);
  NullProgress np;
  const BackgroundMesh bg = generateRegularBcc(vol->grid, BccParams{2.0, 0.0}, np);
  const CleaveResult r = cleave(bg, mats, CleaveParams{}, np);
  Vec3 lo, hi;
  boxOf(vol->grid, lo, hi);
  const Check c = check(r.mesh, lo, hi);
  std::printf("tets %zu min vol %g dihedral [%g, %g] warped %lld snaps %lld degen %lld steiner %lld\n",
              r.mesh.numTets(), c.minVol, c.minDihedral, c.maxDihedral, (long long)r.stats.warpedVertices,
              (long long)r.stats.snaps, (long long)r.stats.degeneracySnaps, (long long)r.stats.steinerPoints);
  EXPECT_EQ(c.nonpositive, 0);
  EXPECT_EQ(c.overshared, 0);
  EXPECT_EQ(c.boundaryOffBox, 0);
  EXPECT_NEAR(c.total, bg.boxVolume, 1e-9 * c.total);
}
