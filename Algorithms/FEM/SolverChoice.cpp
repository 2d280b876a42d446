#include "SolverChoice.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "Algorithms/Core/MemoryBudget.h"
#include "Petsc/PetscLinearSolver.h"
#include "SolverCache.h"
#include "SparseCholesky.h"

namespace tetflow {

double SolverCostModel::iterations(int64_t n, double tolerance) const {
  const double digits = std::log(std::max(tolerance, 1e-300)) / std::log(1e-8);
  return std::max(1.0, iterationConstant * std::cbrt(double(n)) * digits);
}

double SolverCostModel::iterativeSeconds(int64_t n, int64_t nnzK, int64_t k, double tolerance) const {
  return double(k) * iterations(n, tolerance) * (2.0 * double(nnzK) + 12.0 * double(n)) / matvecRate;
}

double SolverCostModel::choleskySeconds(double flops, double factorNonzeros, int64_t k) const {
  return flops / factorRate + double(k) * 4.0 * factorNonzeros / solveRate;
}

double SolverCostModel::amgSeconds(int64_t nnzK, int64_t k, double tolerance) const {
  const double digits = std::log(std::max(tolerance, 1e-300)) / std::log(1e-8);
  return double(nnzK) * (amgSetupPerNonzero + double(k) * amgSolvePerNonzero * std::max(digits, 0.1));
}

double SolverCostModel::predictedFactorNonzeros(int64_t n) { return 4.5 * std::pow(double(n), 4.0 / 3.0); }
double SolverCostModel::predictedFlops(int64_t n) { return 1.9 * double(n) * double(n); }

namespace {
std::string seconds(double s) {
  std::ostringstream o;
  o.precision(s < 10 ? 2 : 3);
  o << s << " s";
  return o.str();
}
} // namespace

SolverChoice chooseSolver(const SparseMatrix& K, const SolverParams& p, int64_t k, Progress& progress,
                          const SolverCostModel& model) {
  SolverChoice c;
  c.preconditioner = p.preconditioner;
  c.backend = p.backend;
  k = std::max<int64_t>(1, k);
  const std::string minresName = std::string("minres + ") + preconditionerKindName(p.preconditioner);
  const std::string solves = std::to_string(k) + (k == 1 ? " solve" : " solves");
  if (p.backend == SolverBackend::Petsc) {
    c.kind = SolverKind::Minres;
    c.note = "auto: " + minresName + " (solver_backend petsc: cholesky runs in one process only)";
    return c;
  }
  if (auto f = solver_cache::findCholesky(K)) {
    c.kind = SolverKind::Cholesky;
    c.factor = f;
    c.reused = true;
    c.note = "auto: cholesky (the factor of this system is kept from an earlier solve: no set-up)";
    return c;
  }
  const int64_t n = K.rows(), nnzK = K.nonZeros();
  // The faster iterative candidate.
  c.predictedMinresSeconds = model.iterativeSeconds(n, nnzK, k, p.tolerance);
  const bool amg = model.amgAvailable && petscAvailable();
  c.predictedAmgSeconds = amg ? model.amgSeconds(nnzK, k, p.tolerance) : std::numeric_limits<double>::infinity();
  const bool amgFaster = c.predictedAmgSeconds < c.predictedMinresSeconds;
  const double tIter = amgFaster ? c.predictedAmgSeconds : c.predictedMinresSeconds;
  const std::string iterName = amgFaster ? std::string("cg + hypre") : minresName;
  c.predictedIterativeSeconds = tIter;
  // The other iterative candidate's prediction, for the note.
  std::string also;
  if (amg) {
    std::ostringstream a;
    a << "; " << (amgFaster ? minresName : std::string("cg + hypre")) << " "
      << seconds(amgFaster ? c.predictedMinresSeconds : c.predictedAmgSeconds);
    also = a.str();
  }
  auto takeIterative = [&](const std::string& why) {
    if (amgFaster) {
      c.kind = SolverKind::Cg;
      c.preconditioner = PreconditionerKind::Hypre;
      c.backend = SolverBackend::Petsc;
    } else {
      c.kind = SolverKind::Minres;
    }
    c.note = "auto: " + iterName + (amgFaster ? " (PETSc, one process; " : " (") + why + also + ")";
  };
  const int64_t avail = memoryAvailable();
  {
    const double nnzL = SolverCostModel::predictedFactorNonzeros(n);
    const double bytes = 8.0 * nnzL;
    const double tChol = double(n) / model.analyzeRate +
                         model.choleskySeconds(SolverCostModel::predictedFlops(n), nnzL, k);
    c.predictedCholeskySeconds = tChol;
    std::ostringstream why;
    if (bytes > 2.0 * double(avail))
      why << "the Cholesky factor would need ~" << formatBytes(bytes) << ", " << formatBytes(double(avail))
          << " available; predicted " << seconds(tIter) << " for " << solves;
    else if (tChol > 3.0 * tIter)
      why << "predicted " << seconds(tChol) << " for cholesky against " << seconds(tIter) << " for " << solves;
    if (!why.str().empty()) {
      takeIterative(why.str());
      return c;
    }
  }
  auto f = std::make_shared<SparseCholesky>();
  f->analyze(K);
  progress.checkCancel();
  const double need = f->factorBytes() + SparseCholesky::solveBytes(n, std::min<int64_t>(k, 16)) + 64.0 * double(n);
  const double tChol = model.choleskySeconds(f->flops(), f->factorNonzeros(), k);
  c.predictedCholeskySeconds = tChol + f->analyzeSeconds();
  std::ostringstream why;
  const std::string analysis = "; analysis " + seconds(f->analyzeSeconds());
  if (need > double(avail)) {
    why << "the Cholesky factor needs " << formatBytes(f->factorBytes()) << ", " << formatBytes(double(avail))
        << " available; predicted " << seconds(tIter) << " for " << solves << analysis;
    takeIterative(why.str());
  } else if (tChol > tIter) {
    why << "predicted " << seconds(tChol) << " for cholesky against " << seconds(tIter) << " for " << solves
        << analysis;
    takeIterative(why.str());
  } else {
    why << "factor " << formatBytes(f->factorBytes()) << " of " << formatBytes(double(avail)) << " available; predicted "
        << seconds(tChol) << " against " << seconds(tIter) << " for " << solves << " of " << iterName << analysis;
    c.kind = SolverKind::Cholesky;
    c.factor = f;
    c.note = "auto: cholesky (" + why.str() + ")";
  }
  return c;
}

} // namespace tetflow
