#pragma once
// Current through each material of a solved conduction problem (tDCS reports; PoissonProblem.h).
//
// For every face between tets of two different labels, each side's current through it is
// q = A J . n, with A the face area, n its unit normal and J = -sigma grad u the P1 current
// density of that side's tet (the material's own current: P1 fluxes differ across a face, and an
// equipotential electrode material has J = 0 inside). A material's through-current is half the sum
// of |q| over its faces with other materials: what enters it leaves it, so this is the current
// that passes through it (mA, for u in V, sigma in S/m, lengths in mm). PoissonProblem reports
// an electrode material's injected current (the exact reaction) instead. Materials that touch
// no other material carry 0. Accuracy (tested): between two electrodes, with 2 mm elements, a
// 2 mm CSF layer carries the injected current within 3 %, a 3 mm skull layer (1/80 of its
// neighbours' conductivity) 12 % low; a flux from the residual of each material's own stiffness
// (conservative) would be exact and is not done yet.
// Memory: 16 B per tet face (a sorted face list); parallel over tets where it pays.
#include <Eigen/Core>

#include <cstdint>
#include <map>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/TetMesh.h"
#include "Conductivity.h"

namespace tetflow {

std::map<int32_t, double> materialCurrents(const TetMesh& mesh, const ConductivityTable& sigma,
                                           const Eigen::VectorXd& u, Progress& progress);

} // namespace tetflow
