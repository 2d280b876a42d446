#pragma once
// Tetrahedralization of the inside of a closed triangle surface through TetGen's library (Debian
// libtet1.5-dev; Si 2015): a constrained Delaunay tetrahedralization of the surface as a
// piecewise-linear complex (switch p), every surface triangle kept as it is (Y: no Steiner point
// on the surface, so a surface mesher's triangles are the mesh's boundary faces), with TetGen's
// quality refinement in the inside (q: radius-edge ratio / minimum dihedral angle).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "Algorithms/Core/TetMesh.h"

namespace tetflow {

struct TetgenRegion {
  Vec3 point{}; // a point strictly inside the region
  int label = 1;
};

struct TetgenSurfaceStats {
  int64_t inputPoints = 0, addedPoints = 0; // Steiner points TetGen added inside
  int64_t flatDropped = 0;
};

// `quality` is TetGen's q switch value ("1.414/10" = radius-edge ≤ 1.414 and dihedral ≥ 10°; ""
// = no refinement); `maxVolume` > 0 adds a volume bound (a). With regions, each tet gets the
// label of the region its seed point is in and the tets of no region are removed; without, every
// tet inside the surface has label 1. Throws ProcessingError with TetGen's reason when it fails
// (e.g. a self-intersecting surface), InputError for an empty or out-of-range input.
TetMesh tetgenFromSurface(const std::vector<Vec3>& points, const std::vector<std::array<int32_t, 3>>& triangles,
                          const std::vector<TetgenRegion>& regions, const std::string& quality,
                          double maxVolume = 0, TetgenSurfaceStats* stats = nullptr);

} // namespace tetflow
