#pragma once
// PETSc/MPI backend of IterativeSolver (solver_backend = petsc): the reduced SPD system K x = b
// solved by PETSc's KSP on every MPI rank of the run. Built only with TETFLOW_WITH_PETSC (Debian
// libpetsc-real-dev, found by pkg-config); otherwise petscAvailable() is false and constructing a
// PetscLinearSolver throws InputError saying how to get PETSc.
//
// Distribution: K is assembled once, on rank 0 (the pipeline runs there), and distributed by
// contiguous row blocks (rank r owns rows [n r / p, n (r+1) / p)): rank 0 sends each worker rank
// its rows in CSR form (global column indices), every rank builds its part of one MATMPIAIJ with
// MatCreateMPIAIJWithArrays. Right-hand sides are scattered the same way, the solution gathered
// to rank 0 (VecScatterCreateToZero). Rank 0 therefore holds the whole matrix once more than a
// fully distributed assembly would; the workers hold only their rows and PETSc's solver state.
//
// Workers (ranks > 0) run runPetscWorker(): a loop that waits for rank 0's commands (set up a
// system, solve, release it, exit), so a net is read, executed, written and reported by rank 0
// alone and no file is written twice.
//
// Solvers and stopping rule: KSPMINRES or KSPCG with PCJACOBI (M = diag K), PCNONE, PCGAMG or
// PCHYPRE (BoomerAMG with hypre's 3-D settings: HMIS coarsening, ext+i interpolation, strong
// threshold 0.5, P_max 4, one level of aggressive coarsening). x0 = 0; stop when
// ||r_k||_{M^-1} <= tol ||b||_{M^-1}: KSPMINRES measures that norm by its recurrence
// (KSP_NORM_PRECONDITIONED is the natural norm for MINRES), KSPCG is set to KSP_NORM_NATURAL
// (sqrt(r^T M^-1 r)); the test is PETSc's default with rtol = tol, atol = 0, dtol off, so
// iteration counts agree with the Eigen path up to rounding. PETSc options from
// SolverParams::petsc_options and the PETSC_OPTIONS environment variable (e.g. "-ksp_view",
// "-ksp_monitor", "-pc_gamg_threshold 0.02") are applied after these settings and override them.
//
// Failures: a PETSc error with one rank throws ProcessingError naming the call and PETSc's
// message. With several ranks the other ranks may be inside the same collective call, so the
// failing rank prints "tetflow: rank R: PETSc error in CALL: MESSAGE; stopping all ranks" and
// calls MPI_Abort (mpirun then ends every rank with a nonzero exit code): never a hang.
// Cancellation: rank 0 polls Progress::cancelRequested() at every iteration and broadcasts it; a
// cancelled solve ends on every rank and rank 0 throws Cancelled.
#include <Eigen/Core>

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/FEM/Assembly.h"
#include "Algorithms/FEM/IterativeSolver.h"

namespace tetflow {

bool petscAvailable(); // this build has PETSc

class PetscLinearSolver {
public:
  struct Outcome {
    SolverStatus status = SolverStatus::NotRun;
    int64_t iterations = 0;
    double relativeResidual = 0.0;  // last ||r||_{M^-1} / ||b||_{M^-1}
    std::vector<double> history;    // relative, entry 0 = 1
    // CG: the extreme eigenvalues of the preconditioned operator M^-1 K estimated from the
    // KSP's Lanczos coefficients (KSPComputeExtremeSingularValues); NaN for MINRES.
    double eigenMin = std::numeric_limits<double>::quiet_NaN();
    double eigenMax = std::numeric_limits<double>::quiet_NaN();
  };
  // Collective: distributes K (square, both triangles, compressed) and sets up the KSP on every
  // rank. Only rank 0 constructs one (the workers follow in runPetscWorker).
  PetscLinearSolver(const SparseMatrix& K, const SolverParams& params);
  ~PetscLinearSolver(); // collective: releases the system on every rank
  PetscLinearSolver(const PetscLinearSolver&) = delete;
  PetscLinearSolver& operator=(const PetscLinearSolver&) = delete;

  bool sameSystem(const SparseMatrix& K, const SolverParams& params) const;
  // progress: cancellation (and, with reportFraction, the solve's fraction).
  Outcome solve(const Eigen::VectorXd& b, Eigen::VectorXd& x, Progress* progress, bool reportFraction = true);
  int ranks() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// MPI and PETSc for an executable. Under mpirun (OMPI_COMM_WORLD_SIZE, PMI_SIZE or PMIX_RANK in
// the environment) the constructor initialises PETSc (and MPI) at once; otherwise nothing happens
// until the first PETSc solve, which initialises a single-process MPI. Without PETSc in the build,
// a launch with more than one rank is an InputError (each rank would run the whole net).
// The destructor sends the workers their exit command (rank 0) and finalises what was initialised.
class ParallelSession {
public:
  ParallelSession();
  ~ParallelSession();
  ParallelSession(const ParallelSession&) = delete;
  ParallelSession& operator=(const ParallelSession&) = delete;
  int rank() const { return rank_; }
  int size() const { return size_; }
  bool worker() const { return rank_ > 0; }
  // Ranks > 0: serve rank 0's commands until it exits; returns the process exit code.
  int runWorker();

private:
  int rank_ = 0, size_ = 1;
};

// Number of ranks of the running MPI job as its launcher announces it (1 when not under mpirun).
int launcherRanks();

} // namespace tetflow
