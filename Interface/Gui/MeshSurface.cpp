#include "MeshSurface.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "Algorithms/Quality/TetQuality.h"

namespace tetflow::gui {

MeshTopology MeshTopology::build(const TetMesh& mesh) {
  MeshTopology topo;
  const size_t n = mesh.numTets();
  topo.neighbor.assign(4 * n, -1);
  topo.centroid.resize(n);
  struct Key {
    int32_t a, b, c;
    int32_t slot; // 4*t + f
  };
  std::vector<Key> keys(4 * n);
#pragma omp parallel for schedule(static)
  for (long long t = 0; t < (long long)n; ++t) {
    const auto& q = mesh.tets[size_t(t)];
    Vec3 c{0, 0, 0};
    for (int k = 0; k < 4; ++k) c = c + mesh.points[size_t(q[k])];
    topo.centroid[size_t(t)] = 0.25 * c;
    for (int f = 0; f < 4; ++f) {
      std::array<int32_t, 3> v;
      int m = 0;
      for (int k = 0; k < 4; ++k)
        if (k != f) v[m++] = q[k];
      std::sort(v.begin(), v.end());
      keys[size_t(4 * t + f)] = {v[0], v[1], v[2], int32_t(4 * t + f)};
    }
  }
  std::sort(keys.begin(), keys.end(), [](const Key& x, const Key& y) {
    if (x.a != y.a) return x.a < y.a;
    if (x.b != y.b) return x.b < y.b;
    return x.c < y.c;
  });
  for (size_t i = 0; i + 1 < keys.size(); ++i) {
    const Key& x = keys[i];
    const Key& y = keys[i + 1];
    if (x.a == y.a && x.b == y.b && x.c == y.c) {
      topo.neighbor[size_t(x.slot)] = y.slot / 4;
      topo.neighbor[size_t(y.slot)] = x.slot / 4;
      ++i;
    }
  }
  if (!mesh.points.empty()) {
    topo.lo = topo.hi = mesh.points.front();
    for (const Vec3& p : mesh.points)
      for (int k = 0; k < 3; ++k) {
        topo.lo[k] = std::min(topo.lo[k], p[k]);
        topo.hi[k] = std::max(topo.hi[k], p[k]);
      }
  }
  std::set<int32_t> labels(mesh.materials.begin(), mesh.materials.end());
  if (mesh.materials.empty() && n) labels.insert(0);
  topo.labels.assign(labels.begin(), labels.end());
  return topo;
}

std::vector<double> computeMinDihedral(const TetMesh& mesh) {
  std::vector<double> v(mesh.numTets());
#pragma omp parallel for schedule(static)
  for (long long t = 0; t < (long long)mesh.numTets(); ++t) {
    const auto& q = mesh.tets[size_t(t)];
    v[size_t(t)] = minDihedral(mesh.points[q[0]], mesh.points[q[1]], mesh.points[q[2]], mesh.points[q[3]]);
  }
  return v;
}

std::vector<double> computeGradientMagnitude(const TetMesh& mesh, const std::vector<double>& u) {
  std::vector<double> g(mesh.numTets(), 0.0);
#pragma omp parallel for schedule(static)
  for (long long t = 0; t < (long long)mesh.numTets(); ++t) {
    const auto& q = mesh.tets[size_t(t)];
    const Vec3 &p0 = mesh.points[q[0]], &p1 = mesh.points[q[1]], &p2 = mesh.points[q[2]], &p3 = mesh.points[q[3]];
    const Vec3 e1 = p1 - p0, e2 = p2 - p0, e3 = p3 - p0;
    const double d = dot(e1, cross(e2, e3));
    if (std::abs(d) < 1e-300) continue;
    // grad u = sum_i (u_i - u_0) * (row i of inverse of [e1 e2 e3]^T)
    const Vec3 r1 = (1.0 / d) * cross(e2, e3), r2 = (1.0 / d) * cross(e3, e1), r3 = (1.0 / d) * cross(e1, e2);
    const double du1 = u[q[1]] - u[q[0]], du2 = u[q[2]] - u[q[0]], du3 = u[q[3]] - u[q[0]];
    const Vec3 grad = du1 * r1 + du2 * r2 + du3 * r3;
    g[size_t(t)] = norm(grad);
  }
  return g;
}

} // namespace tetflow::gui
