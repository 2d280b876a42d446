#pragma once
// Label repair after cleaving: the cleaved mesh keeps its geometry (points and tets untouched, so
// validity and every dihedral angle stay exactly as they are); only tet labels change, where the
// mesh contradicts the input's topology as the certificate (Algorithms/Quality/Certificate.h)
// would see it. The input is MaterialSet::dominantLabels(): the label volume, or the argmax of the
// indicator functions.
//
// 1. Contacts. Two labels may share a face only when some face-adjacent voxel pair of the input
//    carries them. A tet with a face between labels that never touch is relabelled to the label
//    whose indicator function is largest at the tet's centroid among those allowed next to every
//    neighbour's label. Tets are taken most-wrong first (the margin of their own value over the
//    best allowed one, smallest first). Each relabelling removes every forbidden face of its tet
//    and creates none, so the process ends; a tet with no allowed label is left (counted).
// 1b. Point contacts (`points`). Where two labels that never touch meet at a
//    vertex or an edge (their tets share it but no face), the thin layer between them is pinched
//    to nothing there: a non-manifold vertex of that layer, and a node that couples the two
//    materials directly in a P1 FEM. The smaller side's tets around the vertex take the label
//    (largest indicator at their centroid) that may touch every other label around the vertex and
//    every face neighbour. Up to 4 passes. On a lattice coarser than the layer this makes the
//    layer a whole tet thick wherever it was pinched: the head's CSF on the 4 mm default goes from
//    -11 % to +33 % in volume, non-manifold vertices from 8 155 to 48.
// 2. Connections. A piece that is not primary but votes for an image component is joined to
//    another piece voting for the same component when one or two tets of other labels lie between
//    them (through faces) and its label is allowed next to all their neighbours: those tets take
//    its label. Rounds repeat until nothing joins (at most 8). A thin layer that cleaving broke
//    into patches (or that step 1 patched) becomes one piece again. Then the pieces left that
//    step 4 would keep (at least its size limit, of a component with a core: each would be a
//    split in the certificate) may be joined by a chain of up to 6 tets of other labels, the one of
//    least volume, each allowed next to its neighbours and touching no other piece of the label
//    (in the round where short paths join nothing and the ones after it, 8 in all): a component the image joins only through voxel edges or corners has
//    no face-connected path of its own between its parts. After step 3 (whose closing of a
//    non-manifold edge can cut such a link again) the pieces step 4 would keep get the same chance
//    once more.
// 3. Edges. Around an edge where the tets of one label form two or more groups (joined through
//    the faces at the edge), the label touches itself along the edge: a non-manifold interface
//    edge. The smallest gap of other tets between two such groups whose tets may all take the
//    label (allowed next to all their other neighbours) takes it. Up to 4 rounds, each on the
//    edges of the tets the last one changed.
// 4. Fragments. The face-connected pieces of each label vote, tet by tet, for the image component
//    at their centroid (the certificate's rule). The max(1, cores) pieces with the most voting
//    volume are the primary pieces of their image component. A piece that is primary for no
//    component and smaller than fragment_voxels voxel volumes, or than 1 % of the component it
//    votes for most (of its label's voxels when it votes for none), or of any size when that
//    component has no core (the certificate allows losing it, not splitting it), is relabelled to the
//    neighbouring label it shares the most face area with, among those allowed next to all its
//    neighbours; when there is none (the labels around it may not touch each other), the label
//    the image favours over it (largest indicator function, by volume) among those allowed next
//    to all of them, with a least-volume chain of up to 6 tets to that label taking it too (no
//    island of it); kept when there is neither. So is a stray: a tet on the surface of a piece that
//    stays, voting for an image component that piece is not primary of and reaches into with
//    less than that component's size limit (once per tet). Rounds repeat until nothing changes
//    (at most 8). On
//    cells coarser than the voxels this removes the bits of a thin structure (a white-matter
//    finger in a gyrus) that cleaving cut off from it: the component stays in one piece, and the
//    volume correction gives the volume back.
// Deterministic: the same result for any thread count. Stages: "repair contacts",
// "repair connections", "repair edges", "repair fragments".
#include <cstdint>
#include <map>
#include <mutex>
#include <utility>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/TetMesh.h"
#include "Materials.h"

