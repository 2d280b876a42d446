#pragma once
// Label-preserving mesh improvement: raises the worst dihedral angles of a multimaterial tet mesh
// (after cleaving, or read from a file) without changing what any material is.
//
// Score of a tet: s = min(theta_min, (180 - theta_max) * min_angle / (180 - max_angle)), so that
// s >= min_angle exactly when theta_min >= min_angle and theta_max <= max_angle (with the defaults
// 10 and 160: s = min(theta_min, (180 - theta_max) / 2)). Inverted and flat tets score below 0.
//
// Tets scoring below the goal (min_angle + goal_margin) are worked on, worst first, one at a time
// (serially, so the result is the same for any number of threads; only the scans are parallel).
// For each, these operations are tried in order until one raises the worst score of the tets it
// replaces (or, for smoothing, of the moved vertex's tets):
//   smooth    each vertex of the tet moves (pattern search) to maximise the worst score of its tets;
//   peel      a cap on a curved boundary (three faces on it, none on an axis-aligned plane, its
//             fourth corner in no other tet, its last face against its own material) is removed:
//             its volume goes to the outside, counted in the volume budget below;
//   flip      edge removal: the tets around one of its edges, all of one material and closing a
//             ring of 3..kMaxRing tets, are replaced by the best triangulation of the ring (dynamic
//             programming over the ring polygon; a ring of 3 is the 3-2 flip); 2-3 flip: the tet
//             and its neighbour across a face, both of one material, become three tets around the
//             edge joining their apexes;
//   collapse  a vertex of the tet whose tets are all of one material and off the boundary is merged
//             into another corner (its star is re-tiled from that corner);
//   insert    an edge of the tet is split at its midpoint (every tet around it is halved), and the
//             new vertex is smoothed;
//   flip      interface edge removal: an edge whose ring holds two materials in two arcs of at
//             least two tets each lies on their interface; the ring is re-triangulated through the
//             diagonal joining the arcs' ends, which re-diagonalises the interface quadrilateral
//             around the edge (the volume of the tet between the two diagonals changes sides,
//             within the volume budget below);
// and when none helps, the vertices around the tet are smoothed (each for its own star), which
// often makes room for the next pass. Up to `passes` passes run over the tets still below the goal
// and the ones the operations created.
// The last resort, for tets the passes left outside the targets themselves (nothing happens when
// there are none, so a mesh the passes fix is not touched by it), worst first, in up to 4 rounds:
//   move      each vertex of the tet is smoothed again, now with every vertex that is not on a
//             planar box face moving freely (on an interface, a curve or corner where materials
//             meet, a crease of a curved boundary), at most as far as a constrained vertex (10 % of
//             its longest edge) and under the same volume budget;
//   peel      a tet with one to three faces on a curved boundary, its other faces against tets of
//             its own material, is removed when the boundary stays a 2-manifold at each of its
//             corners (the boundary faces around the corner form one cycle), its material stays
//             connected among the tets around its corners, none of the faces involved lies on an
//             axis-aligned plane, and its volume fits the budget.
// Cleaving a segmentation whose exterior is stripped leaves such tets where the label repair made
// the outer surface follow a voxel's step (a pit or a crease), and at curves where three materials
// meet.
// Labels are preserved because:
//   - flips and collapses re-tile a region of one material with tets of that material, and an
//     edge split halves tets in place: no material's region changes at all; an interface edge
//     removal moves one tet's worth of volume across a two-material interface (budgeted) and keeps
//     both materials' tets around the edge (each arc keeps at least one triangle's pair of tets);
//     a peeled cap leaves its material (budgeted) and hangs on a face of its own material only, so
//     no component or contact goes with it (the last resort's peel: faces of its own material only,
//     its material connected without it);
//   - a vertex moves only as its surroundings allow (in the passes; the last resort frees it within
//     the budget, and no move changes a tet's label or the connectivity): inside one material
//     freely; on a surface between two labels (the outside counts as a label) in its tangent plane;
//     on a curve where three labels meet along the curve; where four or more labels meet, or at a
//     corner of the boundary, not at all. On a planar surface (a box face) or a straight curve (a
//     box edge) the move keeps the vertex on it exactly. A curved boundary (a stripped exterior) is
//     a surface against the outside: where it is smooth (every boundary face at the vertex within
//     30 degrees of their mean normal) the vertex moves in the mean tangent plane, or along the
//     curve where it meets one interface; at sharper creases it stays. Elsewhere (interfaces,
//     curved boundaries) a tangent move changes the materials' volumes to second order: each move
//     is accepted only while every material's net volume change stays within max_volume_change
//     percent of its volume, and a constrained vertex moves at most 10 % of its longest edge.
//   - no operation ever leaves a tet with a score below the worst it replaced, nor an inverted or
//     flat tet; connectivity changes only inside one material, so the label topology (components,
//     contacts) is that of the input.
// The domain stays the domain: a boundary vertex on a planar boundary patch or a straight boundary
// edge stays on it, and corners stay.
//
// Fields: point fields are kept (interpolated linearly at new midpoints; vertices removed by a
// collapse drop their values); a cell field's value on a new tet is that of one of the tets it
// replaced (the same material).
#include <cstdint>
#include <string>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/TetMesh.h"

