#pragma once
// Random label volumes of four kinds (blobs, thin sheets, octants touching at corners and edges,
// many-label Voronoi cells), 10..19 voxels a side with 2..8 labels, fixed by (kind, seed): the
// cleaving and mesh-improvement tests' random cases.
#include <memory>
#include <random>
#include <vector>

#include "Algorithms/Core/Volume.h"

namespace tetflow::test {

// Random label volumes of several kinds, fixed seeds.
inline std::shared_ptr<LabelVolume> randomVolume(int kind, unsigned seed) {
  std::mt19937 rng(seed);
  auto vol = std::make_shared<LabelVolume>();
  GridGeometry g;
  g.dims = {12 + int64_t(rng() % 8), 12 + int64_t(rng() % 8), 10 + int64_t(rng() % 8)};
  g.spacing = {1.0, 1.0 + 0.25 * (rng() % 3), 1.0};
  g.origin = {double(rng() % 7) - 3, 2.5, -1};
  vol->allocate(g, 0);
  std::uniform_real_distribution<double> u(0, 1);
  const int nLabels = 2 + int(rng() % 7); // 2..8 materials
  std::vector<int32_t> labels(nLabels);
  for (int i = 0; i < nLabels; ++i) labels[i] = i == 0 ? 0 : labels[i - 1] + 1 + int32_t(rng() % 40);
  const auto& d = g.dims;
  if (kind == 0) { // blobs
    for (int b = 0; b < 2 * nLabels; ++b) {
      const double cx = u(rng) * d[0], cy = u(rng) * d[1], cz = u(rng) * d[2], r = 1.5 + 4 * u(rng);
      const int32_t l = labels[rng() % nLabels];
      for (int64_t k = 0; k < d[2]; ++k)
        for (int64_t j = 0; j < d[1]; ++j)
          for (int64_t i = 0; i < d[0]; ++i)
            if ((i - cx) * (i - cx) + (j - cy) * (j - cy) + (k - cz) * (k - cz) < r * r) vol->at(i, j, k) = l;
    }
  } else if (kind == 1) { // thin sheets, one or two voxels thick, across the volume
    for (int s = 0; s < nLabels; ++s) {
      const int axis = int(rng() % 3);
      const int64_t at = int64_t(rng() % d[axis]);
      const int thick = 1 + int(rng() % 2);
      for (int64_t k = 0; k < d[2]; ++k)
        for (int64_t j = 0; j < d[1]; ++j)
          for (int64_t i = 0; i < d[0]; ++i) {
            const int64_t c = axis == 0 ? i : axis == 1 ? j : k;
            if (c >= at && c < at + thick) vol->at(i, j, k) = labels[s];
          }
    }
  } else if (kind == 2) { // octants touching at corners and edges
    const int64_t mx = d[0] / 2 + int64_t(rng() % 3) - 1, my = d[1] / 2, mz = d[2] / 2 + int64_t(rng() % 3) - 1;
    for (int64_t k = 0; k < d[2]; ++k)
      for (int64_t j = 0; j < d[1]; ++j)
        for (int64_t i = 0; i < d[0]; ++i)
          vol->at(i, j, k) = labels[((i < mx) + 2 * (j < my) + 4 * (k < mz)) % nLabels];
  } else { // many labels: random Voronoi cells
    std::vector<Vec3> seeds(static_cast<size_t>(3 * nLabels));
    for (auto& s : seeds) s = {u(rng) * d[0], u(rng) * d[1], u(rng) * d[2]};
    for (int64_t k = 0; k < d[2]; ++k)
      for (int64_t j = 0; j < d[1]; ++j)
        for (int64_t i = 0; i < d[0]; ++i) {
          size_t best = 0;
          double bd = 1e30;
          for (size_t s = 0; s < seeds.size(); ++s) {
            const Vec3 p{double(i), double(j), double(k)};
            const double dd = dot(p - seeds[s], p - seeds[s]);
            if (dd < bd) { bd = dd; best = s; }
          }
          vol->at(i, j, k) = labels[best % nLabels];
        }
  }
  return vol;
}

} // namespace tetflow::test