namespace tetflow {

struct LabelRepairParams {
  bool contacts = true;
  bool fragments = true;
  // Off here; CleaveMesh (CleavePipeline.h) turns it on: with the volume correction giving back
  // what it thickens, a pinched layer is worse (its vertices leave tets the improvement cannot
  // raise to 10 degrees).
  bool points = false;
  bool connect = true;
  bool edges = true;
  double fragment_voxels = 1.0; // pieces below this many voxel volumes of the input may go (>= 0)
};

struct LabelRepairStats {
  int64_t forbiddenFacesBefore = 0, forbiddenFacesAfter = 0;
  double forbiddenAreaBefore = 0.0, forbiddenAreaAfter = 0.0; // mm^2
  int64_t contactTets = 0;        // tets relabelled for contacts
  int64_t unresolvedTets = 0;     // tets with a forbidden face and no allowed label
  int64_t fragments = 0;          // pieces relabelled
  int64_t fragmentTets = 0;
  int64_t strayTets = 0;          // tets of a piece that stays, reaching into another component
  int64_t keptSmallPieces = 0;    // non-primary pieces below the size left (no allowed label)
  int64_t pointContacts = 0;      // vertices where forbidden labels met, resolved
  int64_t pointTets = 0;
  int64_t connections = 0;        // pieces joined to another piece of their image component
  int64_t connectTets = 0;
  int64_t chainConnections = 0;   // of them, joined through a chain of 3 to 6 tets
  int64_t fragmentChains = 0;     // fragments no neighbour could take, given to a label through a chain
  int64_t fragmentChainTets = 0;  // the chains' tets
  int64_t closedEdges = 0;        // non-manifold interface edges closed
  int64_t edgeTets = 0;
  double relabelledVolume = 0.0;  // mm^3, all steps together
  int fragmentRounds = 0, connectRounds = 0;
  bool skipped = false; // labelRepairNeeded found nothing to repair (nothing else was run)
  bool local = false;   // only around the check's vertices (repairLabelsAround)
  int localRounds = 0;  // further rounds of it kept (CleavePipeline: bad vertices it left)
};

// Whether any repair step could change a label (a cheap, sufficient test: when it says no, none
// would): no two labels that never touch in the image (`contacts`, labelContactPairs) share a
// vertex; no label touches itself along an edge (two groups of its tets at a vertex, joined through
// faces, that share an edge); and every label's tets form one piece (joined through faces, found
// through the groups at each vertex): a piece that could be joined or dissolved needs a second one.
// Two passes over the tets plus the stars of the vertices where labels meet: no face adjacency, no
// image components (LabelRepairCheck.cpp). LabelRepairStats::skipped is set when repairLabels finds so.
bool labelRepairNeeded(const TetMesh& mesh, const std::vector<std::pair<int32_t, int32_t>>& contacts,
                       Progress& progress);
// The same test, saying where: the vertices where labels that never touch meet or a label is
// pinched (the contacts, point contacts and edges steps work there), and whether some label is in
// more than one piece (then connections and fragments, which need the image's components, run).
struct LabelRepairCheck {
  std::vector<int32_t> badVertices;
  bool extraPieces = false;      // a label in more than one piece (joined through vertices)
  bool largeExtraPieces = false; // one of them (not the label's largest) has more than 16 tets
  std::vector<std::vector<int32_t>> smallPieces; // the tets of the others
  bool needed() const { return extraPieces || !badVertices.empty(); }
};
// `joins` (pairs of tets, LabelTopology.h: TetJoins), when given, connect pieces of one label
// through a part of the mesh that was left out (CleavePipeline's culled exterior).
LabelRepairCheck checkLabelRepair(const TetMesh& mesh, const std::vector<std::pair<int32_t, int32_t>>& contacts,
                                  Progress& progress, const std::vector<std::pair<int32_t, int32_t>>* joins = nullptr);
// Which labels touch in an image (labelContactPairs), asked pair by pair: a pair is looked for
// first in the voxels around the place it is asked about (a mixed vertex of the mesh, on the
// interface between the two labels, where they touch when they touch at all), and the whole
// image is scanned, once, only for a pair not found there. So a check that finds nothing costs no
// scan of the image. Thread-safe. `labels` must outlive it.
class LabelContactOracle {
public:
  explicit LabelContactOracle(const LabelVolume& labels) : labels_(labels) {}
  bool touch(int32_t a, int32_t b, const Vec3& near);
  const std::vector<std::pair<int32_t, int32_t>>& all(); // labelContactPairs(labels), computed once

private:
  const std::vector<std::pair<int32_t, int32_t>>& scan(); // all(), with mutex_ held
  const LabelVolume& labels_;
  std::mutex mutex_;
  std::map<std::pair<int32_t, int32_t>, bool> known_;
  std::vector<std::pair<int32_t, int32_t>> all_;
  bool scanned_ = false;
};
LabelRepairCheck checkLabelRepair(const TetMesh& mesh, LabelContactOracle& contacts, Progress& progress,
                                  const std::vector<std::pair<int32_t, int32_t>>* joins = nullptr);
// The repair when the check found no extra piece: the contacts, point contacts and edges steps on
// the tets around the check's vertices only (no image components, no face adjacency of the whole
// mesh). Nothing at all when the check found nothing.
// Relabels each piece (tets) to the neighbouring label it shares the most face area with, among
// those allowed next to all its neighbours (`contacts`); returns the pieces relabelled. For pieces
// the repair itself cut off (CleavePipeline: a label that was in one piece before the local steps).
struct VertexStars; // Algorithms/Quality/LabelTopology.h
// Both take the mesh's vertex stars when the caller has them (relabelling leaves them as they
// are, so rounds on one mesh share them); otherwise they build them.
int64_t dissolvePieces(TetMesh& mesh, const std::vector<std::vector<int32_t>>& pieces,
                       const std::vector<std::pair<int32_t, int32_t>>& contacts, LabelRepairStats& stats,
                       const VertexStars* stars = nullptr);
LabelRepairStats repairLabelsAround(TetMesh& mesh, const MaterialSet& materials, const LabelRepairParams& params,
                                    const LabelRepairCheck& check, const std::vector<std::pair<int32_t, int32_t>>& contacts,
                                    Progress& progress, const VertexStars* stars = nullptr);

// Throws InputError for a negative fragment_voxels or a mesh failing validateStructure. `image`, when
// given, is analyzeLabelImage(materials.dominantLabels()) computed before (it is the costly part of
// a repair that finds nothing to do).
struct LabelImageTopology;
// `joins` as for checkLabelRepair: the pieces the connections and fragments steps see.
// `faceNeighbours`, when given, receives the mesh's tetFaceNeighbours when the repair computed them
// (it relabels only, so they stay valid for the steps after it); when given filled, they are used.
LabelRepairStats repairLabels(TetMesh& mesh, const MaterialSet& materials, const LabelRepairParams& params,
                              Progress& progress, const LabelImageTopology* image = nullptr,
                              const std::vector<std::pair<int32_t, int32_t>>* joins = nullptr,
                              std::vector<int32_t>* faceNeighbours = nullptr);

// repair_* keys: forbidden faces and area before and after, tets and pieces relabelled, volume.
void writeLabelRepairReport(const LabelRepairStats& s, Report& report);

} // namespace tetflow
