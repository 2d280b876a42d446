#pragma once
// Sparse Cholesky factorisation of the reduced SPD system, K = L L^T (after a fill-reducing
// permutation), then solves of blocks of right-hand sides: the direct solver behind
// `solver = cholesky` (IterativeSolver.h). A lead field's transfer matrix, a MEG lead field and
// every tDCS montage on one mesh share K, so they pay for the factorisation once and then two
// triangular solves per right-hand side, many at a time (supernodal blocks: BLAS-3).
//
// Library: CHOLMOD (SuiteSparse; Debian libsuitesparse-dev), supernodal, 64-bit indices; METIS's
// nested dissection as the ordering from 50 000 unknowns on (below, CHOLMOD's default strategy:
// AMD, and METIS too when AMD's fill is high). K must be symmetric with both triangles stored (the lower one is read),
// compressed, column-major.
//
// Memory: analyze() computes the ordering and the factor's exact size (predicted bytes of L and
// the flops of the factorisation) before any numeric work; factorize() calls requireMemory()
// with that size and is refused, naming the system and what would fit, when it is over budget
// (MemoryBudget.h). Cancellation: the numeric factorisation (seconds to minutes, no callbacks in
// CHOLMOD) runs on a worker thread while the caller polls Progress::cancelRequested() every 20 ms;
// a cancelled factorisation returns (throws Cancelled) within that time and leaves its worker to
// finish and free its memory in the background. Errors: not positive definite (a column's pivot
// <= 0) is an InputError naming the column; CHOLMOD running out of memory is a ProcessingError.
#include <Eigen/Core>

#include <cstdint>
#include <memory>

#include "Algorithms/Core/Progress.h"
#include "Assembly.h"

namespace tetflow {

class SparseCholesky {
public:
  SparseCholesky();
  ~SparseCholesky();
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  // Ordering and symbolic factorisation of K (which need not outlive the call: it is copied).
  // InputError for a non-square or uncompressed matrix.
  void analyze(const SparseMatrix& K);
  // Numeric factorisation (analyze first); refused (InputError) before it starts when the factor
  // would not fit in memory, naming its size and the iterative solvers as the way out.
  void factorize(Progress& progress);

  // X = K^-1 B for a block of right-hand sides (B: n x k). Two triangular solves per column.
  // Solves on one factor are serialised (a factor may be shared, SolverCache.h). With `progress`
  // the solves run on a worker thread while the caller polls cancelRequested() every 20 ms, so a
  // block of many columns is cancelled within that time (throws Cancelled; the worker finishes
  // on its own copy of B in the background).
  void solve(const Eigen::MatrixXd& B, Eigen::MatrixXd& X, Progress* progress = nullptr) const;

  // True when K is exactly the matrix this factor was analysed from (size, pattern and values of
  // the lower triangle): one pass over K.
  bool sameMatrix(const SparseMatrix& K) const;

  bool factorized() const;
  int64_t rows() const;
  double factorBytes() const;    // bytes of L (exact after analyze)
  double factorNonzeros() const; // nnz(L)
  double flops() const;          // of the factorisation (CHOLMOD's count)
  const char* ordering() const;  // "amd", "metis", "nesdis", "natural", ... (after analyze)
  double analyzeSeconds() const;
  double factorizeSeconds() const;

  // Bytes needed besides L while solving k right-hand sides of n unknowns (B, X and CHOLMOD's
  // workspace).
  static double solveBytes(int64_t n, int64_t k);

  struct State; // CHOLMOD's objects (SparseCholesky.cpp)

private:
  std::shared_ptr<State> s_; // shared with a factorisation worker that may outlive a cancel
};

} // namespace tetflow
