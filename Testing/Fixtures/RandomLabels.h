#pragma once
// Random label volumes with thin structures, shared by the fidelity test and benchmark: Voronoi
// cells of 4..11 random seeds carrying 2..6 labels, crossed by two one-voxel sheets (labels K and
// K + 1 for K labels), each sheet a plane of one voxel across half the volume in one direction
// and all of it in the other.
#include <random>
#include <vector>

#include "Algorithms/Core/Volume.h"

namespace tetflow::test {

inline LabelVolume voronoiWithSheets(std::mt19937& rng, int n) {
  LabelVolume v;
  GridGeometry g;
  g.dims = {n, n, n};
  v.allocate(g, 0);
  std::uniform_real_distribution<double> u(0.0, n);
  const int seeds = 4 + int(rng() % 8), labels = 2 + int(rng() % 5);
  std::vector<Vec3> s;
  std::vector<int32_t> l;
  for (int i = 0; i < seeds; ++i) {
    s.push_back({u(rng), u(rng), u(rng)});
    l.push_back(int32_t(rng() % labels));
  }
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        double best = 1e300;
        for (size_t q = 0; q < s.size(); ++q) {
          const Vec3 d = Vec3{double(i), double(j), double(k)} - s[q];
          if (dot(d, d) < best) {
            best = dot(d, d);
            v.at(i, j, k) = l[q];
          }
        }
      }
  for (int sheet = 0; sheet < 2; ++sheet) {
    const int axis = int(rng() % 3), at = 2 + int(rng() % (n - 4));
    const int32_t L = labels + sheet;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        int idx[3];
        idx[axis] = at;
        idx[(axis + 1) % 3] = a;
        idx[(axis + 2) % 3] = b;
        if (a > n / 4 && a < 3 * n / 4) v.at(idx[0], idx[1], idx[2]) = L;
      }
  }
  return v;
}
} // namespace tetflow::test
