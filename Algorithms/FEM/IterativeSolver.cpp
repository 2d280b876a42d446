#include "IterativeSolver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Petsc/PetscLinearSolver.h"
#include "SolverCache.h"
#include "SolverChoice.h"
#include "SparseCholesky.h"

namespace tetflow {

namespace {
constexpr std::pair<SolverKind, const char*> kSolverNames[] = {
    {SolverKind::Minres, "minres"}, {SolverKind::Cg, "cg"}, {SolverKind::Cholesky, "cholesky"}, {SolverKind::Auto, "auto"}};
constexpr std::pair<PreconditionerKind, const char*> kPrecNames[] = {
    {PreconditionerKind::Jacobi, "jacobi"},
    {PreconditionerKind::None, "none"},
    {PreconditionerKind::Gamg, "gamg"},
    {PreconditionerKind::Hypre, "hypre"}};
constexpr std::pair<SolverBackend, const char*> kBackendNames[] = {{SolverBackend::Eigen, "eigen"},
                                                                   {SolverBackend::Petsc, "petsc"}};
constexpr std::pair<SolverStatus, const char*> kStatusNames[] = {
    {SolverStatus::NotRun, "not_run"},
    {SolverStatus::Converged, "converged"},
    {SolverStatus::MaxIterations, "max_iterations"},
    {SolverStatus::Breakdown, "breakdown"}};

template <class E, size_t N>
E fromName(const std::pair<E, const char*> (&table)[N], const std::string& name, const char* what) {
  for (const auto& [e, n] : table)
    if (name == n) return e;
  std::string msg = what;
  msg += " '";
  msg += name;
  msg += "' is unknown; use one of:";
  for (const auto& [e, n] : table) {
    msg += ' ';
    msg += n;
  }
  throw InputError(msg);
}
template <class E, size_t N>
const char* toName(const std::pair<E, const char*> (&table)[N], E v) {
  for (const auto& [e, n] : table)
    if (e == v) return n;
  return "?";
}

} // namespace

const char* solverKindName(SolverKind k) { return toName(kSolverNames, k); }
SolverKind solverKindFromName(const std::string& n) { return fromName(kSolverNames, n, "solver"); }
const char* preconditionerKindName(PreconditionerKind k) { return toName(kPrecNames, k); }
PreconditionerKind preconditionerKindFromName(const std::string& n) {
  return fromName(kPrecNames, n, "preconditioner");
}
const char* solverStatusName(SolverStatus s) { return toName(kStatusNames, s); }
const char* solverBackendName(SolverBackend b) { return toName(kBackendNames, b); }
SolverBackend solverBackendFromName(const std::string& n) { return fromName(kBackendNames, n, "solver_backend"); }

void SolverParams::validate() const {
  if (!(tolerance > 0.0 && tolerance < 1.0)) {
    std::ostringstream m;
    m << "tolerance = " << tolerance << ": must be in (0, 1)";
    throw InputError(m.str());
  }
  if (max_iterations < 1) throw InputError("max_iterations = " + std::to_string(max_iterations) + ": must be >= 1");
  const bool amg = preconditioner == PreconditionerKind::Gamg || preconditioner == PreconditionerKind::Hypre;
  if (kind == SolverKind::Cholesky && backend == SolverBackend::Petsc)
    throw InputError("solver = cholesky runs in this process (CHOLMOD): set solver_backend = eigen, or use "
                     "minres or cg with solver_backend = petsc");
  if (amg && backend != SolverBackend::Petsc && kind != SolverKind::Cholesky)
    throw InputError(std::string("preconditioner ") + preconditionerKindName(preconditioner) +
                     " is PETSc's algebraic multigrid: set solver_backend = petsc, or use jacobi or "
                     "none with solver_backend = eigen");
  if (backend == SolverBackend::Petsc && !petscAvailable())
    throw InputError("solver_backend = petsc: this TetFlow was built without PETSc; install "
                     "libpetsc-real-dev (scripts/setup.sh does) and reconfigure with "
                     "-DTETFLOW_WITH_PETSC=ON, or use solver_backend = eigen");
}

bool IterativeSolver::step(int64_t k, double relres) {
  iterations_ = k;
  relres_ = relres;
  history_.push_back(relres);
  if (monitor_) monitor_(k, relres);
  if (progress_) {
    progress_->checkCancel();
    if (reportFraction_ && (k & 7) == 0) {
      const double frac = relres > 0 ? std::log(relres) / std::log(params_.tolerance) : 1.0;
      progress_->report(std::clamp(frac, 0.0, 1.0));
    }
  }
  return relres <= params_.tolerance;
}

void IterativeSolver::checkOperator(Eigen::Index rhsRows) const {
  if (!K_) throw InputError("IterativeSolver: no operator set");
  const SparseMatrix& K = *K_;
  if (K.rows() != K.cols()) throw InputError("IterativeSolver: the matrix is not square");
  if (!K.isCompressed()) throw InputError("IterativeSolver: the matrix must be compressed");
  if (rhsRows != K.rows())
    throw InputError("IterativeSolver: right-hand side has " + std::to_string(rhsRows) +
                     " entries for a matrix of size " + std::to_string(K.rows()));
}

void IterativeSolver::resetSetUp() {
  petsc_.reset();
  cholesky_.reset();
  reused_ = false;
  choiceNote_.clear();
  if (requested_.kind == SolverKind::Auto) params_ = requested_;
}

void IterativeSolver::setCostModel(const SolverCostModel& m) {
  model_ = std::make_shared<const SolverCostModel>(m);
  resetSetUp();
}

void IterativeSolver::choose() {
  if (params_.kind != SolverKind::Auto) return;
  params_.validate();
  checkOperator(K_ ? K_->rows() : 0);
  NullProgress none;
  SolverChoice c = chooseSolver(*K_, params_, rightHandSides_, progress_ ? *progress_ : none,
                                model_ ? *model_ : SolverCostModel());
  params_.kind = c.kind;
  params_.preconditioner = c.preconditioner;
  params_.backend = c.backend;
  cholesky_ = c.factor;
  reused_ = c.reused;
  choiceNote_ = c.note;
}

double IterativeSolver::setUp() {
  params_.validate();
  const auto t0 = std::chrono::steady_clock::now();
  choose();
  if (params_.backend == SolverBackend::Petsc) {
    checkOperator(K_ ? K_->rows() : 0);
    if (petsc_ && petsc_->sameSystem(*K_, params_)) return 0.0;
    petsc_.reset(); // release the old system on every rank before distributing the new one
    petsc_ = std::make_shared<PetscLinearSolver>(*K_, params_);
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  if (!direct() || (cholesky_ && cholesky_->factorized())) return 0.0;
  checkOperator(K_ ? K_->rows() : 0);
  NullProgress none;
  Progress& progress = progress_ ? *progress_ : none;
  if (!cholesky_) {
    if (auto kept = solver_cache::findCholesky(*K_)) {
      cholesky_ = kept;
      reused_ = true;
      return 0.0;
    }
    auto f = std::make_shared<SparseCholesky>();
    f->analyze(*K_);
    progress.checkCancel();
    cholesky_ = f;
  }
  cholesky_->factorize(progress);
  solver_cache::keepCholesky(cholesky_);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void IterativeSolver::solveBlock(const Eigen::MatrixXd& B, Eigen::MatrixXd& X) {
  const auto t0 = std::chrono::steady_clock::now();
  if (K_) choose();
  if (!direct())
    throw InputError(std::string("IterativeSolver: solveBlock needs solver = cholesky (not ") +
                     solverKindName(params_.kind) + ")");
  checkOperator(B.rows());
  setUp();
  cholesky_->solve(B, X, progress_);
  status_ = SolverStatus::Converged;
  iterations_ = 0;
  history_.assign(1, 1.0);
  lanczos_ = {};
  trueRes_ = 0.0;
  if (B.cols() > 0) {
    // ||b - K x|| / ||b|| per column, the worst reported; K X by columns in parallel.
    std::vector<double> res(size_t(B.cols()), 0.0);
#pragma omp parallel for schedule(dynamic, 1)
    for (Eigen::Index j = 0; j < B.cols(); ++j) {
      const double bnorm = B.col(j).norm();
      if (bnorm > 0) res[size_t(j)] = (B.col(j) - (*K_) * X.col(j)).norm() / bnorm;
    }
    for (double r : res) trueRes_ = std::max(trueRes_, r);
  }
  relres_ = trueRes_;
  seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void IterativeSolver::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  const auto t0 = std::chrono::steady_clock::now();
  params_.validate();
  checkOperator(b.size());
  choose();
  const SparseMatrix& K = *K_;
  const Eigen::Index n = K.rows();
  if (direct()) {
    Eigen::MatrixXd X;
    solveBlock(b, X);
    x = X.col(0);
    seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return;
  }
  if (params_.backend == SolverBackend::Petsc) {
    solvePetsc(b, x);
    seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return;
  }
  Eigen::VectorXd minv;
  if (params_.preconditioner == PreconditionerKind::Jacobi) {
    minv = K.diagonal();
    for (Eigen::Index i = 0; i < n; ++i) {
      if (!(minv[i] > 0) || !std::isfinite(minv[i])) {
        std::ostringstream m;
        m << "Jacobi preconditioner: diagonal entry " << i << " is " << minv[i]
          << "; the matrix must have a positive diagonal";
        throw InputError(m.str());
      }
      minv[i] = 1.0 / minv[i];
    }
  }
  status_ = SolverStatus::NotRun;
  iterations_ = 0;
  relres_ = 0.0;
  trueRes_ = 0.0;
  history_.clear();
  lanczos_ = {};
  x = Eigen::VectorXd::Zero(n);

  if (params_.kind == SolverKind::Minres)
    runMinres(b, x, minv);
  else
    runCg(b, x, minv);

  const double bnorm = b.norm();
  if (bnorm > 0) {
    Eigen::VectorXd kx;
    multiplySymmetric(K, x, kx);
    trueRes_ = (b - kx).norm() / bnorm;
  }
  seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

int IterativeSolver::ranks() const { return petsc_ ? petsc_->ranks() : 1; }

void IterativeSolver::solvePetsc(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  setUp(); // first solve, or other params: distribute and set up (else nothing)
  const PetscLinearSolver::Outcome o = petsc_->solve(b, x, progress_, reportFraction_);
  status_ = o.status;
  iterations_ = o.iterations;
  relres_ = o.relativeResidual;
  history_ = o.history;
  kspEigenMin_ = o.eigenMin;
  kspEigenMax_ = o.eigenMax;
  lanczos_ = {};
  if (monitor_)
    for (size_t k = 1; k < history_.size(); ++k) monitor_(int64_t(k), history_[k]);
  trueRes_ = 0.0;
  const double bnorm = b.norm();
  if (bnorm > 0) {
    Eigen::VectorXd kx;
    multiplySymmetric(*K_, x, kx);
    trueRes_ = (b - kx).norm() / bnorm;
  }
}

namespace {
// Vector kernels over fixed chunks of kChunk entries, chunks in parallel (OpenMP). Reductions
// form one partial sum per chunk and add the partials in chunk order, so every result is
// bitwise independent of the number of threads.
constexpr int64_t kChunk = 4096;

template <class F>
void chunkedFor(int64_t n, F&& f) {
  const int64_t nc = (n + kChunk - 1) / kChunk;
#pragma omp parallel for schedule(static) if (nc > 8)
  for (int64_t c = 0; c < nc; ++c) f(c * kChunk, std::min(n, (c + 1) * kChunk));
}

template <class F>
double chunkedSum(int64_t n, std::vector<double>& partial, F&& f) {
  const int64_t nc = (n + kChunk - 1) / kChunk;
  partial.resize(size_t(nc));
#pragma omp parallel for schedule(static) if (nc > 8)
  for (int64_t c = 0; c < nc; ++c) partial[size_t(c)] = f(c * kChunk, std::min(n, (c + 1) * kChunk));
  double sum = 0.0;
  for (double p : partial) sum += p;
  return sum;
}
} // namespace

void IterativeSolver::runMinres(const Eigen::VectorXd& b, Eigen::VectorXd& x, const Eigen::VectorXd& minv) {
  const SparseMatrix& K = *K_;
  const int64_t n = K.rows();
  const double* mv = minv.size() ? minv.data() : nullptr; // nullptr: M = I
  Eigen::VectorXd r1 = b, r2(n), y(n), v(n), w = Eigen::VectorXd::Zero(n), w1 = Eigen::VectorXd::Zero(n),
                  w2 = Eigen::VectorXd::Zero(n);
  std::vector<double> part;
  // y = M^-1 r1, beta1^2 = r1 . y
  double beta1 = chunkedSum(n, part, [&](int64_t i0, int64_t i1) {
    double acc = 0.0;
    for (int64_t i = i0; i < i1; ++i) {
      y[i] = mv ? mv[i] * r1[i] : r1[i];
      acc += r1[i] * y[i];
    }
    return acc;
  });
  if (beta1 < 0) {
    status_ = SolverStatus::Breakdown;
    return;
  }
  history_.push_back(beta1 > 0 ? 1.0 : 0.0);
  if (beta1 == 0) {
    status_ = SolverStatus::Converged;
    return;
  }
  beta1 = std::sqrt(beta1);
  double oldb = 0, beta = beta1, dbar = 0, epsln = 0, phibar = beta1, cs = -1, sn = 0;
  r2 = r1;
  status_ = SolverStatus::MaxIterations;
  lanczos_.diagonal.reserve(size_t(std::min<int64_t>(params_.max_iterations, 1 << 20)));
  for (int64_t k = 1; k <= params_.max_iterations; ++k) {
    // Lanczos step: v_k = y / beta_k, y = K v_k - (beta_k/beta_{k-1}) r_{k-1} - (alpha_k/beta_k) r_k.
    const double sc = 1.0 / beta;
    chunkedFor(n, [&](int64_t i0, int64_t i1) {
      for (int64_t i = i0; i < i1; ++i) v[i] = sc * y[i];
    });
    multiplySymmetric(K, v, y);
    const double c1 = k >= 2 ? beta / oldb : 0.0;
    const double alfa = chunkedSum(n, part, [&](int64_t i0, int64_t i1) {
      double acc = 0.0;
      for (int64_t i = i0; i < i1; ++i) {
        y[i] -= c1 * r1[i];
        acc += v[i] * y[i];
      }
      return acc;
    });
    const double c2 = alfa / beta;
    r1.swap(r2); // r1 = r_k; r2 is overwritten with r_{k+1} = y - c2 r_k, y = M^-1 r_{k+1}
    const double beta2 = chunkedSum(n, part, [&](int64_t i0, int64_t i1) {
      double acc = 0.0;
      for (int64_t i = i0; i < i1; ++i) {
        const double t = y[i] - c2 * r1[i];
        r2[i] = t;
        const double z = mv ? mv[i] * t : t;
        y[i] = z;
        acc += t * z;
      }
      return acc;
    });
    oldb = beta;
    if (beta2 < 0) {
      status_ = SolverStatus::Breakdown;
      break;
    }
    beta = std::sqrt(beta2);
    lanczos_.diagonal.push_back(alfa);
    lanczos_.offDiagonal.push_back(beta);
    // Apply the previous rotation, then make the next one (QR of the tridiagonal).
    const double oldeps = epsln;
    const double delta = cs * dbar + sn * alfa;
    const double gbar = sn * dbar - cs * alfa;
    epsln = sn * beta;
    dbar = -cs * beta;
    const double gamma = std::max(std::hypot(gbar, beta), std::numeric_limits<double>::min());
    cs = gbar / gamma;
    sn = beta / gamma;
    const double phi = cs * phibar;
    phibar = sn * phibar;
    // Solution update: w_k = (v_k - eps_k w_{k-2} - delta_k w_{k-1}) / gamma_k, x += phi_k w_k.
    w1.swap(w2);
    w2.swap(w);
    const double ginv = 1.0 / gamma;
    chunkedFor(n, [&](int64_t i0, int64_t i1) {
      for (int64_t i = i0; i < i1; ++i) {
        const double wi = (v[i] - oldeps * w1[i] - delta * w2[i]) * ginv;
        w[i] = wi;
        x[i] += phi * wi;
      }
    });
    if (step(k, phibar / beta1)) {
      status_ = SolverStatus::Converged;
      break;
    }
    if (beta == 0) { // invariant subspace without a small residual: cannot continue
      status_ = SolverStatus::Breakdown;
      break;
    }
  }
}

void IterativeSolver::runCg(const Eigen::VectorXd& b, Eigen::VectorXd& x, const Eigen::VectorXd& minv) {
  const SparseMatrix& K = *K_;
  const int64_t n = K.rows();
  const double* mv = minv.size() ? minv.data() : nullptr;
  Eigen::VectorXd r = b, z(n), p(n), q(n);
  std::vector<double> part;
  double rz = chunkedSum(n, part, [&](int64_t i0, int64_t i1) {
    double acc = 0.0;
    for (int64_t i = i0; i < i1; ++i) {
      z[i] = mv ? mv[i] * r[i] : r[i];
      acc += r[i] * z[i];
    }
    return acc;
  });
  if (rz < 0) {
    status_ = SolverStatus::Breakdown;
    return;
  }
  history_.push_back(rz > 0 ? 1.0 : 0.0);
  if (rz == 0) {
    status_ = SolverStatus::Converged;
    return;
  }
  const double rz0 = rz;
  p = z;
  double prevAlpha = 0, prevBeta = 0;
  status_ = SolverStatus::MaxIterations;
  for (int64_t k = 1; k <= params_.max_iterations; ++k) {
    multiplySymmetric(K, p, q);
    const double pq = chunkedSum(n, part, [&](int64_t i0, int64_t i1) {
      double acc = 0.0;
      for (int64_t i = i0; i < i1; ++i) acc += p[i] * q[i];
      return acc;
    });
    if (!(pq > 0)) {
      status_ = SolverStatus::Breakdown;
      break;
    }
    const double alpha = rz / pq;
    const double rzNew = chunkedSum(n, part, [&](int64_t i0, int64_t i1) {
      double acc = 0.0;
      for (int64_t i = i0; i < i1; ++i) {
        x[i] += alpha * p[i];
        r[i] -= alpha * q[i];
        z[i] = mv ? mv[i] * r[i] : r[i];
        acc += r[i] * z[i];
      }
      return acc;
    });
    if (rzNew < 0) {
      status_ = SolverStatus::Breakdown;
      break;
    }
    const double beta = rzNew / rz;
    // Lanczos tridiagonal from the CG coefficients (Saad, Iterative Methods, §6.7.3).
    lanczos_.diagonal.push_back(k == 1 ? 1.0 / alpha : 1.0 / alpha + prevBeta / prevAlpha);
    lanczos_.offDiagonal.push_back(std::sqrt(beta) / alpha);
    if (step(k, std::sqrt(rzNew / rz0))) {
      status_ = SolverStatus::Converged;
      break;
    }
    chunkedFor(n, [&](int64_t i0, int64_t i1) {
      for (int64_t i = i0; i < i1; ++i) p[i] = z[i] + beta * p[i];
    });
    rz = rzNew;
    prevAlpha = alpha;
    prevBeta = beta;
  }
}

} // namespace tetflow
