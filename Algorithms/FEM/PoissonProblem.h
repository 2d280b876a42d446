#pragma once
// The FEM Poisson problem of AssembleFEMPoisson (DESIGN §3, §6 "FEM problem", "Solver",
// "Conditioning"): -div(sigma grad u) = f on a TetMesh with P1 elements, one of four boundary
// conditions, the symmetric elimination of Dirichlet values, an iterative solve, conditioning
// figures and derived fields.
//
// Units (consistent, no hidden factors): lengths mm, sigma S/m, potential u V, stiffness mS
// (S/m x mm), currents mA (K u = f), source densities mA/mm^3, dipole moments mA mm, gradients
// V/mm, current densities mA/mm^2 (= kA/m^2; S/m x V/mm).
//
// Stages (named, timed, reported through Progress, DESIGN §7):
//   assemble             stiffness matrix (Assembly.h), load vector
//   boundary conditions  boundary vertices, Dirichlet set, reference vertices, elimination
//   solve                MINRES or CG (IterativeSolver.h)
//   condition            kappa(K) and kappa(D^-1/2 K D^-1/2) (Conditioning.h): with
//                        estimate_condition and dofs <= condition.max_dofs by Spectra (one
//                        SimplicialLDLT factorisation of K serves both); otherwise Lanczos
//                        estimates: the solve's own tridiagonal for the preconditioner used, and
//                        a CG run (fixed-seed random right-hand side, same tolerance and
//                        iteration limit) with the other preconditioner. An eigen solve that does
//                        not converge falls back to the Lanczos estimate. *_method says which.
//   fields               potential, |grad u| and |sigma grad u| per tet, electrode currents
//
// Boundary conditions (BoundaryConditions.h lists them):
//   boundary             u = 0 on every boundary vertex; f = `source` (default 1).
//   electrodes           u = electrode_potential_min (1 V) on boundary vertices with coordinate
//                        <= min + electrode_fraction * extent along electrode_axis,
//                        u = electrode_potential_max (0 V) where >= max - fraction * extent; f = 0.
//   material_electrodes  every vertex of a tet labelled L in electrode_potentials is held at
//                        electrode_potentials[L]; f = 0. A vertex shared by two electrode
//                        materials of different potentials is an InputError.
//   dipole               f = 0 plus the dipole load of Assembly.h addDipole (separation 0: the
//                        partial-integration limit of the +-I monopole pair; > 0: the pair itself).
//                        Pure Neumann problem: the boundary vertex farthest from the dipole
//                        (lowest index on ties) is the reference, held at u = 0 V.
// Connected components without any Dirichlet vertex (e.g. floating pieces under `electrodes`)
// would leave K singular: each gets one reference vertex held at 0 V (its lowest-index boundary
// vertex; for `dipole` the boundary vertex farthest from the dipole), listed in the result and
// logged in `notes`. Vertices used by no tet are excluded (not dofs; potential 0).
//
// Errors (InputError, naming the culprit): mesh structure or an inverted/degenerate tet (by
// index), a conductivity label absent from the mesh, an invalid conductivity, an electrode axis
// outside 0..2, a mesh without extent along it, an electrode fraction outside (0, 0.5),
// electrode_potentials empty or naming a label absent from the mesh, touching electrode
// materials at different potentials, a dipole outside the mesh or with zero moment, bad solver
// parameters, a mesh without tets. Not converging is a status in the result, not an error.
#include <Eigen/Core>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/TetMesh.h"
#include "Assembly.h"
#include "BoundaryConditions.h"
#include "Conditioning.h"
#include "Conductivity.h"
#include "IterativeSolver.h"
#include "SourceModels.h"

namespace tetflow {

struct PoissonParams {
  ConductivityTable conductivities;                 // S/m per label, default for the rest
  BoundaryCondition boundary = BoundaryCondition::Boundary;
  double source = 1.0;                              // boundary: constant f (mA/mm^3)
  int electrode_axis = 0;                           // electrodes: 0 = x, 1 = y, 2 = z
  double electrode_fraction = 0.05;                 // electrodes: band, fraction of the extent
  double electrode_potential_min = 1.0;             // electrodes: u at the min side (V)
  double electrode_potential_max = 0.0;             // electrodes: u at the max side (V)
  std::map<int32_t, double> electrode_potentials;   // material_electrodes: label -> V
  Vec3 dipole_position{0.0, 0.0, 0.0};              // dipole: mm
  Vec3 dipole_moment{0.0, 0.0, 1.0};                // dipole: mA mm
  double dipole_separation = 0.0;                   // dipole: mm (0 = partial-integration limit)
  // dipole: partial integration (Assembly.h addDipole), the St. Venant monopoles (SourceModels.h)
  // or the subtraction model (Subtraction.h); the last two need separation 0.
  SourceModel sourceModel = SourceModel::PartialIntegration;
  double injected_current = 0.0;  // material_electrodes with two labels: mA from the higher-
                                  // potential electrode to the other (0 = potentials as given)
  SolverParams solver;
  bool estimate_condition = true;  // Spectra eigen solves; false = Lanczos estimates only
  bool condition_numbers = true;   // false: no condition stage at all (NaN, method says so)
  ConditionParams condition;       // condition.max_dofs: above it, Lanczos estimates (noted)
};

struct PoissonResult {
  BoundaryCondition boundary = BoundaryCondition::Boundary;
  int64_t vertices = 0, tets = 0;
  int64_t unusedVertices = 0;    // used by no tet: excluded
  int64_t boundaryVertices = 0;  // on faces used by one tet
  int64_t dirichletVertices = 0; // fixed values, reference vertices included
  int64_t components = 0;        // connected components of the mesh
  std::vector<int32_t> referenceVertices; // held at 0 V to make K nonsingular
  std::vector<PointLocation> dipoleTets;  // dipole: tet(s) of the pole(s)
  std::vector<int32_t> labels;            // material labels present, ascending

