#pragma once
// Regular-grid volumes with physical units kept end to end.
//
// Layout: data[i + nx*(j + ny*k)], i fastest (x), 0-based indices.
// Geometry: the centre of voxel (i,j,k) lies at
//     p = origin + direction * (i*spacing[0], j*spacing[1], k*spacing[2])      (mm)
// `direction` holds the unit physical directions of the i, j, k axes as its *columns*
// (row-major storage, direction[row][col]). Identity for an axis-aligned grid; a grid with axis
// flips or a rotation keeps its matrix here, and algorithms that cannot handle it say so.
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "Geometry.h"

namespace tetflow {

struct GridGeometry {
  std::array<int64_t, 3> dims{0, 0, 0};
  Vec3 spacing{1.0, 1.0, 1.0}; // mm, each > 0
  Vec3 origin{0.0, 0.0, 0.0};  // mm, centre of voxel (0,0,0)
  Mat3 direction = identity3(); // columns: unit directions of the i, j, k axes

  int64_t voxelCount() const { return dims[0] * dims[1] * dims[2]; }
  double voxelVolume() const { return spacing[0] * spacing[1] * spacing[2]; }
  Vec3 indexToPhysical(double i, double j, double k) const {
    const Vec3 s{i * spacing[0], j * spacing[1], k * spacing[2]};
    return origin + mul(direction, s);
  }
  // True when direction is the identity (to 1e-9).
  bool isAxisAligned() const;
  // Throws InputError (prefixed by `what`, e.g. a file name) when dims are not all >= 1, a spacing
  // is not a finite positive number, the origin is not finite, or direction is not orthonormal.
  void validate(const std::string& what) const;
  bool operator==(const GridGeometry&) const = default;
};

template <class T>
struct Volume {
  GridGeometry grid;
  std::vector<T> data; // size grid.voxelCount()
  // Label volumes: the tissue name and the conductivity [S/m] of label values, where a label
  // table (LabelTable.h) or the phantom gives them; labels without an entry have none.
  std::map<int32_t, std::string> labelNames;
  std::map<int32_t, double> labelConductivities;

  int64_t index(int64_t i, int64_t j, int64_t k) const {
    return i + grid.dims[0] * (j + grid.dims[1] * k);
  }
  T& at(int64_t i, int64_t j, int64_t k) { return data[static_cast<size_t>(index(i, j, k))]; }
  const T& at(int64_t i, int64_t j, int64_t k) const {
    return data[static_cast<size_t>(index(i, j, k))];
  }
  // Allocate for `g` and fill with `value` (validates g first).
  void allocate(const GridGeometry& g, T value = T{}) {
    g.validate("volume");
    grid = g;
    data.assign(static_cast<size_t>(g.voxelCount()), value);
  }
};

// Integer labels, any values (gaps allowed, negative allowed): 0/85/127/255 is fine.
using LabelVolume = Volume<int32_t>;
// Float values: indicator functions, distances, sizing fields.
using ScalarVolume = Volume<float>;

// Voxel count per label value, ascending by label. Parallel.
std::map<int32_t, int64_t> labelCounts(const LabelVolume& v);

// Throws InputError naming `what` and the first offending voxel (i,j,k) if any value is NaN/Inf.
void requireFinite(const ScalarVolume& v, const std::string& what);

} // namespace tetflow
