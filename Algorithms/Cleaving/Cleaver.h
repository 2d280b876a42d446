#pragma once
// Lattice cleaving (seed chapter 4; §5.5 for unstructured backgrounds): turns a background
// tetrahedral mesh and a set of materials into a conforming multimaterial mesh.
//
// Stages (named, timed, reported through Progress):
//   sample      label every background vertex by its maximal indicator function (ties go to the
//               lower material index) and keep the values of the materials present there
//   interfaces  cuts on edges with two labels, triples on faces with three, quadruples in tets
//               with four (linear interpolation of the sampled values; points computed outside
//               their simplex are projected back into it, §4.4)
//   snap/warp   three phases (§4.7, §4.9): violated vertices are warped to the centre of mass of
//               the violating interface points (vertices on the domain box stay on it, and a warp
//               is cut back when it would leave a background tet below 10 % of its volume, which
//               only happens for alphas beyond the defaults), the points snap to the vertex, and
//               the remaining points
//               on incident simplices are recomputed (oracle re-query at the warped position);
//               then triples/quadruples violating edges snap to the edge's cut; then
//               quadruples violating faces snap to the face's triple
//   generalize  virtual cuts, triples and quadruples complete every interface tet to the
//               six-cut case (§4.8) with the vertex-order rule of §5.5.1 (a virtual cut goes to
//               the lower vertex id), so shared faces are stencilled identically by both tets;
//               then degeneracies are removed by further snaps (§4.7, Fig. 4.7) until every
//               stencil tet is either collapsed or non-degenerate
//   stencil     the generalized stencil: 24 tets (vertex, cut, triple, quadruple) per interface
//               tet, dropping collapsed ones; tets with one material are output unchanged
//   optimize    (optimize_angles) around tets whose score min(smallest dihedral angle,
//               180 - largest) is below 12 degrees, vertices not on the box are moved by a
//               pattern search that maximises the worst score of their tets, never inverting a
//               tet and never changing the volume their tets fill: vertices inside one material
//               move freely; vertices between two materials slide in the interface's tangent
//               plane (normal = gradient of f_a - f_b from the materials); vertices on a curve
//               where three materials meet slide along it (both by at most 10 % of their
//               longest edge); points where four or more materials meet stay. The worst
//               candidates go first, at most 2 % of the vertices (+2000) per pass, two passes,
//               in parallel on vertices that share no tet.
//
// Violation (§4.6): an interface point with barycentric coordinates lambda in its simplex
// violates a sub-simplex s when, for every vertex x outside s and y in s,
//   lambda_x (1 - alpha) < alpha lambda_y,
// alpha being the violation parameter of edge (x, y) measured from y. BCC lattices use
// alpha_short / alpha_long as fractions of the edge length (edges touching the box's face
// centres use alpha_long); unstructured backgrounds use alpha = (1/2 - xi) * h per vertex, h the
// shortest altitude of the incident tets (§5.5.2). alpha_short = alpha_long = 0 gives plain
// stencilling (only interface points exactly on a lower simplex are snapped).
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/TetMesh.h"
#include "Materials.h"

namespace tetflow {

struct CleaveParams {
  double alpha_short = 0.357; // BCC short edges (primal-dual), fraction of edge length, [0, 0.5)
  double alpha_long = 0.203;  // BCC long edges (primal-primal, dual-dual), fraction, [0, 0.5)
  double xi = 0.2;            // unstructured backgrounds: alpha = (1/2 - xi) h, xi in (0, 1/2]
  std::optional<int32_t> strip_exterior; // material label removed after meshing (e.g. 0)
  // Raise the smallest dihedral angles after stencilling by moving vertices along their
  // interfaces (see "optimize" above); the box does not move.
  bool optimize_angles = true;
  // Where an interface point goes on an edge: Exact = where the materials' functions cross, found
  // on the functions themselves (Illinois regula falsi to interface_tolerance, from the linear
  // guess), with triples and quadruples solved on linear models made to vanish at those cuts;
  // Linear = where the linear interpolation of the two end samples crosses (the seed, Cleaver).
  // Auto = Exact on BCC lattices, Linear on unstructured backgrounds: a one-voxel layer keeps its
  // thickness on lattices fine enough to see it, while on particle backgrounds (coarser than the
  // layers they cross, per-vertex alphas) exact points left twice the tets below 10 degrees for the
  // improvement (46 k against 9.5 k on the head, docs/meshing.md).
  enum class InterfacePoints : uint8_t { Auto = 0, Exact = 1, Linear = 2 };
  InterfacePoints interface_points = InterfacePoints::Auto;
  double interface_tolerance = 0.01; // mm
  // Leave out the background tets deep in the exterior of this label (CleavePipeline sets it when
  // it strips the label afterwards): a tet goes when each of its vertices carries the label, so
  // does every vertex within two edges of it (no interface point, warp or stencilled tet of
  // another label comes near), and cull_exterior_at (when set) says it lies in the label's
  // exterior. Such a tet would be output unchanged and stripped; the tets kept around the hole
  // it leaves carry the label, and CleaveResult::exteriorJoins says which of them are connected
  // through it.
  std::optional<int32_t> cull_exterior;
  std::function<bool(const Vec3&)> cull_exterior_at;
};

struct CleaveStats {
  int64_t backgroundTets = 0, interfaceTets = 0;
  int64_t cuts = 0, triples = 0, quadruples = 0;      // real interface points
  int64_t warpedVertices = 0, snaps = 0;               // phase 1-3 snaps
  int64_t degeneracySnaps = 0;                         // extra snaps of the closure
  int64_t steinerPoints = 0;                           // quadruples placed at a tet centroid
  int64_t limitedWarps = 0;
  int64_t optimizedVertices = 0; // moved by the angle optimization  // warps cut back so no background tet loses 90 % of its volume
  int64_t strippedTets = 0;
  int64_t culledTets = 0;     // background tets left out (cull_exterior)
  double culledVolume = 0.0;  // mm^3
};

struct MaterialOutcome {
  int32_t label = 0;
  double inputVolume = 0.0; // mm^3, voxels of the input
  double meshVolume = 0.0;  // mm^3 in the output (before strip_exterior)
  int64_t tets = 0;
  bool stripped = false;
  bool lost() const { return tets == 0 && inputVolume > 0.0; }
};

struct CleaveResult {
  TetMesh mesh;
  CleaveStats stats;
  std::vector<MaterialOutcome> materials; // one per input material, in label order
  // With cull_exterior: pairs of output tets (of the culled label) that touch one connected part
  // of the culled region, chained, so that joining each pair joins every piece around that part.
  std::vector<std::pair<int32_t, int32_t>> exteriorJoins;
};

// Tets and volume [mm^3] of each material of `mesh`, by position in `labels`; tets whose label is
// not listed are not counted. (CleaveMesh refreshes its per-material figures with it after the
// label repair; volume calibration measures its errors with it.)
struct MaterialTally {
  int64_t tets = 0;
  double volume = 0.0;
};
std::vector<MaterialTally> tallyMaterials(const TetMesh& mesh, const std::vector<int32_t>& labels);

// Throws InputError for bad parameters (naming them) or an empty background.
CleaveResult cleave(const BackgroundMesh& background, const MaterialSet& materials,
                    const CleaveParams& params, Progress& progress);

// Figures for the module Report (counts, lost materials, stage times are added by the caller).
void writeCleaveReport(const CleaveResult& r, Report& report);

} // namespace tetflow
