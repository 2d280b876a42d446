#pragma once
// Small label volumes built from a function of position, and what tests count on cleaved meshes:
// shared by the fidelity, thin-layer and volume-correction tests.
#include <functional>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/Core/Volume.h"
#include "Algorithms/Quality/LabelTopology.h"

namespace tetflow::test {

// An n^3 volume of 1 mm voxels (origin 0) labelled by f(x, y, z), coordinates from its centre.
inline LabelVolume labelVolumeOf(int n, const std::function<int32_t(double, double, double)>& f) {
  LabelVolume v;
  GridGeometry g;
  g.dims = {n, n, n};
  v.allocate(g, 0);
  const double c = (n - 1) / 2.0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) v.at(i, j, k) = f(i - c, j - c, k - c);
  return v;
}

// Labels by distance r from the centre of an n^3 volume: `inner` for r < r0, `layer` for
// r0 <= r < r1, `outer` beyond.
inline LabelVolume nestedBalls(int n, double r0, double r1, int32_t inner = 2, int32_t layer = 1, int32_t outer = 0) {
  return labelVolumeOf(n, [=](double x, double y, double z) {
    const double r = std::sqrt(x * x + y * y + z * z);
    return r < r0 ? inner : (r < r1 ? layer : outer);
  });
}

// Area of the faces between tets of labels a and b (mm^2).
inline double contactArea(const TetMesh& m, int32_t a, int32_t b) {
  NullProgress np;
  const auto nb = tetFaceNeighbours(m, np);
  double area = 0;
  for (size_t t = 0; t < m.numTets(); ++t)
    for (int f = 0; f < 4; ++f) {
      const int32_t o = nb[4 * t + size_t(f)];
      if (o <= int32_t(t)) continue;
      const int32_t x = m.materials[t], y = m.materials[size_t(o)];
      if ((x == a && y == b) || (x == b && y == a)) area += tetFaceArea(m, t, f);
    }
  return area;
}

} // namespace tetflow::test
