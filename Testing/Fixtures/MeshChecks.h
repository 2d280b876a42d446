#pragma once
// Validity of a mesh as the cleaving and mesh-improvement tests require it: no inverted, flat or
// duplicate tets, no face in more than two tets, a closed boundary, every vertex used; a mesh that
// tiles a box; closed material surfaces.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>
#include <vector>

#include "Algorithms/Quality/MeshQuality.h"

namespace tetflow::test {

inline void expectValidClosedMesh(const QualityResult& q) {
  EXPECT_TRUE(q.valid);
  EXPECT_EQ(q.inverted, 0);
  EXPECT_EQ(q.zeroVolume, 0);
  EXPECT_EQ(q.duplicateTets, 0);
  EXPECT_EQ(q.nonmanifoldFaces, 0);
  EXPECT_TRUE(q.boundaryClosed);
  EXPECT_EQ(q.unreferencedVertices, 0);
}

// Swaps two vertices of every tet of negative volume.
inline void orientPositive(TetMesh& m) {
  for (size_t t = 0; t < m.numTets(); ++t)
    if (m.tetVolume(t) < 0) std::swap(m.tets[t][0], m.tets[t][1]);
}

inline double triangleArea(const Vec3& a, const Vec3& b, const Vec3& c) { return 0.5 * norm(cross(b - a, c - a)); }

// The faces used by one tet only (vertex ids sorted).
inline std::vector<std::array<int32_t, 3>> boundaryFaces(const TetMesh& m) {
  std::map<std::array<int32_t, 3>, int> count;
  for (const auto& t : m.tets)
    for (int k = 0; k < 4; ++k) {
      std::array<int32_t, 3> s{t[(k + 1) % 4], t[(k + 2) % 4], t[(k + 3) % 4]};
      std::sort(s.begin(), s.end());
      ++count[s];
    }
  std::vector<std::array<int32_t, 3>> out;
  for (const auto& [s, c] : count)
    if (c == 1) out.push_back(s);
  return out;
}

// Their total area.
inline double boundaryArea(const TetMesh& m) {
  double area = 0;
  for (const auto& s : boundaryFaces(m))
    area += triangleArea(m.points[size_t(s[0])], m.points[size_t(s[1])], m.points[size_t(s[2])]);
  return area;
}

// The mesh tiles a box of edge lengths L: its volume is the box's, and so is its boundary area (a
// gap or a T-junction inside the box would add boundary area).
inline void expectTilesBox(const TetMesh& m, const QualityResult& q, const Vec3& L) {
  const double box = L[0] * L[1] * L[2];
  EXPECT_NEAR(q.volume, box, 1e-9 * box);
  const double surface = 2 * (L[0] * L[1] + L[1] * L[2] + L[0] * L[2]);
  EXPECT_NEAR(boundaryArea(m), surface, 1e-9 * surface);
}

// Every material's surface (faces against another material or the outside) is closed: each of
// its edges is used by an even number of those faces. Returns the number of open edges.
inline int64_t openMaterialSurfaceEdges(const TetMesh& m) {
  std::map<std::array<int32_t, 3>, std::vector<size_t>> faces;
  for (size_t t = 0; t < m.tets.size(); ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<int32_t, 3> k;
      int n = 0;
      for (int i = 0; i < 4; ++i)
        if (i != f) k[size_t(n++)] = m.tets[t][size_t(i)];
      std::sort(k.begin(), k.end());
      faces[k].push_back(t);
    }
  std::map<std::pair<int32_t, std::pair<int32_t, int32_t>>, int> edgeUse; // (material, edge)
  for (const auto& [k, ts] : faces) {
    std::vector<int32_t> mats;
    if (ts.size() == 1) mats = {m.materials[ts[0]]};
    else if (m.materials[ts[0]] != m.materials[ts[1]]) mats = {m.materials[ts[0]], m.materials[ts[1]]};
    for (int32_t mat : mats)
      for (int e = 0; e < 3; ++e) {
        const int32_t a = k[size_t(e)], b = k[size_t((e + 1) % 3)];
        ++edgeUse[{mat, {std::min(a, b), std::max(a, b)}}];
      }
  }
  int64_t open = 0;
  for (const auto& [k, n] : edgeUse) open += n % 2;
  return open;
}

} // namespace tetflow::test
