#pragma once
// Closed triangle surfaces out of a labelled tet mesh, for BEM solvers (OpenMEEG, MNE) and
// viewers: the boundary of the union of chosen materials (the outer skin: every material; the
// outer skull: skull and all inside it; the inner skull: what is inside the skull), and the
// checks a BEM solver needs of them.
//
// unionBoundary: every tet face with a tet of the union on one side and, on the other, a tet of
// another material or nothing; oriented with its normal pointing out of the union (away from the
// tet's fourth vertex); vertices numbered compactly in order of first use. Its enclosed volume is
// the union's tet volume up to rounding (divergence theorem), which checkSurface measures.
//
// checkSurface: closed (every edge in two triangles), manifold (no edge in more than two, and
// the triangles around each vertex form one fan), consistently oriented (each edge used once in
// each direction), components (edge-connected), area and enclosed volume (signed: positive
// for outward normals).
//
// sharedVertices: how many vertices two surfaces of one mesh have in common (nested BEM surfaces
// must not touch; where a layer is missing in the segmentation they do).
#include <array>
#include <cstdint>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/TetMesh.h"

namespace tetflow {

struct TriSurface {
  std::vector<Vec3> points;
  std::vector<std::array<int32_t, 3>> triangles;
  std::vector<int32_t> meshVertex; // the mesh vertex of each point
};

TriSurface unionBoundary(const TetMesh& mesh, const std::vector<int32_t>& materials, const std::vector<int32_t>& faceNeighbours);
// The same for any set of tets: inside[t] != 0 for the tets of the union.
TriSurface maskBoundary(const TetMesh& mesh, const std::vector<uint8_t>& inside, const std::vector<int32_t>& faceNeighbours);
// inside[t] = 1 where the tet's material is one of `materials`.
std::vector<uint8_t> materialMask(const TetMesh& mesh, const std::vector<int32_t>& materials);

struct SurfaceCheck {
  int64_t triangles = 0, vertices = 0;
  int64_t openEdges = 0;          // in one triangle
  int64_t nonManifoldEdges = 0;   // in more than two
  int64_t misorientedEdges = 0;   // in two triangles, used in the same direction by both
  int64_t nonManifoldVertices = 0; // the triangles around the vertex form more than one fan
  int components = 0;
  double area = 0.0;              // [mm^2]
  double enclosedVolume = 0.0;    // [mm^3]
  bool closedManifoldOriented() const {
    return openEdges == 0 && nonManifoldEdges == 0 && misorientedEdges == 0 && nonManifoldVertices == 0;
  }
};

// defective (if given) receives, ascending, the points that make the surface non-manifold: those
// whose triangles form more than one fan and the ends of edges in more than two triangles.
SurfaceCheck checkSurface(const TriSurface& s, std::vector<int32_t>* defective = nullptr);

int64_t sharedVertices(const TriSurface& a, const TriSurface& b);

// Geometric crossings (SurfaceMeshing/SurfaceIntersections.h: touching counts; triangles sharing
// a vertex or an edge only where they fold over it), counted up to `atMost` pairs: within one
// surface, and between two (the pairs of the two taken together that have one triangle in each;
// self-crossings of either, if any, are counted first toward atMost). Two surfaces cut from one
// conforming mesh never cross; smoothed or decimated ones could.
int64_t selfIntersections(const TriSurface& s, size_t atMost = 1000);
int64_t crossingPairs(const TriSurface& a, const TriSurface& b, size_t atMost = 1000);

} // namespace tetflow
