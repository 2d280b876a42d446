#pragma once
// Inline fixtures for the FEM tests: structured box meshes (6 tets per cube, Kuhn/Freudenthal
// split: every tet is a monotone path 000 -> 111 through the cube, so the split is conforming and
// invariant under the point reflection x -> -x of the grid), random perturbation of interior
// vertices, and a spherical-shell mesh mapped from a cube shell ("cubed ball").
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/FEM/Assembly.h"
#include "Algorithms/FEM/BoundaryConditions.h"

namespace tetflow::test {

// A direction drawn uniformly on the unit sphere.
inline Vec3 randomUnit(std::mt19937& rng) {
  std::normal_distribution<double> n;
  const Vec3 v{n(rng), n(rng), n(rng)};
  return (1.0 / norm(v)) * v;
}

struct GridIndex {
  int n[3];
  int32_t operator()(int i, int j, int k) const { return i + (n[0] + 1) * (j + (n[1] + 1) * k); }
};

// Box [lo, hi] with n[0] x n[1] x n[2] cubes, 6 tets each; label(cube i, j, k) gives materials.
inline TetMesh kuhnBox(std::array<int, 3> n, const Vec3& lo, const Vec3& hi,
                       const std::function<int32_t(int, int, int)>& label = nullptr) {
  TetMesh m;
  const GridIndex id{{n[0], n[1], n[2]}};
  for (int k = 0; k <= n[2]; ++k)
    for (int j = 0; j <= n[1]; ++j)
      for (int i = 0; i <= n[0]; ++i)
        m.points.push_back({lo[0] + (hi[0] - lo[0]) * i / n[0], lo[1] + (hi[1] - lo[1]) * j / n[1],
                            lo[2] + (hi[2] - lo[2]) * k / n[2]});
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i)
        for (const auto& p : perms) {
          int c[3] = {i, j, k};
          TetMesh::Tet t;
          t[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            t[size_t(s) + 1] = id(c[0], c[1], c[2]);
          }
          if (signedTetVolume(m.points[t[0]], m.points[t[1]], m.points[t[2]], m.points[t[3]]) < 0)
            std::swap(t[1], t[2]);
          m.tets.push_back(t);
          m.materials.push_back(label ? label(i, j, k) : 1);
        }
  return m;
}

// Moves every vertex not on the box boundary by a uniform random offset in [-a, a] per
// coordinate, a = fraction * (smallest cell edge); `frozen(v, axis)` keeps a coordinate.
inline void perturbInterior(TetMesh& m, const Vec3& lo, const Vec3& hi, double cellEdge, double fraction,
                            unsigned seed,
                            const std::function<bool(const Vec3&, int)>& frozen = nullptr) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  const double a = fraction * cellEdge;
  const double eps = 1e-9 * cellEdge;
  for (auto& p : m.points) {
    bool boundary = false;
    for (int c = 0; c < 3; ++c) boundary |= std::abs(p[c] - lo[c]) < eps || std::abs(p[c] - hi[c]) < eps;
    const Vec3 orig = p;
    const double d[3] = {uni(rng), uni(rng), uni(rng)}; // drawn for every vertex: fixed sequence
    if (boundary) continue;
    for (int c = 0; c < 3; ++c)
      if (!frozen || !frozen(orig, c)) p[c] += a * d[c];
  }
}

