#pragma once
// Regular body-centred cubic (BCC) background lattice (seed §4.4) covering exactly the physical
// box of a volume (its voxel cells, plus optional padding), not a bounding cube.
//
// The box is divided into n_a = max(1, round(L_a / cell_size)) cells per axis, so cells are
// cell_size within rounding (slightly rectangular when L_a is not a multiple). Vertices:
//   primal      cell corners                       kind 0
//   dual        cell centres                       kind 1
//   face centre centres of cell faces on the box   kind 2
// Tets: four per interior cell face (dual, dual, and the two ends of one face edge) - the BCC
// tets, edges primal-dual ("short", sqrt(3)/2 h) and primal-primal / dual-dual ("long", h) - and
// four per boundary cell face (dual, face centre, face edge): BCC tets bisected by the box, so
// the lattice ends exactly on the box. All tets positively oriented; total volume = box volume.
// For a rotated or flipped grid the lattice is built in the grid's own frame and mapped to
// physical space with the grid's axes.
#include <cstdint>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/Core/Volume.h"

namespace tetflow {

enum class LatticeVertexKind : uint8_t { Primal = 0, Dual = 1, FaceCentre = 2 };

struct BccParams {
  double cell_size = 4.0; // mm, edge of a lattice cell (> 0)
  double padding = 0.0;   // mm added around the volume's box on every side (>= 0)
  // > 0: the cells are the power of two times this voxel size nearest to cell_size on a log
  // scale (bccSnappedCell), as the thin-layer refinement needs them (OctreeBcc.h); messages
  // name both sizes, and advice gives a cell_size that snaps far enough.
  double snap_voxel = 0.0;
};

// cell_size as the lattice builds it: snapped when params.snap_voxel > 0.
double bccSnappedCell(const BccParams& params);

// Peak bytes per background tet while a regular BCC lattice is built (docs/reliability.md).
inline constexpr double kBccBytesPerTet = 40.0;

struct BackgroundMesh {
  TetMesh mesh;
  // When set, the background's points and tets are *view's (a mesh owned elsewhere, e.g. a
  // module's input) and `mesh` is unused: cleaving reads them and copies only what it changes.
  const TetMesh* view = nullptr;
  const TetMesh& tets() const { return view ? *view : mesh; }
  // Per vertex for BCC lattices (empty for unstructured backgrounds): decides which of
  // alpha_short / alpha_long applies to an edge.
  std::vector<LatticeVertexKind> kind;
  std::array<int64_t, 3> cells{0, 0, 0};
  Vec3 cellSize{0, 0, 0}; // mm per axis
  double boxVolume = 0.0; // mm^3
};

// The sizing field given to a graded background (octree_bcc, particles): checks its grid and that
// every value is a finite positive size (InputError naming the first sample that is not, and the
// fix), and returns its smallest and largest value (mm).
struct SizeRange {
  float min = 0.0f, max = 0.0f;
};
SizeRange checkSizingField(const ScalarVolume& sizing);

// Throws InputError naming the parameter when cell_size/padding are invalid or the lattice
// would exceed 2^31 vertices.
BackgroundMesh generateRegularBcc(const GridGeometry& grid, const BccParams& params, Progress& progress);

} // namespace tetflow
