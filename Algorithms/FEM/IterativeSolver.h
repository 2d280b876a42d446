#pragma once
// Iterative solvers for the reduced SPD system K x = b (DESIGN §6 "Solver", §7: configured, run,
// then queried, like MFEM's IterativeSolver).
//
//   MINRES  preconditioned MINRES of Paige & Saunders (SIAM J. Numer. Anal. 12, 1975), in the
//           recurrences of their minres.m: Lanczos on M^-1 K, QR of the tridiagonal by Givens
//           rotations, x updated by a three-term recurrence.
//   CG      preconditioned conjugate gradients (Hestenes & Stiefel).
//   Cholesky  not iterative: the sparse Cholesky factorisation of K (SparseCholesky.h, CHOLMOD),
//           computed at the first solve (or setUp()) and kept for every later one with the same
//           operator; a solve is two triangular solves. iterations() is 0, the status Converged
//           (or an InputError when K is not positive definite), relativeResidual() and
//           trueResidual() are both ||b - K x||_2 / ||b||_2; the preconditioner, tolerance and
//           max_iterations do not apply. solveBlock() solves many right-hand sides in one pass.
//           The factor is kept for reuse by later solvers of exactly the same K (SolverCache.h).
//   Auto    chooses one of them at setUp() (or the first solve) for this system, the number of
//           right-hand sides announced by setRightHandSides() and the memory available
//           (SolverChoice.h); params().kind is then the kind chosen and choiceNote() says why.
// Preconditioner M = diag(K) (Jacobi) or M = I (none). x0 = 0. With SolverParams::backend = Petsc
// the same solvers run in PETSc on every MPI rank (Petsc/PetscLinearSolver.h), with PETSc's AMG
// preconditioners as further choices.
//
// Stopping rule (both solvers): stop after iteration k when the preconditioned residual norm
//   ||r_k||_{M^-1} = sqrt(r_k^T M^-1 r_k) <= tol * ||b||_{M^-1}      (r_k = b - K x_k),
// i.e. relativeResidual() <= tol. MINRES tracks ||r_k||_{M^-1} by its recurrence (phibar; equal
// in exact arithmetic); CG computes it from r_k and z_k = M^-1 r_k. With M = I it is the 2-norm.
// An iteration is one product with K. Not converging within max_iterations is a status
// (converged() == false), not an exception; so is a breakdown (CG: p^T K p <= 0, i.e. K not
// positive definite; either solver: the preconditioner is not positive definite).
//
// After solve(): iterations(), relativeResidual() (the preconditioned relative residual above,
// last iterate), trueResidual() = ||b - K x||_2 / ||b||_2 (computed once at the end),
// residualHistory() (relative preconditioned residual, entry 0 = 1 for x0 = 0, then one per
// iteration), and the Lanczos tridiagonal of the run (lanczos(): its extreme eigenvalues are
// Ritz values of M^-1 K, used by Conditioning.h as a cheap condition estimate).
//
// Parallelism: the sparse matrix-vector product is parallel (OpenMP, multiplySymmetric: each
// row by one thread); the vector updates are fused loops over fixed chunks of 4096 entries in
// parallel, and every inner product adds its per-chunk partial sums in chunk order. Iterates,
// residuals and iteration counts are therefore bitwise independent of the thread count. Work per
// iteration beyond the mat-vec: MINRES 4 passes over 2-5 vectors, CG 3. The monitor callback and
// the Progress sink are called from the calling thread; progress.checkCancel() is called every
// iteration (throws Cancelled).
#include <Eigen/Core>

#include <algorithm>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Assembly.h"