// Spherical shell r0 <= r <= r2 with an interface sphere at r1: label 1 inside r1, 2 outside.
// A cube grid over [-1,1]^3 with 6m cells per axis minus the inner cube [-1/3,1/3]^3 (Kuhn
// split), each vertex x mapped radially: s = |x|_inf in [1/3, 1] goes linearly to r in
// [r0, r1] (s <= 2/3) and [r1, r2] (s >= 2/3), direction x / |x|_2. Vertices with s = 1/3, 2/3, 1
// lie exactly on the spheres r0, r1, r2. `shellIndex` receives per vertex 0 (inner sphere),
// 2 (outer sphere) or 1 (elsewhere).
inline TetMesh cubedShell(int m, double r0, double r1, double r2, std::vector<int>& shellIndex) {
  const int N = 6 * m, h = 3 * m; // grid index i in [0, N], centred coordinate i - h
  const GridIndex id{{N, N, N}};
  const size_t nv = size_t(N + 1) * (N + 1) * (N + 1);
  std::vector<Vec3> cube(nv);
  std::vector<int> sInt(nv);
  for (int k = 0; k <= N; ++k)
    for (int j = 0; j <= N; ++j)
      for (int i = 0; i <= N; ++i) {
        const int ci = i - h, cj = j - h, ck = k - h;
        cube[size_t(id(i, j, k))] = {double(ci), double(cj), double(ck)};
        sInt[size_t(id(i, j, k))] = std::max({std::abs(ci), std::abs(cj), std::abs(ck)});
      }
  TetMesh full;
  full.points = cube;
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < N; ++k)
    for (int j = 0; j < N; ++j)
      for (int i = 0; i < N; ++i) {
        // cube centre in units of half cells: keep cubes outside the inner cube
        const int cmax = std::max({std::abs(2 * (i - h) + 1), std::abs(2 * (j - h) + 1), std::abs(2 * (k - h) + 1)});
        if (cmax < 2 * m) continue;
        const int32_t label = cmax < 4 * m ? 1 : 2;
        for (const auto& p : perms) {
          int c[3] = {i, j, k};
          TetMesh::Tet t;
          t[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            t[size_t(s) + 1] = id(c[0], c[1], c[2]);
          }
          if (signedTetVolume(cube[t[0]], cube[t[1]], cube[t[2]], cube[t[3]]) < 0) std::swap(t[1], t[2]);
          full.tets.push_back(t);
          full.materials.push_back(label);
        }
      }
  // Compact the used vertices and map them.
  std::vector<int32_t> newId(nv, -1);
  TetMesh out;
  shellIndex.clear();
  for (auto& t : full.tets)
    for (auto& v : t) {
      if (newId[size_t(v)] < 0) {
        newId[size_t(v)] = int32_t(out.points.size());
        const Vec3& x = cube[size_t(v)];
        const double s = double(sInt[size_t(v)]) / double(h); // in [1/3, 1]
        const double r = s <= 2.0 / 3.0 ? r0 + (s - 1.0 / 3.0) * 3.0 * (r1 - r0) : r1 + (s - 2.0 / 3.0) * 3.0 * (r2 - r1);
        out.points.push_back((r / norm(x)) * x);
        shellIndex.push_back(sInt[size_t(v)] == m ? 0 : sInt[size_t(v)] == 3 * m ? 2 : 1);
      }
      v = newId[size_t(v)];
    }
  out.tets = std::move(full.tets);
  out.materials = std::move(full.materials);
  return out;
}

// Solid ball of radius R about the origin with vertices on the sphere ("cubed ball"): the Kuhn
// split of the cube [-h, h]^3 (2h cells per axis), each vertex x mapped to x |x|_inf / |x|_2 *
// R / h, so every cube shell |x|_inf = s lands on the sphere of radius s R / h. One material
// (label 1). The boundary vertices lie exactly on the sphere r = R.
inline TetMesh cubedBall(int h, double R) {
  TetMesh m = kuhnBox({2 * h, 2 * h, 2 * h}, {-double(h), -double(h), -double(h)}, {double(h), double(h), double(h)});
  for (auto& p : m.points) {
    const double inf = std::max({std::abs(p[0]), std::abs(p[1]), std::abs(p[2])});
    const double two = norm(p);
    if (two > 0) p = (inf / two * R / double(h)) * p;
  }
  return m;
}

// A box of n cells per axis, [0, n], in 2-cell blocks of two materials (1 and 2) like a 3-D
// checkerboard, its interior vertices perturbed (seed), and its electrode problem: x = 0 at 1 V,
// x = n[0] at 0 V, sigma 1 and 0.01 S/m (contrast 100).
inline TetMesh checkerBox(std::array<int, 3> n, unsigned seed) {
  const Vec3 lo{0, 0, 0}, hi{double(n[0]), double(n[1]), double(n[2])};
  TetMesh m = kuhnBox(n, lo, hi, [](int i, int j, int k) { return (i / 2 + j / 2 + k / 2) % 2 ? 1 : 2; });
  perturbInterior(m, lo, hi, 1.0, 0.15, seed);
  return m;
}
inline ConductivityTable checkerSigma() {
  ConductivityTable s;
  s.set(1, 1.0);
  s.set(2, 0.01);
  return s;
}
inline ReducedSystem checkerElectrodeSystem(std::array<int, 3> n, unsigned seed) {
  const TetMesh m = checkerBox(n, seed);
  NullProgress np;
  const SparseMatrix K = assembleStiffness(m, checkerSigma(), np);
  DirichletSet d(m.numPoints());
  for (size_t v = 0; v < m.numPoints(); ++v) {
    if (m.points[v][0] == 0.0) d.set(v, 1.0);
    if (m.points[v][0] == double(n[0])) d.set(v, 0.0);
  }
  return eliminateDirichlet(K, Eigen::VectorXd::Zero(K.rows()), d);
}

} // namespace tetflow::test
