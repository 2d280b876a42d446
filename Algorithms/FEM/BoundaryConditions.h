#pragma once
// Boundary conditions of the FEM problem (DESIGN §6 "FEM problem") and the symmetric elimination
// of Dirichlet values.
//
// Choices (saved names; values stable, DESIGN §7):
//   boundary            u = 0 on every boundary vertex, f = 1 (consistent load, vol/4 per vertex)
//   electrodes          DESIGN §6 (b): u = 1 on boundary vertices with coordinate <=
//                       min + 5 % of the extent along the electrode axis (default x), u = 0 where
//                       >= max - 5 %, f = 0, insulated (natural condition) elsewhere
//   material_electrodes every vertex of a tet of a chosen material label is held at that label's
//                       potential (e.g. "5:1; 6:0"): the material acts as a perfect conductor;
//                       f = 0, insulated elsewhere
//   dipole              EEG forward problem: a current dipole source (Assembly.h addDipole), f = 0,
//                       insulated everywhere; the pure-Neumann system is made well posed by a
//                       reference vertex held at u = 0
// Boundary vertices are the vertices of faces used by exactly one tet.
//
// Symmetric elimination: with D the Dirichlet vertices (values u_D) and F the free ones,
//   K_FF u_F = f_F - K_FD u_D,
// so the reduced matrix K_FF is a principal submatrix of K: symmetric, and positive definite as
// soon as every connected component of the mesh has at least one Dirichlet vertex.
#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

#include "Assembly.h"

namespace tetflow {

enum class BoundaryCondition : int { Boundary = 0, Electrodes = 1, MaterialElectrodes = 2, Dipole = 3 };
const char* boundaryConditionName(BoundaryCondition bc);
// InputError listing the valid names for anything else.
BoundaryCondition boundaryConditionFromName(const std::string& name);

// Fixed values per vertex (full length = number of vertices).
struct DirichletSet {
  std::vector<uint8_t> fixed;  // 1 = Dirichlet (or excluded) vertex
  std::vector<double> value;   // its value (V); 0 for free vertices

  explicit DirichletSet(size_t vertices = 0) : fixed(vertices, 0), value(vertices, 0.0) {}
  void set(size_t v, double u) {
    fixed[v] = 1;
    value[v] = u;
  }
  size_t count() const;
};

// The reduced system over the free vertices only.
struct ReducedSystem {
  SparseMatrix K;                   // |F| x |F|, compressed, both triangles stored (mS)
  Eigen::VectorXd b;                // f_F - K_FD u_D (mA)
  std::vector<int32_t> freeVertex;  // reduced index -> vertex (ascending)
  std::vector<int32_t> reducedIndex; // vertex -> reduced index, -1 for fixed vertices
  std::vector<double> fixedValue;   // per vertex: its Dirichlet value (0 where free)
  // Full vector of vertex values: x at the free vertices, the Dirichlet values elsewhere.
  Eigen::VectorXd expand(const Eigen::VectorXd& x) const;
};

// Eliminates the Dirichlet vertices of `d` from K u = f (K square, symmetric, both triangles
// stored, compressed). Parallel over columns (OpenMP). InputError when sizes disagree.
ReducedSystem eliminateDirichlet(const SparseMatrix& K, const Eigen::VectorXd& f, const DirichletSet& d);

} // namespace tetflow
