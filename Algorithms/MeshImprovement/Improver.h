#pragma once
// Internal to Algorithms/MeshImprovement: the improver's state, shared by
//   MeshImprovement.cpp  the driver (scans, the worst-first passes, compaction, report);
//   LocalMoves.cpp       vertex constraints and smoothing;
//   LocalFlips.cpp       edge removal, 2-3 flips, edge collapse and edge-split insertion.
// Nothing outside Algorithms/MeshImprovement includes this file.
#include <array>
#include <climits>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "Algorithms/MeshImprovement/MeshImprovement.h"
#include "Algorithms/Quality/LabelTopology.h"
#include "Algorithms/Quality/TetQuality.h"

namespace tetflow::improve_detail {

using Tet = TetMesh::Tet;
inline constexpr int32_t kOutside = INT32_MIN; // the label of the outside of the domain
inline constexpr int kMaxRing = 7;             // largest ring an edge removal re-triangulates

// The worst improveScore of a set of tets, kept as the extremes of their dihedral cosines. A tet's
// score falls as its largest cosine (smallest angle) rises and as its smallest cosine (largest
// angle) falls, so the worst score of a set is the score of those two extremes: two acos per
// change of an extreme instead of two per tet, and the same value as the minimum over the tets.
class WorstScore {
public:
  WorstScore(double minAngle, double maxAngle) : minAngle_(minAngle), maxAngle_(maxAngle) {}
  // Adds a tet; true when the worst score may have changed (then value() is worth asking).
  bool add(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
    if (invalid_) return false;
    double lo, hi;
    if (!dihedralCosineRange(a, b, c, d, lo, hi)) return invalid_ = true;
    bool changed = false;
    if (hi > hi_) hi_ = hi, changed = true;
    if (lo < lo_) lo_ = lo, changed = true;
    return changed;
  }
  // 1e9 for no tets, -1 once a tet was flat or inverted.
  double value() const;

private:
  double minAngle_, maxAngle_;
  double hi_ = -2.0, lo_ = 2.0; // cosines lie in [-1, 1]
  bool invalid_ = false;
};

// Tets around one vertex with their materials (a working copy for trial moves).
struct LocalStar {
  std::vector<Tet> tets;
  std::vector<int32_t> mats;
};

// How a vertex may move: dof 3 freely, 2 in the plane with normal `dir`, 1 along `dir`, 0 not.
struct Constraint {
  int dof = 0;
  Vec3 dir{0, 0, 0};
  // Axes (bit a) whose coordinate must stay exactly as it is: the vertex is on an axis-aligned
  // planar piece of the boundary.
  uint8_t keepAxes = 0;
  // A free move (dof 3) of a vertex that is otherwise constrained (the last resort): it moves at
  // most as far as a constrained vertex does.
  bool constrainedReach = false;
};

// True when (a, b, c, d) is an even permutation of the stored tet q (so it has q's orientation).
bool samePermutationParity(const Tet& q, int32_t a, int32_t b, int32_t c, int32_t d);

class Improver {
public:
  Improver(TetMesh& m, const ImproveParams& p, Progress& progress);
  // nb: the mesh's face neighbours, carried through run() (improveMesh).
  ImproveStats run(std::vector<int32_t>* nb = nullptr);

  // ---- the operations (LocalMoves.cpp / LocalFlips.cpp); each returns whether it changed the
  // mesh and appends the tets it created or reshaped to `touched` ----
  bool smoothVertex(int32_t v, std::vector<int32_t>& touched);
  // Edge removal inside one material, or (acrossInterface) of an edge on an interface between two
  // materials, re-diagonalising the interface.
  bool removeEdge(int32_t a, int32_t b, bool acrossInterface, std::vector<int32_t>& touched);
  bool flip23(int32_t t, int face, std::vector<int32_t>& touched);
  bool collapseInto(int32_t t, std::vector<int32_t>& touched);
  bool splitEdge(int32_t t, std::vector<int32_t>& touched);
  // Removes a cap tet on a curved boundary (see MeshImprovement.h, "peel").
  bool peelCap(int32_t t, std::vector<int32_t>& touched);
  // Removes a tet on a curved boundary that the passes left outside the targets (the last resort
  // of "peel" in MeshImprovement.h); creates nothing.
  bool peelBoundaryTet(int32_t t);
  // Removes t when its volume fits its material's budget (counted as going to the outside).
  bool removeWithinBudget(int32_t t);
  // True when the triangle (x, y, z) lies in a plane normal to a coordinate axis (a box face).
  bool onAxisPlane(int32_t x, int32_t y, int32_t z) const;

private:
  TetMesh& m_;
  const ImproveParams& p_;
  Progress& progress_;
  double goal_ = 0.0;
  ImproveStats st_;
  bool lastResort_ = false; // the phase after the passes: constrained vertices may move freely

  std::vector<uint8_t> alive_;
  std::vector<int32_t> origin_;                     // tet -> input tet whose cell-field values it takes
  std::vector<std::array<int32_t, 2>> splitEnds_;   // vertex nv0 + i -> the edge it split
  size_t nv0_ = 0, nt0_ = 0;                        // input sizes
  VertexStars csr_;                                 // stars of the input
  std::unordered_map<int32_t, std::vector<int32_t>> changedStars_;

  std::vector<int32_t> labels_;    // ascending material labels
  std::vector<double> budget_;     // per label: allowed |net volume change| [mm^3]
  std::vector<double> change_;     // per label: net volume change so far [mm^3]

  // ---- stars ----
  void starOf(int32_t v, std::vector<int32_t>& out) const;
  std::vector<int32_t>& mutableStar(int32_t v);
  void killTet(int32_t t);
  int32_t addTet(const Tet& q, int32_t material, int32_t origin);
  int32_t oppositeTet(int32_t t, int face) const; // the tet across face `face` of t, or -1
  LocalStar localStar(const std::vector<int32_t>& ts) const;

  // ---- scores ----
  double score(const Tet& q) const;
  double scoreWith(const Tet& q, int32_t v, const Vec3& at) const;
  // Adds q, with v at `at`, to w.
  bool addWith(WorstScore& w, const Tet& q, int32_t v, const Vec3& at) const;
  double worstOf(const std::vector<int32_t>& ts) const;
  size_t labelIndex(int32_t label) const;

  // ---- smoothing (LocalMoves.cpp) ----
  Constraint classify(int32_t v, const LocalStar& s) const;
  // Best position for v among constrained pattern-search moves; returns the worst score of `s`
  // there (its current worst when it does not move) and the per-label volume change in *delta.
  double optimizePosition(int32_t v, const LocalStar& s, Vec3& best, std::vector<double>& delta) const;
  void commitVolumeChange(const std::vector<double>& delta);
  double triangulateRing(const std::vector<int32_t>& poly, int32_t a, int32_t b,
                         std::vector<std::array<int32_t, 3>>* tris) const;

  // ---- driver (MeshImprovement.cpp) ----
  bool improveTet(int32_t t, std::vector<int32_t>& touched);
  void scanAll(double& mn, double& mx, int64_t& below, int64_t& above, std::vector<int32_t>* bad) const;
  std::vector<double> labelVolumes() const;
  // Dead tets and unreferenced vertices out; nb (when given) follows the tets.
  void compact(std::vector<int32_t>* nb);
  // nb of the tets before compact() (newIndex: old tet -> its index after, -1 when dead) for the
  // compacted mesh.
  void carryFaceNeighbours(std::vector<int32_t>& nb, const std::vector<int32_t>& newIndex) const;
};

} // namespace tetflow::improve_detail
