#include "TetLocator.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace tetflow {

namespace {
// The bounding box of tet t, padded by 1e-9 of its extent on each axis (as locatePoint pads it).
void paddedBox(const TetMesh& mesh, int64_t t, Vec3& lo, Vec3& hi) {
  const auto& q = mesh.tets[size_t(t)];
  for (int c = 0; c < 3; ++c) {
    double l = mesh.points[q[0]][c], u = l;
    for (int i = 1; i < 4; ++i) {
      l = std::min(l, mesh.points[q[i]][c]);
      u = std::max(u, mesh.points[q[i]][c]);
    }
    const double pad = 1e-9 * (u - l);
    lo[c] = l - pad;
    hi[c] = u + pad;
  }
}
} // namespace

bool tetContainsPoint(const TetMesh& mesh, int64_t t, const Vec3& p) {
  constexpr double kEps = 1e-10;
  Vec3 lo, hi;
  paddedBox(mesh, t, lo, hi);
  for (int c = 0; c < 3; ++c)
    if (p[c] < lo[c] || p[c] > hi[c]) return false;
  const TetGradients g = tetGradients(mesh, size_t(t));
  if (!(g.volume > 0)) return false;
  const Vec3 d = p - mesh.points[mesh.tets[size_t(t)][0]];
  double l[4];
  l[1] = dot(g.grad[1], d);
  l[2] = dot(g.grad[2], d);
  l[3] = dot(g.grad[3], d);
  l[0] = 1.0 - l[1] - l[2] - l[3];
  return l[0] >= -kEps && l[1] >= -kEps && l[2] >= -kEps && l[3] >= -kEps;
}

PointLocation pointLocationIn(const TetMesh& mesh, int64_t t, const Vec3& p) {
  PointLocation loc;
  loc.tet = t;
  const TetGradients g = tetGradients(mesh, size_t(t));
  const Vec3 d = p - mesh.points[mesh.tets[size_t(t)][0]];
  for (int a = 1; a < 4; ++a) loc.bary[size_t(a)] = dot(g.grad[size_t(a)], d);
  loc.bary[0] = 1.0 - loc.bary[1] - loc.bary[2] - loc.bary[3];
  return loc;
}

int64_t TetLocator::cellOf(double x, int axis) const {
  const double i = std::floor((x - lo_[axis]) / h_); // clamped as a double: no overflow in the cast
  return int64_t(std::clamp(i, 0.0, double(dims_[size_t(axis)] - 1)));
}

void TetLocator::build() const {
  const int64_t nt = int64_t(mesh_.numTets());
  Vec3 lo{std::numeric_limits<double>::max(), std::numeric_limits<double>::max(), std::numeric_limits<double>::max()};
  Vec3 hi{-lo[0], -lo[1], -lo[2]};
  for (const auto& t : mesh_.tets)
    for (int32_t v : t)
      for (int c = 0; c < 3; ++c) {
        lo[c] = std::min(lo[c], mesh_.points[size_t(v)][c]);
        hi[c] = std::max(hi[c], mesh_.points[size_t(v)][c]);
      }
  double vol = 1.0;
  for (int c = 0; c < 3; ++c) vol *= std::max(hi[c] - lo[c], 1e-300);
  h_ = 1.5 * std::cbrt(vol / double(std::max<int64_t>(nt, 1)));
  if (!(h_ > 0) || !std::isfinite(h_)) h_ = 1.0;
  for (;;) { // at most ~4 cells per tet (a flat mesh would otherwise get a huge grid)
    for (int c = 0; c < 3; ++c)
      dims_[size_t(c)] = std::clamp<int64_t>(int64_t(std::floor((hi[c] - lo[c]) / h_)) + 1, 1, 4096);
    if (double(dims_[0]) * double(dims_[1]) * double(dims_[2]) <= 4.0 * double(nt) + 64.0) break;
    h_ *= 1.26;
  }
  lo_ = lo;
  const int64_t cells = dims_[0] * dims_[1] * dims_[2];
  auto cellRange = [&](int64_t t, std::array<int64_t, 3>& a, std::array<int64_t, 3>& b) {
    Vec3 l, u;
    paddedBox(mesh_, t, l, u);
    for (int c = 0; c < 3; ++c) {
      a[size_t(c)] = cellOf(l[c], c);
      b[size_t(c)] = cellOf(u[c], c);
    }
  };
  std::vector<int64_t> count(size_t(cells) + 1, 0);
  std::array<int64_t, 3> a{}, b{};
  for (int64_t t = 0; t < nt; ++t) {
    cellRange(t, a, b);
    for (int64_t k = a[2]; k <= b[2]; ++k)
      for (int64_t j = a[1]; j <= b[1]; ++j)
        for (int64_t i = a[0]; i <= b[0]; ++i) ++count[size_t((k * dims_[1] + j) * dims_[0] + i + 1)];
  }
  for (int64_t c = 0; c < cells; ++c) count[size_t(c + 1)] += count[size_t(c)];
  offset_ = count;
  tets_.assign(size_t(offset_.back()), 0);
  for (int64_t t = 0; t < nt; ++t) { // tets in increasing order within every cell
    cellRange(t, a, b);
    for (int64_t k = a[2]; k <= b[2]; ++k)
      for (int64_t j = a[1]; j <= b[1]; ++j)
        for (int64_t i = a[0]; i <= b[0]; ++i) tets_[size_t(count[size_t((k * dims_[1] + j) * dims_[0] + i)]++)] = int32_t(t);
  }
  built_ = true;
}

std::optional<PointLocation> TetLocator::locate(const Vec3& p) const {
  if (!built_.load() && (queries_.fetch_add(1) < 4 || mesh_.numTets() >= size_t(INT32_MAX)))
    return locatePoint(mesh_, p);
  std::call_once(once_, [this] { build(); });
  if (mesh_.numTets() == 0) return std::nullopt;
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(p[c])) return std::nullopt;
  int64_t idx[3];
  for (int c = 0; c < 3; ++c) idx[c] = cellOf(p[c], c);
  const int64_t cell = (idx[2] * dims_[1] + idx[1]) * dims_[0] + idx[0];
  for (int64_t i = offset_[size_t(cell)]; i < offset_[size_t(cell) + 1]; ++i) {
    const int64_t t = tets_[size_t(i)];
    if (!tetContainsPoint(mesh_, t, p)) continue;
    // The first containing tet of the cell is the lowest index overall (every containing tet's
    // padded box holds p, so it is in p's cell; the cell lists tets in increasing order).
    return pointLocationIn(mesh_, t, p);
  }
  return std::nullopt;
}

} // namespace tetflow
