#pragma once
// P1 (linear tetrahedral) finite elements for -div(sigma grad u) = f (DESIGN §3 AssembleFEMPoisson,
// §6 "FEM problem"): mesh topology helpers, stiffness assembly, load vectors and point sources.
//
// Conventions: vertices and tets are 0-based indices of the TetMesh; positions in mm; one degree
// of freedom per vertex (dof i = vertex i in the full system). The barycentric coordinates of
// tet (p0, p1, p2, p3) have constant gradients
//   grad l1 = (e2 x e3) / D, grad l2 = (e3 x e1) / D, grad l3 = (e1 x e2) / D,
//   grad l0 = -(grad l1 + grad l2 + grad l3),   e_k = p_k - p0, D = e1 . (e2 x e3) = 6 vol,
// and the local stiffness matrix is K_ab = vol * grad(l_a)^T sigma grad(l_b).
//
// Parallelism, determinism, memory: assembly is parallel over both cores with OpenMP and needs
// no atomics on the matrix. Column j (= row j) is built by one thread from the star of vertex j
// (VertexStars.h: the tets around j, produced block by block, so the full vertex -> tets map is
// never held): first the pattern (the distinct vertices of the star), then the values, adding the
// tets around j in ascending tet order. Entry (a, j) of a tet is vol * g_a^T sigma g_j evaluated
// so that swapping a and j gives the same bits; hence K is exactly symmetric and bitwise the
// same for any thread count and block size. The gradients of a tet are recomputed at each of its
// 4 corners instead of being stored (no 80 B/tet array). Temporary memory beyond the matrix: 4 B
// per vertex (degrees) + 4 B per vertex per thread (marks) + the current block's star lists
// (4 B per corner, a quarter of all corners by default = 4 B per tet).
#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/TetMesh.h"
#include "Conductivity.h"

namespace tetflow {

// Column-major, int indices, compressed; TetFlow's stiffness matrices store both triangles.
using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

// Throws InputError naming the first tet (lowest index) whose signed volume is not positive
// (inverted) or is zero within |V| <= kZeroVolumeRelTol * L_max^3 (degenerate). P1 needs every
// tet positively oriented and non-degenerate (DESIGN §2, TetMesh.h).
void checkTetVolumes(const TetMesh& mesh);

// Per vertex: 1 when it lies on a boundary face (a triangular face used by exactly one tet),
// else 0. Vertices used by no tet are 0. Parallel over vertices, from their stars (VertexStars.h).
std::vector<uint8_t> boundaryVertexFlags(const TetMesh& mesh);

// Electrodes on the surface: for each position, the nearest boundary vertex (lowest index on ties)
// and its distance (mm). Parallel over the positions. InputError when the mesh has no boundary.
struct SurfaceSnap {
  int32_t vertex = -1;
  double distance = 0.0;
};
std::vector<SurfaceSnap> snapToBoundary(const TetMesh& mesh, const std::vector<Vec3>& positions);

// Connected components of the tets (two tets are connected when they share a vertex):
// component id per vertex, -1 for vertices used by no tet; ids are 0.. in order of the lowest
// vertex index of each component. `count` receives the number of components.
std::vector<int32_t> vertexComponents(const TetMesh& mesh, int32_t& count);

// Barycentric gradients (1/mm) and volume (mm^3) of tet t.
struct TetGradients {
  std::array<Vec3, 4> grad;
  double volume = 0.0;
};
TetGradients tetGradients(const TetMesh& mesh, size_t t);

// Global stiffness matrix (numPoints x numPoints, mS; see Conductivity.h for units) with sigma
// chosen per tet by its material label from `sigma`. Vertices used by no tet have an empty
// row/column. Checks sizes (validateStructure), volumes (checkTetVolumes) and the conductivity
// table; throws InputError naming the culprit. Stages are not opened here; calls
// progress.checkCancel() after every block of vertex stars. `blockCorners` (> 0) overrides the
// star block budget (tests use it to show the result does not depend on it).
SparseMatrix assembleStiffness(const TetMesh& mesh, const ConductivityTable& sigma, Progress& progress);
SparseMatrix assembleStiffness(const TetMesh& mesh, const ConductivityTable& sigma, Progress& progress,
                               int64_t blockCorners);

// Consistent load vector b_i = integral f phi_i for a constant source density f (mA/mm^3):
// b_i = sum over tets T containing i of f vol_T / 4.
Eigen::VectorXd assembleLoad(const TetMesh& mesh, double f);
// Consistent load for a piecewise linear f given at the vertices (P1 mass matrix applied to f):
// b_i = sum_T vol_T / 20 (f_i + sum_{a in T} f_a). Reduces to vol/4 per vertex for constant f.
Eigen::VectorXd assembleLoad(const TetMesh& mesh, const std::vector<double>& fAtVertices);

// A point of the mesh: containing tet (lowest index among those whose closure contains it, with
// barycentric coordinates >= -1e-10) and its barycentric coordinates (sum 1).
struct PointLocation {
  int64_t tet = -1;
  std::array<double, 4> bary{0, 0, 0, 0};
};
std::optional<PointLocation> locatePoint(const TetMesh& mesh, const Vec3& p);

// Point current source I (mA) at p: b_a += I * l_a(p) for the 4 vertices a of the containing tet
// (the exact integral of I delta_p phi_a). InputError naming `what` if p is outside the mesh.
PointLocation addPointSource(const TetMesh& mesh, const Vec3& p, double current, Eigen::VectorXd& b,
                             const std::string& what);

// Current dipole with moment m (mA mm) at position p (mm), as the load of EEG forward problems.
//  separation d > 0: two monopoles, +I at p + d/2 m^ and -I at p - d/2 m^, I = |m| / d, each
//                    distributed by barycentric weights over its containing tet;
//  separation d = 0: the limit d -> 0 of the same (the "partial integration" dipole):
//                    b_a += m . grad l_a for the 4 vertices of the tet containing p.
// Both add loads that sum to zero (no net current). Returns the tet(s) used (one for d = 0).
// InputError when |m| = 0, d < 0, or a pole lies outside the mesh.
std::vector<PointLocation> addDipole(const TetMesh& mesh, const Vec3& position, const Vec3& moment,
                                     double separation, Eigen::VectorXd& b);

// y = K x for a square matrix stored with both triangles (symmetric): y_i = column i . x, parallel
// over columns (OpenMP), no races; y is resized. Requires K symmetric (TetFlow's matrices are).
void multiplySymmetric(const SparseMatrix& K, const Eigen::VectorXd& x, Eigen::VectorXd& y);
// Same on raw arrays of K.cols() entries (x and y must not overlap).
void multiplySymmetric(const SparseMatrix& K, const double* x, double* y);

} // namespace tetflow
