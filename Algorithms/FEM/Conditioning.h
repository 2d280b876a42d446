#pragma once
// Conditioning of the reduced stiffness matrix (DESIGN §6 "Conditioning"):
//   kappa_2(K) = lambda_max / lambda_min of the reduced (SPD) K, and
//   kappa_2(D^-1/2 K D^-1/2), D = diag(K) (the Jacobi-scaled matrix; its spectrum is that of
//   M^-1 K with M = D, which is what Jacobi-preconditioned MINRES/CG see).
// Every estimate says which method and tolerance produced it (SpectrumEstimate::method).
//
// Methods:
//  - spectraExtremes(): for n > dense_limit, lambda_max by Spectra's SymEigsSolver (implicitly
//    restarted Lanczos, ncv basis vectors, parallel matrix-vector product) and lambda_min by
//    Spectra's SymEigsShiftSolver in shift-invert mode at shift 0 (largest eigenvalue of K^-1),
//    the solves done by a sparse Cholesky factorisation (Eigen::SimplicialLDLT, AMD ordering).
//    Spectra's convergence test is relative: |residual of a Ritz pair| <= tol * |Ritz value|.
//    The factorisation costs memory growing faster than the matrix (3-D fill-in): meant for
//    meshes up to some 10^5 vertices. For n <= dense_limit: dense Eigen::SelfAdjointEigenSolver.
//    If Spectra does not converge (or the factorisation fails), converged == false and the
//    missing value is NaN; the message says which part failed.
//  - lanczosEstimate(): the extreme eigenvalues of the Lanczos tridiagonal recorded by MINRES or
//    CG (IterativeSolver::lanczos()), by Sturm-sequence bisection to machine precision. These are
//    Ritz values of M^-1 K: lambda_min is over- and lambda_max under-estimated, so the kappa
//    estimate is a lower bound that tightens as the Krylov space grows. Costs nothing beyond the
//    solve; meant for meshes too large for the eigen solves.
#include <cstdint>
#include <limits>
#include <string>

#include "Algorithms/Core/Progress.h"
#include "Assembly.h"
#include "IterativeSolver.h"

namespace tetflow {

struct ConditionParams {
  double tolerance = 1e-8;    // Spectra's relative tolerance on the Ritz pairs
  int64_t ncv = 20;           // Lanczos basis size (Spectra ncv), >= 3
  int64_t max_restarts = 2000; // Spectra maxit
  int64_t dense_limit = 200;  // n <= dense_limit: dense eigen decomposition
  // Above this many unknowns the eigen solves are not attempted (PoissonProblem uses the Lanczos
  // estimates and says so): the simplicial factorisation is single-threaded, cannot be cancelled
  // and grows like n^2 in time (measured: 40564 dofs of a cleaved head, 15 M factor non-zeros,
  // 20 s). 0 = no limit.
  int64_t max_dofs = 20000;
};

struct SpectrumEstimate {
  double lambdaMin = std::numeric_limits<double>::quiet_NaN();
  double lambdaMax = std::numeric_limits<double>::quiet_NaN();
  double kappa = std::numeric_limits<double>::quiet_NaN(); // lambdaMax / lambdaMin
  bool converged = false;
  std::string method;      // which method (and tolerance) produced the numbers
  double tolerance = 0.0;  // relative tolerance of the method (0 = exact to rounding)
  int64_t operations = 0;  // products with the matrix + solves with the factorisation (Spectra),
                           // or Lanczos steps (lanczosEstimate)
};

// Extreme eigenvalues of the symmetric positive definite A (both triangles stored, compressed).
// Calls progress->checkCancel() between the two solves.
SpectrumEstimate spectraExtremes(const SparseMatrix& A, const ConditionParams& params, Progress* progress);

// D^-1/2 K D^-1/2 with D = diag(K) (unit diagonal). InputError if a diagonal entry is <= 0.
SparseMatrix jacobiScaled(const SparseMatrix& K);

// Both figures of DESIGN §6 with one factorisation: kappa(K) as spectraExtremes(K), and
// kappa(S), S = D^-1/2 K D^-1/2, with lambda_max(S) by Lanczos on S and lambda_min(S) by
// shift-invert at 0 using S^-1 = D^1/2 K^-1 D^1/2 (the same LDL^T factors of K).
struct ConditionPair {
  SpectrumEstimate matrix;  // of K
  SpectrumEstimate jacobi;  // of D^-1/2 K D^-1/2
};
ConditionPair spectraConditionNumbers(const SparseMatrix& K, const ConditionParams& params, Progress* progress);

// Extreme eigenvalues of the symmetric tridiagonal T_k (k = T.steps(), k-1 off-diagonals used),
// Sturm bisection. `what` describes the operator and run for SpectrumEstimate::method, e.g.
// "MINRES on M^-1 K, M = diag(K)". k = 0 gives NaNs and converged = false.
SpectrumEstimate lanczosEstimate(const LanczosTridiagonal& T, const std::string& what);

} // namespace tetflow
