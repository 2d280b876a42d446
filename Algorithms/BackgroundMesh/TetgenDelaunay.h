#pragma once
// Delaunay tetrahedralization of a point set through TetGen's library interface (Debian
// libtet1.5-dev; Si 2015). The result covers the convex hull of the points.
#include <string>
#include <vector>

#include "Algorithms/Core/TetMesh.h"

namespace tetflow {

// Tets over `points` (0-based indices into them), all positively oriented (signedTetVolume > 0).
// `switches` are TetGen's command-line switches without the leading '-' ("" = plain Delaunay);
// "Q" (quiet) and "z" (0-based) are always added. Tets TetGen returns with no volume (four
// coplanar points) are dropped and counted in *flat. Throws ProcessingError with TetGen's reason
// when it fails (duplicate points are reported by TetGen, not an error: it skips them and they are
// counted in *duplicates). Points TetGen adds (a quality switch) are appended to `points`.
std::vector<TetMesh::Tet> tetgenDelaunay(std::vector<Vec3>& points, const std::string& switches,
                                         int64_t* flat = nullptr, int64_t* duplicates = nullptr);

} // namespace tetflow