namespace tetflow {

class PetscLinearSolver;
class SparseCholesky;
struct SolverCostModel;

enum class SolverKind : int { Minres = 0, Cg = 1, Cholesky = 2, Auto = 3 };
const char* solverKindName(SolverKind k);
SolverKind solverKindFromName(const std::string& name); // InputError listing the names

// gamg (PETSc's smoothed-aggregation AMG) and hypre (BoomerAMG) need backend Petsc.
enum class PreconditionerKind : int { Jacobi = 0, None = 1, Gamg = 2, Hypre = 3 };
const char* preconditionerKindName(PreconditionerKind k);
PreconditionerKind preconditionerKindFromName(const std::string& name);

enum class SolverStatus : int { NotRun = 0, Converged = 1, MaxIterations = 2, Breakdown = 3 };
const char* solverStatusName(SolverStatus s); // "not_run", "converged", "max_iterations", "breakdown"

// Where the iterations run: Eigen = the solvers of this file (one process, OpenMP); Petsc = PETSc's
// KSP (KSPMINRES / KSPCG) with PCJACOBI / PCNONE / PCGAMG / PCHYPRE, on every MPI rank of the run
// (Petsc/PetscLinearSolver.h). Same stopping rule, same queries (lanczos() stays empty).
enum class SolverBackend : int { Eigen = 0, Petsc = 1 };
const char* solverBackendName(SolverBackend b);
SolverBackend solverBackendFromName(const std::string& name);

struct SolverParams {
  SolverKind kind = SolverKind::Minres;
  PreconditionerKind preconditioner = PreconditionerKind::Jacobi;
  double tolerance = 1e-8;         // relative, in (0, 1)
  int64_t max_iterations = 10000;  // >= 1
  SolverBackend backend = SolverBackend::Eigen;
  std::string petsc_options;       // Petsc: PETSc options (e.g. "-ksp_view"), applied after ours
  SolverParams() = default;
  SolverParams(SolverKind k, PreconditionerKind p, double tol, int64_t maxIterations)
      : kind(k), preconditioner(p), tolerance(tol), max_iterations(maxIterations) {}
  // Throws InputError naming the parameter (tolerance, max_iterations, preconditioner,
  // solver_backend) when out of range or not available in this build.
  void validate() const;
};

// Symmetric tridiagonal T_k of the preconditioned Lanczos process: diagonal[0..k), offDiagonal[i]
// couples i and i+1 (k-1 entries are used for T_k; one more may be stored).
struct LanczosTridiagonal {
  std::vector<double> diagonal;
  std::vector<double> offDiagonal;
  size_t steps() const { return diagonal.size(); }
};

class IterativeSolver {
public:
  // (iteration k >= 1, relative preconditioned residual after it)
  using Monitor = std::function<void(int64_t, double)>;

  IterativeSolver() = default;
  explicit IterativeSolver(const SolverParams& p) : params_(p), requested_(p) {}

  // --- configure ---
  void setParams(const SolverParams& p) {
    params_ = p;
    requested_ = p;
    resetSetUp();
  }
  // After an auto choice, kind (and for cg + hypre the preconditioner and backend) is the one
  // chosen; requested() is what was asked for.
  const SolverParams& params() const { return params_; }
  const SolverParams& requested() const { return requested_; }
  // Auto: the cost model that weighs the candidates (SolverChoice.h); tests change its rates.
  void setCostModel(const SolverCostModel& m);
  // K must be square, symmetric with both triangles stored, compressed, and outlive solve().
  // With the Jacobi preconditioner every diagonal entry must be > 0 (checked in solve()).
  void setOperator(const SparseMatrix& K) {
    K_ = &K;
    resetSetUp(); // a new operator (even at the same address) is set up again
  }
  void setMonitor(Monitor m) { monitor_ = std::move(m); }
  // reportFraction false: the sink is asked for cancellation only (a caller reporting its own
  // fraction over many solves, e.g. a lead field).
  void setProgress(Progress* p, bool reportFraction = true) {
    progress_ = p;
    reportFraction_ = reportFraction;
  }
  // How many right-hand sides will be solved with this operator (solver = auto weighs a set-up
  // against them); default 1.
  void setRightHandSides(int64_t k) { rightHandSides_ = std::max<int64_t>(1, k); }

