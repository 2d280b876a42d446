#pragma once
// Graded BCC background mesh on a balanced octree driven by a sizing field (seed §4.8.1 grading,
// §5.6 "adaptive octree background meshes").
//
// Cells. The box (the volume's voxel cells plus `padding`) is split into root cells of at most
// max_cell_size per axis (n_a = ceil(L_a / max_cell_size), so cells tile the box exactly and are
// slightly rectangular when L_a is not a multiple). A cell is split into 8 while the smallest
// sizing-field value over it (the samples inside it, or the nearest sample when none is) is below
// its longest edge and that edge is longer than min_cell_size, so leaves are no larger than the
// field over them down to min_cell_size, and no smaller than min_cell_size / 2. The tree is then
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
// Indices: vertices 0-based: leaf corners and centres in order of first use over the leaves
// sorted by (level, z, y, x), then the face centres on the box; all tets positively oriented;
// total volume = box volume.
#include <array>
#include <cstdint>
#include <unordered_set>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/Volume.h"
#include "Algorithms/Cleaving/Materials.h"
#include "BccLattice.h"

namespace tetflow {

struct OctreeBccParams {
  double min_cell_size = 0.0; // mm, leaves stop splitting at this edge; 0 = the sizing field's minimum
  double max_cell_size = 0.0; // mm, root cell edge; 0 = the sizing field's maximum
  double padding = 0.0;       // mm added around the volume's box on every side (>= 0)
  // With an EdgeTopology (ThinLayers.h): leaves holding an edge that misses a material are split
  // until their longest edge is at most this (mm); 0 = sqrt(2) x the largest voxel spacing (the
  // leaves there are then within a factor sqrt(2) of the voxel size).
  double thin_layer_cell_size = 0.0;
  // The thin-layer rounds after the first mesh and test only the tets of the leaves whose
  // surroundings changed, and the whole tree is meshed once at the end (the same mesh). false:
  // mesh and test the whole tree every round (for tests that check that).
  bool partial_thin_rounds = true;
  // Root cells of a power of two times the voxel with thin layers (below); false: as asked (for
  // tests of cleaving at a given ratio of cells to voxels).
  bool snap_roots = true;
};

struct OctreeBccStats {
  int levels = 0;                       // levels used (1 = roots only)
  std::vector<int64_t> leavesPerLevel;  // index = level (0 = roots)
  int64_t balanceSplits = 0;            // leaves split to keep neighbours within one level
  int64_t interfaceSplits = 0;          // leaves split so no graded tet crosses an interface
  int interfaceRounds = 0;              // mesh / split rounds for that
  int64_t gradedInterfaceTets = 0;      // graded tets still cut by an interface (0 = none)
  int64_t transitionTets = 0;           // tets between leaves of different sizes
  int64_t bisectedTets = 0;             // tets on a split edge (two per split edge and piece)
  double rootCellSize = 0.0;            // mm, longest edge of a root cell
  double finestCellSize = 0.0;          // mm, longest edge of the smallest leaf
  // Thin layers (with an EdgeTopology): leaves split because an edge of theirs missed a material
  // (before meshing, on the leaf's own BCC edges, and in rounds on the meshed tets), and the tets
  // whose edges still miss one at the thin-layer cell size (left to the label repair).
  int64_t thinLayerSplits = 0;
  int thinLayerRounds = 0;
  int64_t thinLayerTetsLeft = 0;
  double thinLayerCellSize = 0.0;       // mm, longest edge of a leaf at the thin-layer level (0: off)
};

struct OctreeBccResult {
  BackgroundMesh background;
  OctreeBccStats stats;
  std::vector<uint8_t> graded; // per tet: 1 for a transition or bisected tet
};

// The balanced octree alone, in the grid's own frame (local coordinates: lo = the box's low
// corner; physical = grid.origin + grid.direction * local). Leaf i has level leafLevel(i) and
// index leafIndex(i) at that level: it spans lo + index * rootSize / 2^level over one cell of
// rootSize / 2^level. Leaves are sorted by (level, z, y, x) and tile the box.
struct SizingOctree {
  int finestLevel = 0;                   // deepest level allowed by min_cell_size (and thin layers)
  int thinLevel = 0;                     // thin layers: leaves above this level may be split
  std::array<int64_t, 3> roots{0, 0, 0}; // root cells per axis
  Vec3 lo{0, 0, 0}, boxLength{0, 0, 0}, rootSize{0, 0, 0}; // mm
  std::vector<uint64_t> leaves;          // packed keys, sorted
  std::unordered_set<uint64_t> leafSet;
  size_t size() const { return leaves.size(); }
  int leafLevel(size_t i) const;
  std::array<int64_t, 3> leafIndex(size_t i) const;
  // Level of the leaf holding the finest cell f (finest-cell coordinates), -1 outside the box;
  // `near` (when >= 0): the levels near, near - 1 and near + 1 are tried first.
  int levelAt(const std::array<int64_t, 3>& f, int near = -1) const;
  // Local point of half-finest-cell coordinates.
  Vec3 halfToLocal(int64_t x, int64_t y, int64_t z) const;
  // Editing (leafSet only; finish() rebuilds `leaves` and the level statistics): split one leaf
  // into its 8 children (appended to *touched when given); restore the 2:1 balance around the
  // leaves in `queue` and everything split meanwhile, returning the number of splits.
  void split(uint64_t key, std::vector<uint64_t>* touched);
  // `created` (when given) receives the leaves the balance made.
  int64_t balance(std::vector<uint64_t> queue, const Progress* progress = nullptr,
                  std::vector<uint64_t>* created = nullptr);
  void finish(OctreeBccStats& stats, const Progress* progress = nullptr);
};
class EdgeTopology;
// Refines and balances as described above (and for thin layers, with `thin`); fills stats except
// the tet counts.
SizingOctree buildSizingOctree(const GridGeometry& grid, const ScalarVolume& sizing, const OctreeBccParams& params,
                               OctreeBccStats& stats, Progress& progress, const EdgeTopology* thin = nullptr);

// `sizing`: a scalar volume of element sizes in mm (e.g. ComputeSizingField's output), any grid;
// every value must be finite and > 0. Throws InputError naming the culprit (parameters, a bad
// sizing value, a tree that would need more than 12 levels, more than 2^20 finest cells along an
// axis, or more than 2^31 - 1 tets - checked level by level before the leaves are allocated).
// With `materials`, graded tets are kept off the material interfaces: while a transition or
// bisected tet has vertices of different dominant materials (argmax of the indicator functions,
// ties to the lower index - the labels cleaving gives them), its coarser leaf is split (both
// when equal) and the tree rebalanced, then meshed again (seed §4.8.1: graded tets only in
// homogeneous regions). Such a leaf is always above the finest level, so every round splits;
// after at most 100 rounds the graded tets still cut are counted in stats.gradedInterfaceTets
// (0 when the rule holds everywhere).
// With `thin` (ThinLayers.h), leaves are split where an edge misses a material, down to
// params.thin_layer_cell_size: first on each leaf's own BCC edges (as if its neighbours were of its
// size) while refining, then in rounds on the tets of the balanced mesh (the leaves on either side
// of a tet whose edge misses one, the coarser, or both when equal) until none is left above that
// size (at most 2 rounds).
OctreeBccResult generateOctreeBcc(const GridGeometry& grid, const ScalarVolume& sizing,
                                  const OctreeBccParams& params, Progress& progress,
                                  const MaterialSet* materials = nullptr, const EdgeTopology* thin = nullptr);

// A regular BCC lattice (BccLattice.h: the same cells) whose cells are split, as an octree, where
// an edge misses a material (above), down to params.thin_layer_cell_size. Without such an edge it
// is generateRegularBcc's lattice itself. min/max_cell_size are not used.
// Root cells with thin layers (both functions; not when thin.nothingMisses()): a power of two
// times the voxel size (the largest spacing), the one nearest to cell_size (max_cell_size for the
// octree) on a log scale, then rounded per axis to tile the box (n_a = round(L_a / that), and
// for the octree n_a = ceil(L_a / that): no level above its power of two, as min_cell_size asks); so
// every refinement level lies on the same sizes whatever size was asked for, and a coarser cell
// never refines the layers further (cell_size 5 and 6 mm on 1 mm voxels give 4 and 8 mm cells).
OctreeBccResult generateThinLayerBcc(const GridGeometry& grid, const BccParams& bcc, const OctreeBccParams& params,
                                     const EdgeTopology& thin, Progress& progress, const MaterialSet* materials = nullptr);

void reportOctreeBcc(const OctreeBccStats& stats, Report& report);
// thin_layer_* keys (nothing when thin layers were not refined).
void reportThinLayers(const OctreeBccStats& stats, Report& report);

} // namespace tetflow
