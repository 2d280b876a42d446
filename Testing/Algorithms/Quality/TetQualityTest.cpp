// Tests for Algorithms/Quality/TetQuality: exact answers on known tets, degenerate tets (no NaN),
// and invariance of every metric under rotation, translation, uniform scaling and corner order.
#include "Algorithms/Quality/TetQuality.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

namespace tetflow {
namespace {

constexpr double kQualityTol = 1e-9;
const double kRegularAngle = std::acos(1.0 / 3.0) * 180.0 / std::numbers::pi; // 70.528779...

std::array<Vec3, 4> regularTet() {
  // Alternate corners of the cube [-1,1]^3: edge 2 sqrt(2), positively oriented.
  std::array<Vec3, 4> p{Vec3{1, 1, 1}, Vec3{1, -1, -1}, Vec3{-1, 1, -1}, Vec3{-1, -1, 1}};
  if (signedTetVolume(p[0], p[1], p[2], p[3]) < 0) std::swap(p[0], p[1]);
  return p;
}

// Two adjacent cube centres (cube edge 1) and the two ends of an edge of their shared face.
std::array<Vec3, 4> bccTet() {
  std::array<Vec3, 4> p{Vec3{0, 0, 0.5}, Vec3{0, 0, -0.5}, Vec3{0.5, 0.5, 0}, Vec3{-0.5, 0.5, 0}};
  if (signedTetVolume(p[0], p[1], p[2], p[3]) < 0) std::swap(p[0], p[1]);
  return p;
}

std::array<Vec3, 4> cornerTet() {
  return {Vec3{0, 0, 0}, Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}};
}

TetMetrics metricsOf(const std::array<Vec3, 4>& p) { return tetMetrics(p[0], p[1], p[2], p[3]); }

std::vector<double> sortedAngles(const std::array<Vec3, 4>& p) {
  const auto a = dihedralAngles(p[0], p[1], p[2], p[3]);
  std::vector<double> v(a.begin(), a.end());
  std::sort(v.begin(), v.end());
  return v;
}

TEST(TetQuality, RegularTetIsExact) {
  const auto p = regularTet();
  for (double a : dihedralAngles(p[0], p[1], p[2], p[3])) EXPECT_NEAR(a, kRegularAngle, kQualityTol);
  EXPECT_NEAR(kRegularAngle, 70.5287793655, 1e-9);
  const auto m = metricsOf(p);
  EXPECT_NEAR(m.minDihedral, kRegularAngle, kQualityTol);
  EXPECT_NEAR(m.maxDihedral, kRegularAngle, kQualityTol);
  EXPECT_NEAR(m.aspectRatio, std::sqrt(2.0 / 3.0), kQualityTol);
  EXPECT_NEAR(m.radiusRatio, 1.0, kQualityTol);
  // Edge 2 sqrt(2): V = edge^3 / (6 sqrt 2) = 8/3 (the cube minus 4 corner tets of 4/3 each).
  EXPECT_NEAR(m.volume, 8.0 / 3.0, kQualityTol);
  EXPECT_FALSE(m.zeroVolume);
  EXPECT_NEAR(longestEdge(p[0], p[1], p[2], p[3]), std::sqrt(8.0), kQualityTol);
}

TEST(TetQuality, RightCornerTetIsExact) {
  const auto p = cornerTet();
  const auto a = dihedralAngles(p[0], p[1], p[2], p[3]);
  // Edges (0,1) (0,2) (0,3) pass through the origin: 90 degrees; the others acos(1/sqrt 3).
  const double other = std::acos(1.0 / std::sqrt(3.0)) * 180.0 / std::numbers::pi;
  EXPECT_NEAR(other, 54.7356103172, 1e-9);
  for (int e = 0; e < 3; ++e) EXPECT_NEAR(a[e], 90.0, kQualityTol) << e;
  for (int e = 3; e < 6; ++e) EXPECT_NEAR(a[e], other, kQualityTol) << e;
  EXPECT_NEAR(tetVolume(p[0], p[1], p[2], p[3]), 1.0 / 6.0, kQualityTol);
  EXPECT_NEAR(minDihedral(p[0], p[1], p[2], p[3]), other, kQualityTol);
  EXPECT_NEAR(maxDihedral(p[0], p[1], p[2], p[3]), 90.0, kQualityTol);
  // Shortest altitude 1/sqrt 3 (onto the slanted face), longest edge sqrt 2.
  EXPECT_NEAR(aspectRatio(p[0], p[1], p[2], p[3]), 1.0 / std::sqrt(6.0), kQualityTol);
  // r_in = 1/(3+sqrt 3), R = sqrt(3)/2.
  EXPECT_NEAR(radiusRatio(p[0], p[1], p[2], p[3]), std::sqrt(3.0) - 1.0, kQualityTol);
}

TEST(TetQuality, BccLatticeTetHas60And90Degrees) {
  const auto p = bccTet();
  const auto v = sortedAngles(p);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(v[i], 60.0, kQualityTol);
  for (int i = 4; i < 6; ++i) EXPECT_NEAR(v[i], 90.0, kQualityTol);
  // The 90 degree angles sit at the two long edges (centre-centre, corner-corner).
  const auto a = dihedralAngles(p[0], p[1], p[2], p[3]);
  EXPECT_NEAR(a[0], 90.0, kQualityTol); // edge (0,1): the two cube centres
  EXPECT_NEAR(a[5], 90.0, kQualityTol); // edge (2,3): the two face corners
  const auto m = metricsOf(p);
  EXPECT_NEAR(m.volume, 1.0 / 12.0, kQualityTol);
  EXPECT_NEAR(m.aspectRatio, 1.0 / std::sqrt(2.0), kQualityTol);
  EXPECT_NEAR(m.radiusRatio, 3.0 / std::sqrt(10.0), kQualityTol);
}

TEST(TetQuality, SliverApproaches0And180) {
  // A square's corners lifted alternately by +-eps: dihedral angles near 0 and 180.
  for (double eps : {1e-2, 1e-4, 1e-6}) {
    std::array<Vec3, 4> p{Vec3{0, 0, eps}, Vec3{1, 1, eps}, Vec3{1, 0, -eps}, Vec3{0, 1, -eps}};
    if (signedTetVolume(p[0], p[1], p[2], p[3]) < 0) std::swap(p[0], p[1]);
    const auto v = sortedAngles(p);
    // Four edges of the square: near 0; the two diagonals: near 180.
    for (int i = 0; i < 4; ++i) EXPECT_LT(v[i], 1e3 * eps) << eps;
    for (int i = 4; i < 6; ++i) EXPECT_GT(v[i], 180.0 - 1e3 * eps) << eps;
    const auto m = metricsOf(p);
    EXPECT_FALSE(m.zeroVolume);
    EXPECT_GT(m.minDihedral, 0.0);
    EXPECT_LT(m.maxDihedral, 180.0);
    EXPECT_GT(m.aspectRatio, 0.0);
    EXPECT_LT(m.aspectRatio, 10 * eps);
    EXPECT_GT(m.radiusRatio, 0.0);
    EXPECT_LT(m.radiusRatio, 10 * eps);
    // Exact: opposite diagonals of length sqrt 2, perpendicular, 2 eps apart: V = 2*2eps/6.
    EXPECT_NEAR(m.volume, 2.0 * eps / 3.0, 1e-12);
  }
}

void expectDegenerate(const std::array<Vec3, 4>& p, const char* what) {
  SCOPED_TRACE(what);
  const auto m = metricsOf(p);
  EXPECT_TRUE(m.zeroVolume);
  EXPECT_TRUE(isZeroVolume(p[0], p[1], p[2], p[3]));
  EXPECT_EQ(m.minDihedral, 0.0);
  EXPECT_EQ(m.maxDihedral, 180.0);
  EXPECT_EQ(m.aspectRatio, 0.0);
  EXPECT_EQ(m.radiusRatio, 0.0);
  EXPECT_EQ(aspectRatio(p[0], p[1], p[2], p[3]), 0.0);
  EXPECT_EQ(radiusRatio(p[0], p[1], p[2], p[3]), 0.0);
  EXPECT_EQ(minDihedral(p[0], p[1], p[2], p[3]), 0.0);
  EXPECT_EQ(maxDihedral(p[0], p[1], p[2], p[3]), 180.0);
  for (double a : m.dihedral) {
    EXPECT_FALSE(std::isnan(a));
    EXPECT_TRUE(std::abs(a) < 1e-6 || std::abs(a - 180.0) < 1e-6) << a;
  }
  EXPECT_FALSE(std::isnan(m.volume));
}

TEST(TetQuality, DegenerateTetsGiveZeroRatiosAndNoNaN) {
  // Flat: a point inside the triangle of the other three.
  expectDegenerate({Vec3{0, 0, 0}, Vec3{3, 0, 0}, Vec3{0, 3, 0}, Vec3{1, 1, 0}}, "inner point");
  // Flat convex quadrilateral.
  expectDegenerate({Vec3{0, 0, 0}, Vec3{1, 1, 0}, Vec3{1, 0, 0}, Vec3{0, 1, 0}}, "quad");
  // Collinear.
  expectDegenerate({Vec3{0, 0, 0}, Vec3{1, 0, 0}, Vec3{2, 0, 0}, Vec3{5, 0, 0}}, "collinear");
  // Two coincident corners.
  expectDegenerate({Vec3{0, 0, 0}, Vec3{0, 0, 0}, Vec3{1, 0, 0}, Vec3{0, 1, 0}}, "coincident");
  // All corners equal.
  expectDegenerate({Vec3{2, 2, 2}, Vec3{2, 2, 2}, Vec3{2, 2, 2}, Vec3{2, 2, 2}}, "point");
  // Below the relative tolerance (|V| = 1e-13 * L^3 scale) still counts as zero volume.
  expectDegenerate({Vec3{0, 0, 0}, Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0.3, 0.3, 1e-13}}, "tiny");
  // The flat quadrilateral's angles: 4 edges at 0 and both diagonals at 180.
  const auto a = dihedralAngles(Vec3{0, 0, 0}, Vec3{1, 1, 0}, Vec3{1, 0, 0}, Vec3{0, 1, 0});
  std::vector<double> v(a.begin(), a.end());
  std::sort(v.begin(), v.end());
  for (int i = 0; i < 4; ++i) EXPECT_EQ(v[i], 0.0);
  for (int i = 4; i < 6; ++i) EXPECT_EQ(v[i], 180.0);
}

