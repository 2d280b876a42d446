#pragma once
// A CAD model to a tetrahedral mesh (seed chapter 3): PSYS particles (CadParticles.h), their
// parameter-space triangulation stitched along shared curves (CadTriangulation.h), checks that the
// surface is closed, manifold and of the model's Euler characteristic, then TetGen inside it
// (TetgenSurface.h), one material per solid (label = solid index + 1).
#include <string>

#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/MeshImprovement/MeshImprovement.h"
#include "Algorithms/SurfaceMeshing/CadParticles.h"
#include "Algorithms/SurfaceMeshing/CadSample.h"
#include "Algorithms/SurfaceMeshing/CadTriangulation.h"
#include "Algorithms/SurfaceMeshing/TetgenSurface.h"

namespace tetflow {

struct CadMeshParams {
  PsysParams particles;
  std::string tetgenQuality = "1.414/10"; // TetGen's -q value; "" for none
  double maxTetVolume = 0;                // TetGen's -a value (mm³); 0 for none
  // Mesh improvement of TetGen's tets toward [min_angle, max_angle] with every surface and
  // interface face kept (ImproveParams::fixSurfaces), so the boundary stays on the CAD patches.
  bool improve = true;
  ImproveParams improveParams = [] {
    ImproveParams p;
    p.fixSurfaces = true;
    return p;
  }();
};

// Smoothing of the triangulated sample: every patch vertex (a particle inside a patch) of a
// triangle with an angle below `belowDeg` moves, in its patch's parameters, toward the centroid of
// its ring when that raises the smallest angle of its triangles (and they keep facing along the
// patch's normal); vertices on curves and corners stay. Up to `passes` passes; returns the moves.
// The particles leave pockets (seed §3.5.2.1, Fig. 3.17) where a few triangles fall below 30°.
int64_t smoothCadSurface(const CadModel& model, const CadSample& sample, CadSurfaceMesh& surface,
                         double belowDeg = 35.0, int passes = 5);

// Figures of a triangle surface.
struct SurfaceFigures {
  int64_t vertices = 0, edges = 0, triangles = 0;
  int64_t boundaryEdges = 0, nonManifoldEdges = 0, inconsistentEdges = 0;
  int euler = 0;
  double minAngle = 0, medianMinAngle = 0;       // triangle angles, degrees
  double maxRadiusEdge = 0, medianRadiusEdge = 0; // circumradius / shortest edge
};
SurfaceFigures surfaceFigures(const std::vector<Vec3>& points, const std::vector<std::array<int32_t, 3>>& triangles);

struct CadMeshResult {
  CadSurfaceMesh surface;       // points: the particles the triangles use, corners first (point c = corner c)
  std::vector<std::vector<int32_t>> curvePoints; // per curve: its surface points from t0 to t1, corners excluded
  std::vector<double> curvePointParameters;      // per surface point on a curve: its t (else NaN)
  TetMesh mesh;
  PsysStats particles;
  CadTriangulationStats triangulation;
  int64_t smoothed = 0; // smoothCadSurface's moves
  SurfaceFigures figures;
  TetgenSurfaceStats tetgen;
  ImproveStats improve; // when params.improve
  double minDihedral = 0, maxDihedral = 0; // of the final mesh, degrees
  int modelEuler = 0;
  double seconds[4] = {0, 0, 0, 0}; // particles, triangulation, tetgen, improvement
};

// Throws ProcessingError when the surface is not closed and manifold or its Euler characteristic
// differs from the model's (the message names the counts), or when TetGen fails.
CadMeshResult meshCadModel(const CadModel& model, const CadMeshParams& params);

} // namespace tetflow
