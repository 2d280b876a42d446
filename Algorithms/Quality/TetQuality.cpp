#include "TetQuality.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tetflow {

namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

double maxEdgeSquared(const std::array<Vec3, 4>& p) {
  double m = 0.0;
  for (const auto& e : kTetEdges) {
    const Vec3 d = p[e[1]] - p[e[0]];
    m = std::max(m, dot(d, d));
  }
  return m;
}

// Signed volume relative to p0 (translation-robust).
double volumeOf(const std::array<Vec3, 4>& p) {
  return dot(p[1] - p[0], cross(p[2] - p[0], p[3] - p[0])) / 6.0;
}

bool zeroVolume(double volume, double lmax) {
  return std::abs(volume) <= kZeroVolumeRelTol * lmax * lmax * lmax;
}

std::array<double, 6> anglesOf(const std::array<Vec3, 4>& p) {
  std::array<double, 6> out{};
  for (size_t n = 0; n < kTetEdges.size(); ++n) {
    const int i = kTetEdges[n][0], j = kTetEdges[n][1];
    // The two corners not on the edge.
    int k = -1, l = -1;
    for (int c = 0; c < 4; ++c)
      if (c != i && c != j) (k < 0 ? k : l) = c;
    const Vec3 e = p[j] - p[i];
    const Vec3 mk = cross(e, p[k] - p[i]);
    const Vec3 ml = cross(e, p[l] - p[i]);
    // atan2(0, 0) = 0: an edge with a zero-area face gets angle 0 (documented).
    out[n] = std::atan2(norm(cross(mk, ml)), dot(mk, ml)) * kRadToDeg;
  }
  return out;
}

// Face areas opposite each corner: A_k = |(p_b - p_a) x (p_c - p_a)| / 2.
std::array<double, 4> faceAreas(const std::array<Vec3, 4>& p) {
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  std::array<double, 4> a{};
  for (int k = 0; k < 4; ++k) {
    const Vec3& x = p[kFace[k][0]];
    a[k] = 0.5 * norm(cross(p[kFace[k][1]] - x, p[kFace[k][2]] - x));
  }
  return a;
}

double aspectOf(const std::array<double, 4>& a, double volume, double lmax) {
  const double amax = *std::max_element(a.begin(), a.end());
  const double denom = amax * lmax;
  if (!(denom > 0.0)) return 0.0;
  return 3.0 * std::abs(volume) / denom;
}

double radiusOf(const std::array<Vec3, 4>& p, const std::array<double, 4>& a, double volume) {
  const double s = a[0] + a[1] + a[2] + a[3];
  const Vec3 u = p[1] - p[0], v = p[2] - p[0], w = p[3] - p[0];
  const Vec3 n = dot(u, u) * cross(v, w) + dot(v, v) * cross(w, u) + dot(w, w) * cross(u, v);
  const double denom = s * norm(n);
  if (!(denom > 0.0)) return 0.0;
  // Rounding can push a perfect tet a hair above 1.
  return std::min(1.0, 108.0 * volume * volume / denom);
}

std::array<Vec3, 4> pack(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  return {p0, p1, p2, p3};
}

} // namespace

double tetVolume(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  return volumeOf(pack(p0, p1, p2, p3));
}

double longestEdge(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  return std::sqrt(maxEdgeSquared(pack(p0, p1, p2, p3)));
}

bool isZeroVolume(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  const auto p = pack(p0, p1, p2, p3);
  return zeroVolume(volumeOf(p), std::sqrt(maxEdgeSquared(p)));
}

std::array<double, 6> dihedralAngles(const Vec3& p0, const Vec3& p1, const Vec3& p2,
                                     const Vec3& p3) {
  return anglesOf(pack(p0, p1, p2, p3));
}

bool dihedralCosineRange(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, double& lo, double& hi) {
  const Vec3 e1 = p1 - p0, e2 = p2 - p0, e3 = p3 - p0;
  const double v6 = dot(e1, cross(e2, e3)); // 6 V
  if (!(v6 > 0)) return false;
  // Flat (the zero-volume test): V <= kZeroVolumeRelTol * L_max^3.
  const Vec3 e4 = p2 - p1, e5 = p3 - p1, e6 = p3 - p2;
  const double l2 = std::max({dot(e1, e1), dot(e2, e2), dot(e3, e3), dot(e4, e4), dot(e5, e5), dot(e6, e6)});
  if (v6 / 6.0 <= kZeroVolumeRelTol * l2 * std::sqrt(l2)) return false;
  Vec3 n[4];
  n[1] = cross(e3, e2);
  n[2] = cross(e1, e3);
  n[3] = cross(e2, e1);
  n[0] = -1.0 * (n[1] + n[2] + n[3]);
  double len[4];
  for (int k = 0; k < 4; ++k) len[k] = norm(n[k]);
  lo = 1.0;
  hi = -1.0;
  for (int k = 0; k < 4; ++k)
    for (int l = k + 1; l < 4; ++l) {
      const double c = -dot(n[k], n[l]) / (len[k] * len[l]);
      lo = std::min(lo, c);
      hi = std::max(hi, c);
    }
  return true;
}

double dihedralScore(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  double lo, hi;
  if (!dihedralCosineRange(p0, p1, p2, p3, lo, hi)) return -1.0;
  return std::acos(std::clamp(std::max(hi, -lo), -1.0, 1.0)) * (180.0 / M_PI);
}

double minDihedral(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  return tetMetrics(p0, p1, p2, p3).minDihedral;
}

double maxDihedral(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  return tetMetrics(p0, p1, p2, p3).maxDihedral;
}

double aspectRatio(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  const auto p = pack(p0, p1, p2, p3);
  const double v = volumeOf(p), lmax = std::sqrt(maxEdgeSquared(p));
  return zeroVolume(v, lmax) ? 0.0 : aspectOf(faceAreas(p), v, lmax);
}

double radiusRatio(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  const auto p = pack(p0, p1, p2, p3);
  const double v = volumeOf(p), lmax = std::sqrt(maxEdgeSquared(p));
  return zeroVolume(v, lmax) ? 0.0 : radiusOf(p, faceAreas(p), v);
}

TetMetrics tetMetrics(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  const auto p = pack(p0, p1, p2, p3);
  TetMetrics m;
  m.volume = volumeOf(p);
  const double lmax = std::sqrt(maxEdgeSquared(p));
  m.zeroVolume = zeroVolume(m.volume, lmax);
  m.dihedral = anglesOf(p);
  if (m.zeroVolume) {
    m.minDihedral = 0.0;
    m.maxDihedral = 180.0;
    m.aspectRatio = 0.0;
    m.radiusRatio = 0.0;
    return m;
  }
  m.minDihedral = *std::min_element(m.dihedral.begin(), m.dihedral.end());
  m.maxDihedral = *std::max_element(m.dihedral.begin(), m.dihedral.end());
  const auto areas = faceAreas(p);
  m.aspectRatio = aspectOf(areas, m.volume, lmax);
  m.radiusRatio = radiusOf(p, areas, m.volume);
  return m;
}

} // namespace tetflow
