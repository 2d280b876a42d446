#pragma once
// Graded BCC background mesh on a balanced octree driven by a sizing field (seed §4.8.1 grading,
// §5.6 "adaptive octree background meshes").
//
// Cells. The box (the volume's voxel cells plus `padding`) is split into root cells of at most
// max_cell_size per axis (n_a = ceil(L_a / max_cell_size), so cells tile the box exactly and are
// slightly rectangular when L_a is not a multiple). A cell is split into 8 while the smallest
// sizing-field value over it (the samples inside it, or the nearest sample when none is) is below
// its longest edge, and its children would not be smaller than min_cell_size. The tree is then
// balanced: leaves that touch (by a face, an edge or a corner) differ by at most one level.
//
// Vertices: leaf corners (kind Primal), leaf centres (Dual), and the centres of leaf faces on the
// box (FaceCentre). Tets: every leaf face is a "piece" shared by the two leaves on either side (the
// smaller leaf's face when their sizes differ) or by a leaf and the box. Each piece spans the
// double pyramid between the two centres (or the centre and the face centre on the box), cut into
// one tet per piece edge: (centre, other centre, a, b). The segment between the two centres
// crosses the piece inside it (at 1/3 of the small face from its inner corner when sizes differ),
// so these tets are positive and tile the box. An edge (a, b) whose midpoint is a vertex (a corner
// of a smaller leaf around that edge) is split there: two tets (.., a, m), (.., m, b) - the
// bisected BCC tets of Labelle & Shewchuk - so the mesh is conforming. Between equal leaves away
// from level changes the tets are the regular BCC tets (dihedral angles 60 and 90 degrees).
//
// Indices: vertices 0-based in order of first use over the leaves sorted by (level, z, y, x); all
// tets positively oriented; total volume = box volume.
#include <cstdint>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/Volume.h"
#include "BccLattice.h"

namespace tetflow {

struct OctreeBccParams {
  double min_cell_size = 0.0; // mm, smallest leaf edge; 0 = the sizing field's minimum
  double max_cell_size = 0.0; // mm, root cell edge; 0 = the sizing field's maximum
  double padding = 0.0;       // mm added around the volume's box on every side (>= 0)
};

struct OctreeBccStats {
  int levels = 0;                       // levels used (1 = roots only)
  std::vector<int64_t> leavesPerLevel;  // index = level (0 = roots)
  int64_t balanceSplits = 0;            // leaves split to keep neighbours within one level
  int64_t transitionTets = 0;           // tets between leaves of different sizes
  int64_t bisectedTets = 0;             // tets on a split edge (two per split edge and piece)
  double rootCellSize = 0.0;            // mm, longest edge of a root cell
  double finestCellSize = 0.0;          // mm, longest edge of the smallest leaf
};

struct OctreeBccResult {
  BackgroundMesh background;
  OctreeBccStats stats;
};

// `sizing`: a scalar volume of element sizes in mm (e.g. ComputeSizingField's output), any grid;
// every value must be finite and > 0. Throws InputError naming the culprit (parameters, a bad
// sizing value, a tree that would need more than 12 levels or 2^31 vertices).
OctreeBccResult generateOctreeBcc(const GridGeometry& grid, const ScalarVolume& sizing,
                                  const OctreeBccParams& params, Progress& progress);

void reportOctreeBcc(const OctreeBccStats& stats, Report& report);

} // namespace tetflow
