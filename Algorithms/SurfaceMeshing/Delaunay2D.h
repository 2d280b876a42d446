#pragma once
// Robust 2D Delaunay triangulation of a point set, for triangulating surface patches in parameter
// space (where grids, circles and uniformly sampled straight boundaries make cocircular and
// collinear points the rule rather than the exception).
//
// Algorithm: incremental Bowyer-Watson with triangle adjacency. The outside of the convex hull is
// covered by "ghost" triangles that share a vertex at infinity, so there is no super-triangle to
// get wrong: the result covers exactly the convex hull, collinear hull points included (they are
// vertices, never corners of zero-area triangles). Points are inserted in BRIO order (random
// rounds of doubling size, each sorted along a Hilbert curve) and located by a stochastic
// visibility walk from the last new triangle, so the expected cost is O(n log n).
//
// Robustness: orient2D and inCircle2D use a floating-point filter with Shewchuk's error bounds and
// fall back to exact expansion arithmetic, so every decision is exact. Before triangulating, the
// coordinates are normalised: each axis is translated to start at 0 when that subtraction is
// exact for every point, and both axes are scaled by the same power of two so that the bounding
// box is about the unit square. Both steps are exact and a similarity, so the result is the
// Delaunay triangulation of the input coordinates themselves (a per-axis stretch would change
// which triangulation is Delaunay; callers that want one, e.g. for an anisotropic parameter
// domain, scale their points before calling). The only rounding: a normalised coordinate below
// 2^-200 of the box is flushed to 0, which keeps the exact arithmetic clear of underflow.
//
// When four or more points are cocircular the Delaunay triangulation is not unique; which one is
// returned depends on the (deterministic, platform-independent) insertion order.
#include <array>
#include <cstdint>
#include <vector>

#include "Algorithms/Core/Geometry.h"

namespace tetflow {

struct Triangulation2D {
  // Indices into the input points, counter-clockwise (positive signed area).
  std::vector<std::array<int32_t, 3>> triangles;
  // Input points skipped because they lie within 1e-12 of the bounding box size (its longest
  // side) of an earlier kept point. Skipped points appear in no triangle.
  int64_t duplicates = 0;
};

// Delaunay triangulation of the convex hull of `points`. Every point that is not a duplicate is a
// vertex of some triangle. Throws InputError when a coordinate is not finite, or when there are
// fewer than 3 distinct points or they are all collinear.
Triangulation2D delaunay2D(const std::vector<Point2>& points);

// The predicates' signs are exact whenever every coordinate is 0 or of magnitude between 2^-200
// and 2^200 (then nothing in the exact arithmetic underflows or overflows); delaunay2D normalises
// its points into that range. Their values are approximations of the determinants.

// Twice the signed area of triangle (a, b, c): > 0 when counter-clockwise, < 0 when clockwise,
// exactly 0 when collinear.
double orient2D(const Point2& a, const Point2& b, const Point2& c);

// > 0 when d lies strictly inside the circumcircle of the counter-clockwise triangle (a, b, c),
// < 0 when strictly outside, exactly 0 when on it (the sign flips for clockwise a, b, c).
double inCircle2D(const Point2& a, const Point2& b, const Point2& c, const Point2& d);

// For each undirected edge (pair of point indices), whether it is an edge of the triangulation.
std::vector<bool> hasEdges(const Triangulation2D& t, const std::vector<std::array<int32_t, 2>>& edges);

} // namespace tetflow
