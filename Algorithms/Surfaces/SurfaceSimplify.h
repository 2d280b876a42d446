#pragma once
// Smoothing and decimation of closed BEM surfaces that keep them closed, manifold and nested.
//
// A surface cut from a voxel-born mesh is a staircase of many small triangles (100 k for the
// default head's inner skull), where BEM solvers want a few thousand smooth ones (MNE's standard
// is 5120 per surface). Both operations here change one surface against fixed obstacles (the
// surfaces it must stay between) and never let it cross them or itself:
//
// smoothSurface: Taubin's lambda|mu smoothing (lambda 0.5, mu -0.53: a shrinking step toward the
// neighbours' mean, then an inflating one, so the volume stays), `iterations` pairs of steps. A
// vertex moves only if afterwards none of its triangles crosses an obstacle or another triangle of
// the surface, turns over (normal turned by more than 90 degrees) or gets thinner than a quality of
// 0.05 (4 sqrt3 area / sum of squared edges; 1 for an equilateral triangle).
//
// decimateSurface: edge collapses in order of the quadric error (Garland & Heckbert 1997: the
// sum of squared distances to the planes of the triangles merged into a vertex, area-weighted;
// the new point minimises it, or is the better end or the midpoint where that is ill-posed) until
// at most targetTriangles remain or no collapse is allowed. A collapse is allowed when it keeps
// the surface a closed 2-manifold (the edge's ends share exactly the two neighbours across the
// edge, and every vertex keeps three neighbours or more) and its new triangles pass the tests of
// smoothSurface (with a quality floor of 0.1).
//
// Both keep TriSurface::meshVertex for the points that remain, renumber points compactly and
// report what they did and what they refused.
#include <cstdint>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Surfaces/BemSurfaces.h"

namespace tetflow {

struct SurfaceEditStats {
  int64_t moves = 0;             // smoothing: vertex moves made
  int64_t collapses = 0;         // decimation: edges collapsed
  int64_t refusedTopology = 0;   // a collapse that would not keep a closed manifold
  int64_t refusedShape = 0;      // a triangle turned over or too thin
  int64_t refusedCrossing = 0;   // a triangle would cross an obstacle or the surface
};

SurfaceEditStats smoothSurface(TriSurface& s, const std::vector<const TriSurface*>& obstacles, int iterations,
                               const Progress& progress);

SurfaceEditStats decimateSurface(TriSurface& s, const std::vector<const TriSurface*>& obstacles,
                                 int64_t targetTriangles, const Progress& progress);

} // namespace tetflow
