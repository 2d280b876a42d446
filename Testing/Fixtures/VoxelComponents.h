#pragma once
// Plain voxel-by-voxel references for the label-image analysis (LabelTopology.h, LabelRuns.h) and
// the certificate: BFS components of equal labels, numbered in scan order, and the core rule.
#include <array>
#include <cstdint>
#include <cstdlib>
#include <deque>
#include <utility>
#include <vector>

#include "Algorithms/Core/Volume.h"

namespace tetflow::test {

inline bool insideVolume(const LabelVolume& v, int i, int j, int k) {
  return i >= 0 && j >= 0 && k >= 0 && i < int(v.grid.dims[0]) && j < int(v.grid.dims[1]) && k < int(v.grid.dims[2]);
}

// A core voxel: its six face neighbours in the volume carry its label.
inline bool isCoreVoxel(const LabelVolume& v, int i, int j, int k) {
  const int d[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const auto& e : d)
    if (insideVolume(v, i + e[0], j + e[1], k + e[2]) && v.at(i + e[0], j + e[1], k + e[2]) != v.at(i, j, k))
      return false;
  return true;
}

// Components of equal labels among the voxels with member(i, j, k), 26-connected (`full`) or
// 6-connected, by BFS, numbered in scan order: (per voxel component or -1, count).
template <class Member>
std::pair<std::vector<int32_t>, int32_t> voxelComponents(const LabelVolume& v, Member member, bool full) {
  const int nx = int(v.grid.dims[0]), ny = int(v.grid.dims[1]), nz = int(v.grid.dims[2]);
  std::vector<int32_t> comp(size_t(v.grid.voxelCount()), -1);
  int32_t n = 0;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (!member(i, j, k) || comp[size_t(v.index(i, j, k))] >= 0) continue;
        std::deque<std::array<int, 3>> q{{i, j, k}};
        comp[size_t(v.index(i, j, k))] = n;
        while (!q.empty()) {
          const auto [a, b, c] = q.front();
          q.pop_front();
          for (int dk = -1; dk <= 1; ++dk)
            for (int dj = -1; dj <= 1; ++dj)
              for (int di = -1; di <= 1; ++di) {
                const int s = std::abs(di) + std::abs(dj) + std::abs(dk);
                if (s == 0 || (!full && s != 1)) continue;
                const int x = a + di, y = b + dj, z = c + dk;
                if (!insideVolume(v, x, y, z) || !member(x, y, z) || v.at(x, y, z) != v.at(a, b, c)) continue;
                if (comp[size_t(v.index(x, y, z))] >= 0) continue;
                comp[size_t(v.index(x, y, z))] = n;
                q.push_back({x, y, z});
              }
        }
        ++n;
      }
  return {comp, n};
}

} // namespace tetflow::test
