#pragma once
// Making the BEM surfaces of a voxel-born mesh usable: manifold, and nested without touching.
//
// A mesh that keeps a segmentation's topology keeps its pinches too: where a one-voxel layer meets
// itself at an edge or a corner, the boundary of a union of materials touches itself there (a
// non-manifold vertex or edge), and where a layer is pinched to nothing the surfaces inside and
// outside it share vertices. A BEM solver takes neither.
//
// repairUnion changes the union (a set of tets), never the mesh, round by round until its boundary
// is a manifold that does not touch the enclosing surface:
//  - at each vertex where the boundary is not manifold, the tets around the vertex all join the
//    union (fill) or all leave it (carve), whichever moves less volume; fill only where the vertex
//    is inside the mesh and, for an inner surface, the filled tets lie inside the enclosing union
//    without reaching its surface; after the first rounds only carving, so the rounds end;
//  - at each vertex the inner boundary shares with the enclosing surface, the union's tets around
//    it leave (the inner surface moves one ring of tets inward there).
// Each changed vertex's star is a few tets, so the enclosed volume moves by the volume of the
// tets counted in the result, which callers report against the materials' volume.
#include <cstdint>
#include <vector>

#include "Algorithms/Quality/LabelTopology.h"
#include "Algorithms/Surfaces/BemSurfaces.h"

namespace tetflow {

struct UnionRepair {
  int rounds = 0;                 // rounds that changed something
  int64_t pinchesMended = 0;      // non-manifold vertices met, all rounds
  int64_t touchesMended = 0;      // vertices shared with the enclosing surface met, all rounds
  int64_t tetsAdded = 0, tetsRemoved = 0; // against the union the call began with
  double volumeAdded = 0.0, volumeRemoved = 0.0; // [mm^3]
  int64_t defectsLeft = 0;        // non-manifold vertices when the rounds ran out
  int64_t touchesLeft = 0;        // vertices still on the enclosing surface
  TriSurface surface;             // the boundary of the repaired union
};

// inside: the union (per tet, non-zero = in), changed in place. enclosing / enclosingSurface: the
// (already repaired) union this one must stay strictly inside, or null; the union is first cut to
// it. maxRounds bounds the work; a result with defectsLeft or touchesLeft > 0 did not converge.
UnionRepair repairUnion(const TetMesh& mesh, const std::vector<int32_t>& faceNeighbours, const VertexStars& stars,
                        std::vector<uint8_t>& inside, const std::vector<uint8_t>* enclosing,
                        const TriSurface* enclosingSurface, int maxRounds = 100);

} // namespace tetflow
