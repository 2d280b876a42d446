#pragma once
// The exact tet mesh of a label volume: every voxel a cube split into the 6 Kuhn tets around its
// main diagonal (conforming across cubes), labelled with the voxel's label. Used to build meshes
// with known topology for the certificate and the label repair.
#include <algorithm>

#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/Core/Volume.h"

namespace tetflow::test {

// Every voxel a cube (its corners at the voxel's faces) split into the 6 Kuhn tets around its
// main diagonal: a conforming mesh that represents the label volume exactly.
inline TetMesh voxelMesh(const LabelVolume& v) {
  const auto& g = v.grid;
  const int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  TetMesh m;
  auto pid = [&](int64_t i, int64_t j, int64_t k) { return int32_t(i + (nx + 1) * (j + (ny + 1) * k)); };
  for (int64_t k = 0; k <= nz; ++k)
    for (int64_t j = 0; j <= ny; ++j)
      for (int64_t i = 0; i <= nx; ++i)
        m.points.push_back(g.indexToPhysical(double(i) - 0.5, double(j) - 0.5, double(k) - 0.5));
  const int step[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int64_t k = 0; k < nz; ++k)
    for (int64_t j = 0; j < ny; ++j)
      for (int64_t i = 0; i < nx; ++i) {
        int perm[3] = {0, 1, 2};
        do {
          int64_t c[3] = {i, j, k};
          TetMesh::Tet t;
          t[0] = pid(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            for (int a = 0; a < 3; ++a) c[a] += step[perm[s]][a];
            t[s + 1] = pid(c[0], c[1], c[2]);
          }
          m.tets.push_back(t);
          m.materials.push_back(v.at(i, j, k));
          if (m.tetVolume(m.numTets() - 1) < 0) std::swap(m.tets.back()[0], m.tets.back()[1]);
        } while (std::next_permutation(perm, perm + 3));
      }
  return m;
}

// Tets of voxel (i,j,k) in voxelMesh: 6 consecutive ones.
inline size_t firstTet(const LabelVolume& v, int64_t i, int64_t j, int64_t k) { return size_t(6 * v.index(i, j, k)); }
inline void relabelVoxel(const LabelVolume& v, TetMesh& m, int64_t i, int64_t j, int64_t k, int32_t L) {
  for (size_t t = firstTet(v, i, j, k); t < firstTet(v, i, j, k) + 6; ++t) m.materials[t] = L;
}

} // namespace tetflow::test
