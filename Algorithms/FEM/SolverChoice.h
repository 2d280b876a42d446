#pragma once
// `solver = auto`: which solver is fastest for this system and this many right-hand sides, within
// the memory this process may take (issue 49 item 1). Three candidates: cholesky (CHOLMOD),
// minres with the given preconditioner (Jacobi by default), and - when this build has PETSc and
// solver_backend is eigen - CG with BoomerAMG run by PETSc in this process ("amg"). The rule:
//   1. solver_backend petsc: minres (CHOLMOD runs in one process), the preconditioner as given.
//   2. The factor of exactly this K is kept from an earlier solve (SolverCache.h): cholesky.
//   3. The iterative time is the faster of
//        t_minres = k * its(n) * (2 nnz(K) + 12 n) / R_matvec,   its(n) = c n^(1/3) log(tol)/log(1e-8)
//        t_amg    = nnz(K) * (s_setup + k * s_solve * log(tol)/log(1e-8))
//      (BoomerAMG's set-up and one CG solve, ~16 iterations at any size, cost about a constant
//      per nonzero of K: measured 3.6-5.8e-7 and 1.9-3.7e-7 s from 0.1 to 2 M unknowns).
//   4. Predict, before any analysis, nnz(L) ~ 4.5 n^(4/3) and the factorisation's flops ~ 1.9 n^2
//      (nested dissection of a 3-D mesh; the constants fitted on the layered heads of the scaling
//      benchmark, where they held within a factor 2). When the predicted factor needs more than
//      twice the memory available, or the predicted Cholesky time is over three times the
//      iterative one: the faster iterative solver, without analysing.
//   5. Otherwise analyse (CHOLMOD's ordering and symbolic factorisation: exact nnz(L) and flops)
//      and take cholesky when L and the solves' blocks fit in the memory available and
//        t_cholesky  = flops / R_factor + k * 4 nnz(L) / R_solve
//      is at most the iterative time; else the faster iterative solver. The analysed factor is
//      handed on, so choosing does not analyse twice.
// The rates are those measured on this 2-core machine (R_factor 3e10, R_solve 9e9, R_matvec
// 3.1e9 flop/s; c = 12.5, Jacobi-MINRES on the 1 mm head; s_setup 4e-7, s_solve 2.7e-7 s, one
// PETSc rank); on another machine their ratios, not their values, decide. The note says what was
// picked and why, with the predictions.
#include <cstdint>
#include <memory>
#include <string>

#include "Algorithms/Core/Progress.h"
#include "IterativeSolver.h"

namespace tetflow {

class SparseCholesky;

struct SolverCostModel {
  double factorRate = 3.0e10; // flop/s of the numeric factorisation
  double solveRate = 9.0e9;   // flop/s of the triangular solves (blocks of right-hand sides)
  double matvecRate = 3.1e9;  // flop/s of one Jacobi-MINRES iteration
  double iterationConstant = 12.5; // its(n) = c n^(1/3) at tolerance 1e-8
  double analyzeRate = 6.5e4; // unknowns per second of the ordering + symbolic analysis
  double amgSetupPerNonzero = 4.0e-7; // s per nonzero of K: BoomerAMG's set-up (one PETSc rank)
  double amgSolvePerNonzero = 2.7e-7; // s per nonzero of K: one CG + BoomerAMG solve to 1e-8
  bool amgAvailable = true;           // and this build has PETSc (petscAvailable())
  // Predictions for n unknowns, nnz(K) = nnzK.
  double iterations(int64_t n, double tolerance) const;
  double iterativeSeconds(int64_t n, int64_t nnzK, int64_t rightHandSides, double tolerance) const;
  double choleskySeconds(double flops, double factorNonzeros, int64_t rightHandSides) const;
  double amgSeconds(int64_t nnzK, int64_t rightHandSides, double tolerance) const;
  static double predictedFactorNonzeros(int64_t n);
  static double predictedFlops(int64_t n);
};

struct SolverChoice {
  SolverKind kind = SolverKind::Minres;
  // What the chosen kind runs with: the requested preconditioner and backend, or for the AMG
  // candidate Hypre on Petsc (kind Cg).
  PreconditionerKind preconditioner = PreconditionerKind::Jacobi;
  SolverBackend backend = SolverBackend::Eigen;
  std::shared_ptr<SparseCholesky> factor; // kind Cholesky: analysed (factorised when reused)
  bool reused = false;                    // the factor came from SolverCache
  double predictedCholeskySeconds = 0, predictedIterativeSeconds = 0; // iterative: the faster one
  double predictedMinresSeconds = 0, predictedAmgSeconds = 0;          // amg: infinity when unavailable
  std::string note; // "auto: cholesky (...)" / "auto: minres + jacobi (...)" / "auto: cg + hypre (...)"
};

// p.kind must be Auto. K: the reduced SPD system (both triangles). Cancellable (the analysis).
SolverChoice chooseSolver(const SparseMatrix& K, const SolverParams& p, int64_t rightHandSides, Progress& progress,
                          const SolverCostModel& model = SolverCostModel());

} // namespace tetflow