TEST(TetQuality, InvertedTetKeepsShapeMetricsAndNegativeVolume) {
  auto p = regularTet();
  std::swap(p[0], p[1]);
  const auto m = metricsOf(p);
  EXPECT_NEAR(m.volume, -8.0 / 3.0, kQualityTol);
  EXPECT_FALSE(m.zeroVolume);
  EXPECT_NEAR(m.minDihedral, kRegularAngle, kQualityTol);
  EXPECT_NEAR(m.aspectRatio, std::sqrt(2.0 / 3.0), kQualityTol);
  EXPECT_NEAR(m.radiusRatio, 1.0, kQualityTol);
}

Mat3 randomRotation(std::mt19937& rng) {
  // Random unit quaternion.
  std::normal_distribution<double> g(0.0, 1.0);
  double q[4];
  double n = 0;
  for (double& c : q) {
    c = g(rng);
    n += c * c;
  }
  n = std::sqrt(n);
  for (double& c : q) c /= n;
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  return {{{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
           {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
           {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}}};
}

TEST(TetQuality, MetricsAreInvariantUnderRigidMotionScalingAndCornerOrder) {
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_real_distribution<double> logScale(-3.0, 3.0);
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    std::array<Vec3, 4> p;
    for (auto& x : p) x = {u(rng), u(rng), u(rng)};
    if (signedTetVolume(p[0], p[1], p[2], p[3]) < 0) std::swap(p[0], p[1]);
    const auto m0 = metricsOf(p);
    if (m0.minDihedral < 1.0) continue; // keep well-conditioned tets for tight tolerances
    ++checked;
    const Mat3 rot = randomRotation(rng);
    const double s = std::pow(10.0, logScale(rng));
    const Vec3 shift{100 * u(rng), 100 * u(rng), 100 * u(rng)};
    std::array<Vec3, 4> q;
    for (int i = 0; i < 4; ++i) q[i] = s * mul(rot, p[i]) + shift;
    const auto m1 = metricsOf(q);
    const double angTol = 1e-6, ratioTol = 1e-8;
    for (int e = 0; e < 6; ++e) EXPECT_NEAR(m1.dihedral[e], m0.dihedral[e], angTol);
    EXPECT_NEAR(m1.minDihedral, m0.minDihedral, angTol);
    EXPECT_NEAR(m1.maxDihedral, m0.maxDihedral, angTol);
    EXPECT_NEAR(m1.aspectRatio, m0.aspectRatio, ratioTol);
    EXPECT_NEAR(m1.radiusRatio, m0.radiusRatio, ratioTol);
    EXPECT_NEAR(m1.volume / (s * s * s), m0.volume, 1e-8 * std::abs(m0.volume) + 1e-12);
    EXPECT_GT(m1.volume, 0.0); // a rotation keeps the orientation
    // An even permutation of the corners keeps everything, including the volume sign.
    const auto m2 = tetMetrics(p[1], p[2], p[0], p[3]);
    EXPECT_NEAR(m2.volume, m0.volume, 1e-12);
    EXPECT_NEAR(m2.minDihedral, m0.minDihedral, 1e-9);
    EXPECT_NEAR(m2.maxDihedral, m0.maxDihedral, 1e-9);
    EXPECT_NEAR(m2.aspectRatio, m0.aspectRatio, 1e-12);
    EXPECT_NEAR(m2.radiusRatio, m0.radiusRatio, 1e-12);
    // Bounds: regular tet maximises the min angle, the aspect ratio and the radius ratio.
    EXPECT_LE(m0.minDihedral, kRegularAngle + 1e-9);
    EXPECT_LE(m0.aspectRatio, std::sqrt(2.0 / 3.0) + 1e-12);
    EXPECT_LE(m0.radiusRatio, 1.0);
    EXPECT_GE(m0.maxDihedral, kRegularAngle - 1e-9);
    double sum = 0;
    for (double a : m0.dihedral) sum += a;
    EXPECT_GT(sum, 360.0);
    EXPECT_LT(sum, 720.0);
  }
  EXPECT_GT(checked, 150);
}

TEST(TetQuality, CosineRangeAndScoreAgreeWithTheAngles) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int checked = 0;
  for (int i = 0; i < 2000; ++i) {
    std::array<Vec3, 4> p;
    for (auto& x : p) x = {u(rng), u(rng), u(rng)};
    double lo, hi;
    const bool ok = dihedralCosineRange(p[0], p[1], p[2], p[3], lo, hi);
    const TetMetrics m = tetMetrics(p[0], p[1], p[2], p[3]);
    if (m.volume <= 0 || m.zeroVolume) {
      EXPECT_FALSE(ok);
      EXPECT_EQ(dihedralScore(p[0], p[1], p[2], p[3]), -1.0);
      continue;
    }
    ASSERT_TRUE(ok);
    EXPECT_NEAR(std::acos(hi) * 180.0 / M_PI, m.minDihedral, 1e-6);
    EXPECT_NEAR(std::acos(lo) * 180.0 / M_PI, m.maxDihedral, 1e-6);
    EXPECT_NEAR(dihedralScore(p[0], p[1], p[2], p[3]), std::min(m.minDihedral, 180.0 - m.maxDihedral), 1e-6);
    ++checked;
  }
  EXPECT_GT(checked, 500);
}

TEST(TetQuality, ZeroVolumeTestIsScaleFree) {
  // The same shapes at mm and at km scale classify the same way.
  for (double s : {1e-6, 1.0, 1e6}) {
    EXPECT_FALSE(isZeroVolume(Vec3{0, 0, 0}, Vec3{s, 0, 0}, Vec3{0, s, 0}, Vec3{0, 0, 1e-9 * s}));
    EXPECT_TRUE(isZeroVolume(Vec3{0, 0, 0}, Vec3{s, 0, 0}, Vec3{0, s, 0}, Vec3{0, 0, 1e-13 * s}));
  }
}

} // namespace
} // namespace tetflow
