#pragma once
// Self-intersection check of a closed triangle surface, run before TetGen: TetGen takes the
// surface as a piecewise-linear complex whose facets meet only in shared edges and vertices, and
// on a self-intersecting surface it crashes (a segfault inside its memory pool) instead of
// reporting an error. This check names the offending triangle pairs, so the caller can throw an
// InputError instead.
//
// What counts as an intersection: triangles sharing an edge may meet only along it (folded over
// onto each other, dihedral angle ~0, they intersect); triangles sharing one vertex only at it (a
// fold through the shared vertex is an intersection); other triangles not at all (touching
// counts, and so do coincident or overlapping coplanar triangles). Sharing is by index: a point
// duplicated under another index is not shared (weld duplicates first). Triangles with a
// repeated vertex index are skipped.
//
// Arithmetic is plain double, each pair translated to one of its corners, with the relative
// tolerance kRelTol = 1e-10 of the smaller triangle's longest edge (L):
//   - no shared vertex: the triangles' distance is computed as the least distance between an
//     edge of one and the other triangle (a segment crossing a triangle has distance 0), between
//     points that lie on the triangles; pairs closer than kRelTol L are reported. So a pair with a
//     gap of more than ~1e-10 L is never reported and a crossing or touching pair always is.
//   - one shared vertex v: the corners at v are compared as cones (a convex intersection that
//     holds v and another point holds a whole segment from v), with kRelTol radians of slack:
//     reported when they share a direction from v.
//   - a shared edge: reported when the third vertices are on the same side and the two
//     triangles' separation over their common width (the smaller height times the sine of the
//     dihedral angle) is below kRelTol L.
// Near-degenerate triangles (sliver, area ~ eps L^2) make these decisions only as accurate as
// their normals, i.e. to ~eps L^2 / area.
//
// Search: the triangles' bounding boxes (padded by kRelTol L) go into a uniform grid of cubic
// cells of the mean edge length (larger when the boxes would fill more than 16 cells per
// triangle on average), stored as a spatial hash with at least as many buckets as box-cell
// entries, so well-shaped surfaces cost O(n). Each candidate pair is tested once, in the cell
// holding the lower corner of the boxes' intersection. Triangles are processed in blocks in index
// order, in parallel (OpenMP) within a block; the search stops after the block in which
// maxReported pairs are reached, so the result -- the maxReported lexicographically smallest
// pairs (a, b), a < b, with their points -- does not depend on the number of threads.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "Algorithms/Core/Geometry.h"

namespace tetflow {

// Two triangles (indices into the triangle list, a < b) that intersect, and a point of their
// intersection away from what they share (on both triangles to within the tolerance).
struct SurfaceIntersection {
  int32_t a = -1, b = -1;
  Vec3 where{};
};

// The intersecting pairs of `triangles` (indices into `points`), at most maxReported of them:
// the lexicographically smallest. Throws InputError for an out-of-range index or a non-finite
// coordinate of a used point.
std::vector<SurfaceIntersection> surfaceIntersections(const std::vector<Vec3>& points,
                                                      const std::vector<std::array<int32_t, 3>>& triangles,
                                                      size_t maxReported = 10);

// The pairwise test surfaceIntersections applies to its candidate pairs: whether triangles s and
// t intersect other than in what they share; `where` (if given) gets a point of the intersection
// when they do. False when s or t repeats a vertex index. Throws InputError for an out-of-range
// index.
bool trianglesIntersect(const std::vector<Vec3>& points, const std::array<int32_t, 3>& s,
                        const std::array<int32_t, 3>& t, Vec3* where = nullptr);

} // namespace tetflow
