#pragma once
// Parameter-space triangulation of a CAD model's particle sample (seed §3.4): every patch is
// triangulated in its own (u, v) parameters, where a 2-D Delaunay triangulation is cheap and
// exact, and the patches are stitched along their shared curves through the particle indices, so
// the result is one closed triangle surface whose vertices are the sample's particles.
//
// First, a curve whose chain (corner0, its particles, corner1) would join the same two particles
// twice (a closed curve with fewer than two particles; two curves between the same corners without
// particles) is split, since every link of a chain becomes an edge of the surface. Then, per patch,
// in rounds:
//   1. Boundary loops in the parameters: each loop's curve uses in order, each contributing its
//      start corner and then its curve's particles in traversal order, placed by the use's pcurve.
//      A seam (a curve the patch uses on both sides) appears twice with different (u, v) and the
//      same particles; a degenerate edge (a sphere's pole) gets points along its pcurve, spaced like
//      the neighbouring boundary segments (at least two), that all stand for its corner's particle.
//   2. Affine scaling (seed 3.15): the parameters are mapped by A = G^(1/2), G the mean of J^T J
//      (J = [dS/du dS/dv]) over the patch's points where J is regular, so that distances in the
//      scaled plane match 3-D distances as well as one linear map can.
//   3. Interior particles strictly inside the diametral circle of a boundary segment (two
//      consecutive loop points, scaled) are removed from the patch: they would keep that segment
//      out of the Delaunay triangulation.
//   4. The Delaunay triangulation (Delaunay2D.h) of loop points and interior particles, scaled. A
//      boundary segment that is not one of its edges is split: a new particle on its curve at the
//      mid parameter (a degenerate edge gets twice as many points instead). A split changes the
//      curve in every patch that uses it, so those patches are redone in the next round; at most
//      12 rounds.
//   5. With every boundary segment an edge, the triangles fall into regions separated by the
//      segments, each wholly inside the loops or wholly outside. A region's side is read from the
//      orientation of its segments (OpenCASCADE puts a forward face on the left of its loops), an
//      exact test; the even-odd rule on a centroid decides only if the segments disagree.
//   6. Lifting to 3-D through the particle indices. Triangles with a repeated particle are dropped:
//      along a degenerate edge that is the strip that collapses into the pole; anywhere else (both
//      sides of a seam in one triangle) the sample is too coarse for the patch, an error. A
//      counter-clockwise triangle in (u, v) has the normal dS/du x dS/dv; it is reversed when the
//      patch is, so normals point out of the solid.
// Then 3-D edge flips (seed §3.4, after Cheng and Dey) improve each patch: an edge inside a patch
// (not on a curve) is flipped when its two opposite angles sum to more than π, the flipped pair's
// sum is smaller, both new triangles face within 90° of the surface normal and the new edge does not
// exist yet; at most 20 passes. Across a pole, triangles are neighbours through the pole's copies,
// so flips also remove the slivers a pole's parameter-space distortion leaves beside a seam.
// Last, the surface is checked: every edge in exactly two triangles, in opposite directions.
#include <cstdint>

#include "Algorithms/SurfaceMeshing/CadSample.h"

namespace tetflow {

struct CadTriangulationStats {
  int rounds = 0;                 // triangulation rounds (1 when no boundary segment was missing)
  int64_t curveSplits = 0;        // particles added on curves
  int64_t encroachingRemoved = 0; // patch particles removed for encroaching upon a boundary segment
  int64_t flips = 0;              // 3-D edge flips
  int64_t degenerateDropped = 0;  // lifted triangles with a repeated particle (poles)
  int64_t foldsCancelled = 0;     // pairs of lifted triangles on the same particles in opposite directions
};

// Triangulates every patch in its (affinely scaled) parameter space and stitches the patches along
// their shared curves through the particle indices. May add particles on curves (splitting a curve
// segment whose two ends are not a Delaunay edge in some patch, at the mid parameter; sample.onCurve
// stays sorted) and remove patch particles that encroach upon a boundary segment (from
// sample.onPatch only; they stay in sample.particles, used by no triangle).
// Throws ProcessingError naming the patch when a boundary cannot be recovered after 12 rounds, when
// two of its boundary points coincide in the parameters (duplicate particles), or when the lifted
// surface is not closed and manifold there (a sample too coarse for the patch, e.g. across a seam
// of a thin tube).
CadSurfaceMesh triangulateCadSample(const CadModel& model, CadSample& sample, CadTriangulationStats* stats = nullptr);

} // namespace tetflow
