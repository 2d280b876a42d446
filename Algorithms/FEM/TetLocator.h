#pragma once
// Point location for many points in one mesh: the same answer as locatePoint() (Assembly.h: the
// lowest-index tet whose closure contains the point, barycentric coordinates >= -1e-10), from a
// uniform grid of buckets instead of a pass over every tet. Lead fields with thousands of source
// points, St. Venant and subtraction sources and MEG coils query it once per point.
//
// The grid is built at the 5th query (the first four are plain passes, so a single dipole pays
// nothing for it): cell edge 1.5 (box volume / tets)^(1/3), each tet in every cell its bounding
// box (padded as locatePoint pads it) overlaps; about 12 bytes per tet, ~0.3 s for 4 M tets on 2
// threads. locate() is safe to call from several threads at once.
#include <atomic>
#include <cstdint>
#include <mutex>
#include <optional>
#include <vector>

#include "Algorithms/Core/TetMesh.h"
#include "Assembly.h"

namespace tetflow {

// locatePoint's two steps: whether the closure of tet t holds p (padded bounding box, then every
// barycentric coordinate >= -1e-10), and p's barycentric coordinates in t.
bool tetContainsPoint(const TetMesh& mesh, int64_t t, const Vec3& p);
PointLocation pointLocationIn(const TetMesh& mesh, int64_t t, const Vec3& p);

class TetLocator {
public:
  explicit TetLocator(const TetMesh& mesh) : mesh_(mesh) {}
  TetLocator(const TetLocator&) = delete;
  TetLocator& operator=(const TetLocator&) = delete;

  std::optional<PointLocation> locate(const Vec3& p) const;
  bool built() const { return built_.load(); }

private:
  void build() const;
  int64_t cellOf(double x, int axis) const; // the grid cell along `axis`, clamped to the grid

  const TetMesh& mesh_;
  mutable std::atomic<int> queries_{0};
  mutable std::atomic<bool> built_{false};
  mutable std::once_flag once_;
  mutable Vec3 lo_{0, 0, 0};
  mutable double h_ = 1.0;
  mutable std::array<int64_t, 3> dims_{1, 1, 1};
  mutable std::vector<int64_t> offset_; // cell c's tets: tets_[offset_[c] .. offset_[c + 1])
  mutable std::vector<int32_t> tets_;
};

} // namespace tetflow