  // --- run --- (x is resized; x0 = 0). With backend Petsc the matrix is handed to PETSc at the
  // first solve and kept (with its preconditioner set up) for later solves with the same
  // operator and params: a lead field's many right-hand sides pay for the set-up once. InputError for a missing/non-square operator, a size
  // mismatch, bad params, or a non-positive diagonal with Jacobi.
  void solve(const Eigen::VectorXd& b, Eigen::VectorXd& x);
  // Auto: chooses the kind first. Cholesky: factorises K now (if not yet; a factor of exactly K
  // kept in SolverCache is taken instead) and returns the seconds it took (0 when it was already
  // set up). Backend petsc: distributes K and sets up the preconditioner (an AMG hierarchy) on
  // every rank. MINRES and CG of the eigen backend set nothing up and return 0. Cancellable;
  // refused before it allocates when the factor would not fit (SparseCholesky.h).
  double setUp();
  // Auto: chooses now (cholesky: analysed, not yet factorised), without setting up. Others: nothing.
  void choose();
  // Cholesky only: X = K^-1 B for every column of B at once (the queries then describe the
  // worst column). InputError for the iterative kinds.
  void solveBlock(const Eigen::MatrixXd& B, Eigen::MatrixXd& X);
  bool direct() const { return params_.kind == SolverKind::Cholesky; }
  // Whether setUp() may analyse and factorise (cholesky, or auto with backend eigen; auto may also
  // pick cg + hypre on PETSc in this process, whose set-up setUp() then does).
  bool mayFactorize() const {
    return direct() || (params_.kind == SolverKind::Auto && params_.backend == SolverBackend::Eigen);
  }
  // Cholesky, after setUp(): the factor (nullptr before).
  const SparseCholesky* cholesky() const { return cholesky_.get(); }
  // The factor was taken from SolverCache (no factorisation was paid for it here).
  bool factorReused() const { return reused_; }
  // Auto: "auto: <kind> (<why>)" after the choice; empty otherwise.
  const std::string& choiceNote() const { return choiceNote_; }

  // --- query ---
  SolverStatus status() const { return status_; }
  bool converged() const { return status_ == SolverStatus::Converged; }
  int64_t iterations() const { return iterations_; }
  double relativeResidual() const { return relres_; }
  double trueResidual() const { return trueRes_; }
  const std::vector<double>& residualHistory() const { return history_; }
  const LanczosTridiagonal& lanczos() const { return lanczos_; }
  double seconds() const { return seconds_; }
  int ranks() const; // MPI ranks of the last solve (1 for eigen)
  // Backend petsc, CG: PETSc's estimate of the extreme eigenvalues of M^-1 K from the last solve's
  // Lanczos coefficients (with gamg or hypre: of the AMG-preconditioned operator); NaN otherwise.
  double kspEigenMin() const { return kspEigenMin_; }
  double kspEigenMax() const { return kspEigenMax_; }

private:
  void runMinres(const Eigen::VectorXd& b, Eigen::VectorXd& x, const Eigen::VectorXd& minv);
  void runCg(const Eigen::VectorXd& b, Eigen::VectorXd& x, const Eigen::VectorXd& minv);
  bool step(int64_t k, double relres); // records history, calls monitor/progress; true = stop

  void solvePetsc(const Eigen::VectorXd& b, Eigen::VectorXd& x);
  void checkOperator(Eigen::Index rhsRows) const;
  void resetSetUp();

  SolverParams params_;
  SolverParams requested_;
  std::shared_ptr<const SolverCostModel> model_; // null: the default model
  const SparseMatrix* K_ = nullptr;
  std::shared_ptr<PetscLinearSolver> petsc_; // Petsc: the distributed system, reused
  std::shared_ptr<SparseCholesky> cholesky_; // Cholesky: the factor, reused
  Monitor monitor_;
  Progress* progress_ = nullptr;
  bool reportFraction_ = true;
  bool reused_ = false;
  int64_t rightHandSides_ = 1;
  std::string choiceNote_;

  SolverStatus status_ = SolverStatus::NotRun;
  int64_t iterations_ = 0;
  double relres_ = 0.0;
  double trueRes_ = 0.0;
  double seconds_ = 0.0;
  double kspEigenMin_ = std::numeric_limits<double>::quiet_NaN();
  double kspEigenMax_ = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> history_;
  LanczosTridiagonal lanczos_;
};

} // namespace tetflow
