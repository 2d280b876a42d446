#pragma once
// Scalar fields sampled from a function of the physical position, and the box a grid covers: the
// background-mesh tests' inputs.
#include <functional>

#include "Algorithms/Core/Volume.h"

namespace tetflow::test {

// f at every sample centre of g.
inline ScalarVolume fieldOn(const GridGeometry& g, const std::function<double(const Vec3&)>& f) {
  ScalarVolume v;
  v.allocate(g);
  for (int64_t k = 0; k < g.dims[2]; ++k)
    for (int64_t j = 0; j < g.dims[1]; ++j)
      for (int64_t i = 0; i < g.dims[0]; ++i) v.at(i, j, k) = float(f(g.indexToPhysical(double(i), double(j), double(k))));
  return v;
}

// Edge lengths of the box of the grid's voxel cells (plus `pad` on every side), in its own frame.
inline Vec3 boxLengths(const GridGeometry& g, double pad) {
  return {double(g.dims[0]) * g.spacing[0] + 2 * pad, double(g.dims[1]) * g.spacing[1] + 2 * pad,
          double(g.dims[2]) * g.spacing[2] + 2 * pad};
}

} // namespace tetflow::test
