#include "Volume.h"

#include <cmath>
#include <sstream>

#include "Errors.h"

namespace tetflow {

bool GridGeometry::isAxisAligned() const {
  const Mat3 id = identity3();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      if (std::abs(direction[r][c] - id[r][c]) > 1e-9) return false;
  return true;
}

void GridGeometry::validate(const std::string& what) const {
  for (int a = 0; a < 3; ++a) {
    if (dims[a] < 1) {
      std::ostringstream m;
      m << what << ": dimension " << a << " is " << dims[a] << "; every dimension must be >= 1";
      throw InputError(m.str());
    }
    if (!std::isfinite(spacing[a]) || spacing[a] <= 0.0) {
      std::ostringstream m;
      m << what << ": spacing along axis " << a << " is " << spacing[a]
        << "; voxel spacing must be a positive number (mm)";
      throw InputError(m.str());
    }
    if (!std::isfinite(origin[a])) {
      throw InputError(what + ": the origin is not a finite number");
    }
  }
  // Orthonormal columns.
  for (int c = 0; c < 3; ++c) {
    for (int d = c; d < 3; ++d) {
      double s = 0.0;
      for (int r = 0; r < 3; ++r) s += direction[r][c] * direction[r][d];
      const double want = (c == d) ? 1.0 : 0.0;
      if (!std::isfinite(s) || std::abs(s - want) > 1e-4) {
        throw InputError(what +
                         ": the axis directions are not orthonormal (sheared or scaled grid); "
                         "only rotations and axis flips of a regular grid are supported");
      }
    }
  }
}

std::map<int32_t, int64_t> labelCounts(const LabelVolume& v) {
  const int64_t n = static_cast<int64_t>(v.data.size());
  std::map<int32_t, int64_t> total;
#pragma omp parallel
  {
    std::map<int32_t, int64_t> local;
    int32_t last = 0;
    int64_t run = 0;
#pragma omp for schedule(static) nowait
    for (int64_t i = 0; i < n; ++i) {
      const int32_t l = v.data[static_cast<size_t>(i)];
      if (run > 0 && l == last) {
        ++run;
      } else {
        if (run > 0) local[last] += run;
        last = l;
        run = 1;
      }
    }
    if (run > 0) local[last] += run;
#pragma omp critical
    for (const auto& [l, c] : local) total[l] += c;
  }
  return total;
}

void requireFinite(const ScalarVolume& v, const std::string& what) {
  const int64_t n = static_cast<int64_t>(v.data.size());
  int64_t bad = n;
#pragma omp parallel for reduction(min : bad)
  for (int64_t i = 0; i < n; ++i)
    if (!std::isfinite(v.data[static_cast<size_t>(i)]) && i < bad) bad = i;
  if (bad < n) {
    const int64_t nx = v.grid.dims[0], ny = v.grid.dims[1];
    std::ostringstream m;
    m << what << ": value at voxel (" << bad % nx << ", " << (bad / nx) % ny << ", "
      << bad / (nx * ny) << ") is " << v.data[static_cast<size_t>(bad)]
      << "; NaN and infinite values are not allowed in a scalar volume";
    throw InputError(m.str());
  }
}

} // namespace tetflow