  std::shared_ptr<const SparseMatrix> matrix; // reduced K (dofs x dofs, mS)
  int64_t dofs = 0;
  int64_t nnz = 0;                            // stored non-zeros of the reduced K (both triangles)

  SolverParams solver;
  int64_t ranks = 1;             // MPI ranks of the solve (petsc backend; 1 for eigen)
  std::string solverUsed;        // the solver that ran (solver = auto: the one it chose)
  SolverStatus status = SolverStatus::NotRun;
  bool converged = false;
  int64_t iterations = 0;
  double relativeResidual = 0.0; // ||r||_{M^-1} / ||b||_{M^-1}
  double trueResidual = 0.0;     // ||b - K x||_2 / ||b||_2
  std::vector<double> residualHistory;

  SpectrumEstimate kappa;        // of K
  SpectrumEstimate kappaJacobi;  // of D^-1/2 K D^-1/2
  SpectrumEstimate lanczos;      // Ritz estimate from the solve itself (of M^-1 K)

  std::vector<double> potential;      // per vertex (V)
  // Subtraction model: the singular part u_inf of the potential (V, shifted like it so that the
  // reference vertex is at 0 V; 0 off the dipole's piece); empty for the other models.
  std::vector<double> singularPotential;
  std::vector<double> gradMagnitude;  // per tet |grad u| (V/mm)
  std::vector<double> currentDensity; // per tet |sigma grad u| (mA/mm^2)
  double potentialMin = 0.0, potentialMax = 0.0;
  // Electrodes with their potential (V) and the current injected into the conductor through
  // them (mA; the reaction K u - f summed over their vertices), in order: `electrodes`: "min"
  // then "max" side; `material_electrodes`: "label_L" per label, ascending. Empty otherwise.
  struct Electrode {
    std::string name;
    double potential = 0.0;
    double current = 0.0;
    int32_t label = -1; // material_electrodes: the electrode's material label
  };
  std::vector<Electrode> electrodes;
  double injectedCurrent = 0.0;                  // injected_current (mA; 0 = not used)
  double injectionScale = 1.0;                   // injected_current / current at potentials given
  std::map<int32_t, double> materialCurrents;    // electrodes: current through each material (mA)

  double assembleSeconds = 0, boundarySeconds = 0, solveSeconds = 0, conditionSeconds = 0,
         fieldsSeconds = 0;
  std::vector<std::string> notes; // things the user should know (reference vertices, ...)
};

PoissonResult solvePoisson(const TetMesh& mesh, const PoissonParams& params, Progress& progress);

// Per-tet |grad u| and |sigma grad u| of the P1 function with vertex values u (parallel).
void computeFluxFields(const TetMesh& mesh, const ConductivityTable& sigma, const Eigen::VectorXd& u,
                       std::vector<double>& gradMagnitude, std::vector<double>& currentDensity);

// Adds point field "potential" and cell fields "grad_magnitude", "current_density" (1 component).
void addPoissonFields(const PoissonResult& r, TetMesh& mesh);

// Report keys, in this order: vertices, tets, materials, boundary_condition, boundary_vertices,
// dirichlet_vertices, reference_vertices, unused_vertices, dofs, nnz, solver, preconditioner,
// solver_backend, ranks, tolerance, max_iterations, iterations, relative_residual, true_residual, converged,
// solver_status, kappa, kappa_method, lambda_min, lambda_max, kappa_jacobi, kappa_jacobi_method,
// lambda_min_jacobi, lambda_max_jacobi, kappa_lanczos, kappa_lanczos_method, potential_min,
// potential_max, then per electrode `electrode_<name>_current` (mA) and, for `electrodes`,
// resistance (kOhm = V/mA: potential difference / current of the min electrode); with
// injected_current, `electrode_<name>_potential` (V) and injection_scale; for both electrode
// conditions `material_<label>_current` (mA, MaterialCurrents.h); for dipole: dipole_tet, reference_vertex; then assemble_seconds,
// boundary_seconds, solve_seconds, condition_seconds, fields_seconds. NaN figures (e.g. an eigen
// solve that did not converge) are written as NaN doubles; the *_method text says why.
void writePoissonReport(const PoissonResult& r, Report& report);

} // namespace tetflow
