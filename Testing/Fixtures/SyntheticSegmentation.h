#pragma once
// A synthetic abdominal-style segmentation with the properties of real ones: labels
// {0, 84, 85, 127, 255} (non-consecutive), anisotropic 0.617 x 0.617 x 1.333 mm voxels, a
// non-zero origin, smooth organ-like regions (so gzip compresses it as it would a real one).
// Used by the cross-format test (small) and the volume I/O benchmark (25 million voxels).
#include <cmath>

#include "Algorithms/Core/Volume.h"

namespace tetflow::test {

inline LabelVolume syntheticSegmentation(int64_t nx, int64_t ny, int64_t nz) {
  GridGeometry g;
  g.dims = {nx, ny, nz};
  g.spacing = {0.617, 0.617, 1.333};
  g.origin = {-157.6, -180.2, -412.25};
  LabelVolume v;
  v.allocate(g, 0);
  const double cx = 0.5 * nx * g.spacing[0], cy = 0.5 * ny * g.spacing[1], cz = 0.5 * nz * g.spacing[2];
#pragma omp parallel for schedule(static)
  for (int64_t k = 0; k < nz; ++k)
    for (int64_t j = 0; j < ny; ++j)
      for (int64_t i = 0; i < nx; ++i) {
        // Local coordinates relative to the box centre, scaled to the box (so any size works).
        const double x = (i * g.spacing[0] - cx) / cx, y = (j * g.spacing[1] - cy) / cy,
                     z = (k * g.spacing[2] - cz) / cz;
        int32_t label = 0;
        if (x * x / 0.8 + y * y / 0.6 + z * z / 1.1 < 1.0) label = 84; // body
        const double wob = 0.05 * std::sin(7 * x) * std::cos(5 * y);
        if ((x - 0.25) * (x - 0.25) / 0.12 + (y + 0.1) * (y + 0.1) / 0.08 + z * z / 0.3 < 1.0 + wob)
          label = 85; // organ inside the body, touching it
        if ((x + 0.3) * (x + 0.3) / 0.03 + (y - 0.2) * (y - 0.2) / 0.03 + (z - 0.2) * (z - 0.2) / 0.1 < 1.0)
          label = 127; // smaller organ
        if ((x + 0.05) * (x + 0.05) + (y + 0.35) * (y + 0.35) < 0.004) label = 255; // vessel along z
        v.at(i, j, k) = label;
      }
  return v;
}

} // namespace tetflow::test
