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

SurfaceCheck checkSurface(const TriSurface& s);

int64_t sharedVertices(const TriSurface& a, const TriSurface& b);

} // namespace tetflow
