#pragma once
// The particles that sample a CAD model (seed chapter 3, PSYS), shared by the particle system
// (CadParticles.h) that places them and the parameter-space triangulation (CadTriangulation.h)
// that connects them.
#include <array>
#include <cstdint>
#include <vector>

#include "Algorithms/CAD/CadModel.h"

namespace tetflow {

struct CadParticle {
  int dim = 0;      // 0: on a corner, 1: on a curve, 2: on a patch
  int cell = 0;     // the corner, curve or patch id
  double t = 0;     // curve parameter (dim 1)
  Point2 uv{};      // patch parameters (dim 2)
  Vec3 x{};         // position, mm
  double sigma = 0; // radius of its ball of influence (the inferred sizing field), mm
};

struct CadSample {
  // Corner particles first (particle c is corner c), then the others in any order.
  std::vector<CadParticle> particles;
  // Per curve: its particles (not its corners) sorted by t from t0 to t1.
  std::vector<std::vector<int>> onCurve;
  // Per patch: its interior particles.
  std::vector<std::vector<int>> onPatch;
};

// A closed triangle surface of a CAD model: vertices are the sample's particles (same indices;
// a particle no triangle uses is left in place), triangles oriented with the outward normal of
// the patch's first solid.
struct CadSurfaceMesh {
  std::vector<Vec3> points;
  std::vector<std::array<int32_t, 3>> triangles;
  std::vector<int32_t> trianglePatch; // patch of each triangle
};

} // namespace tetflow