namespace tetflow {

struct ImproveParams {
  double min_angle = 10.0;         // target smallest dihedral angle [deg], in (0, 60)
  double max_angle = 160.0;        // target largest dihedral angle [deg], in (90, 180)
  double goal_margin = 1.0;        // tets are worked on up to min_angle + goal_margin [deg]
  double max_volume_change = 0.05; // percent: net change allowed per material
  int passes = 6;                  // passes over the remaining bad tets
  bool smooth = true, flip = true, collapse = true, insert = true, peel = true;
  // Keep every boundary and interface face as it is: vertices on them do not move, no edge on
  // them is split, no interface edge is removed, no cap is peeled. For meshes whose surface was
  // placed on a CAD model's patches (MeshCADSurface), so that it stays there.
  bool fixSurfaces = false;
};

struct ImproveTet {  // a tet that still misses the target after improvement
  int64_t tet = 0;   // index in the output mesh
  int32_t material = 0;
  Vec3 centroid{0, 0, 0};
  double minDihedral = 0.0, maxDihedral = 0.0;
};

struct ImproveMaterial {
  int32_t label = 0;
  double volumeBefore = 0.0, volumeAfter = 0.0; // mm^3
};

struct ImproveStats {
  int64_t tetsBefore = 0, tetsAfter = 0, verticesBefore = 0, verticesAfter = 0;
  double minBefore = 0.0, maxBefore = 0.0, minAfter = 0.0, maxAfter = 0.0; // dihedral [deg]
  int64_t belowMinBefore = 0, aboveMaxBefore = 0, belowMinAfter = 0, aboveMaxAfter = 0;
  int64_t smoothed = 0, edgeRemovals = 0, interfaceFlips = 0, flips23 = 0, collapses = 0, insertions = 0;
  int64_t capsRemoved = 0; // "peel"
  int64_t boundaryPeels = 0;   // "last resort": tets peeled off a curved boundary
  int64_t lastResortMoves = 0; // "last resort": moves of otherwise constrained vertices
  int passes = 0;
  // A tet was added or removed: the tets are no longer those given, in their order (with none, only
  // vertices moved, and unreferenced vertices may have been dropped).
  bool tetsChanged = false;
  std::vector<ImproveMaterial> materials; // ascending label
  std::vector<ImproveTet> unfixed;        // the worst remaining (at most 20), worst first
  int64_t unfixedCount = 0;               // all tets still outside [min_angle, max_angle]
  double maxVolumeChangePercent() const;  // largest |after - before| / before over materials
};

// Improves `mesh` in place (it must be valid: positive tets, conforming). Throws InputError for
// parameters out of range (naming them) and Cancelled when cancelled. faceNeighbours (optional):
// the mesh's face neighbours (tetFaceNeighbours) on entry, carried to the improved mesh (what
// tetFaceNeighbours gives on it: the tets the improvement kept keep theirs, the faces of the tets
// it made or uncovered are matched again); left empty when empty or not of the mesh's size.
ImproveStats improveMesh(TetMesh& mesh, const ImproveParams& params, Progress& progress,
                         std::vector<int32_t>* faceNeighbours = nullptr);

// Score of a tet (see above) for the given targets.
double improveScore(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, double minAngle, double maxAngle);

// Figures for a module Report, keys prefixed "improve_".
void writeImproveReport(const ImproveStats& s, const ImproveParams& p, Report& report);

} // namespace tetflow
