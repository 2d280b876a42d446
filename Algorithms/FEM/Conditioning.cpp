#include "Conditioning.h"

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>
#include <Spectra/SymEigsShiftSolver.h>
#include <Spectra/SymEigsSolver.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "Algorithms/Core/Errors.h"

namespace tetflow {

namespace {

// y = A x through TetFlow's parallel symmetric product (Spectra matrix-operation concept).
class ParallelSymProduct {
public:
  using Scalar = double;
  explicit ParallelSymProduct(const SparseMatrix& A) : A_(A) {}
  Eigen::Index rows() const { return A_.rows(); }
  Eigen::Index cols() const { return A_.cols(); }
  void perform_op(const double* x, double* y) const { multiplySymmetric(A_, x, y); }

private:
  const SparseMatrix& A_;
};

using Ldlt = Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower>;

// y = A^-1 x for A = diag(s)^-1 K diag(s)^-1 from the LDL^T factors of K:
// y = s .* K^-1 (s .* x) (s empty: A = K; s = sqrt(diag K): A = D^-1/2 K D^-1/2). Spectra shift-solve concept; only the shift 0 is used.
class FactoredInverse {
public:
  using Scalar = double;
  FactoredInverse(const Ldlt& ldlt, Eigen::Index n, const Eigen::VectorXd& s) : ldlt_(ldlt), n_(n), s_(s) {}
  Eigen::Index rows() const { return n_; }
  Eigen::Index cols() const { return n_; }
  void set_shift(double sigma) {
    if (sigma != 0.0) throw ProcessingError("shift-invert: only the shift 0 is supported");
  }
  void perform_op(const double* x, double* y) const {
    Eigen::Map<const Eigen::VectorXd> xm(x, n_);
    Eigen::Map<Eigen::VectorXd> ym(y, n_);
    if (s_.size() == 0) {
      ym = ldlt_.solve(xm);
    } else {
      const Eigen::VectorXd sx = s_.cwiseProduct(xm);
      ym = s_.cwiseProduct(ldlt_.solve(sx));
    }
  }

private:
  const Ldlt& ldlt_;
  Eigen::Index n_;
  const Eigen::VectorXd& s_;
};

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

SpectrumEstimate denseExtremes(const SparseMatrix& A, const ConditionParams& params) {
  SpectrumEstimate est;
  const Eigen::Index n = A.rows();
  Eigen::MatrixXd dense = Eigen::MatrixXd(A);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(dense, Eigen::EigenvaluesOnly);
  est.lambdaMin = es.eigenvalues()[0];
  est.lambdaMax = es.eigenvalues()[n - 1];
  est.kappa = est.lambdaMax / est.lambdaMin;
  est.converged = es.info() == Eigen::Success;
  est.tolerance = 0.0;
  est.method = "dense Eigen::SelfAdjointEigenSolver (n = " + std::to_string(n) + " <= " +
               std::to_string(params.dense_limit) + "), exact to rounding";
  return est;
}

// lambda_max by Lanczos on A, lambda_min by shift-invert at 0 through `inverse` (nullptr when
// the factorisation failed). `inverseText` names how A^-1 is applied.
SpectrumEstimate spectraRun(const SparseMatrix& A, const FactoredInverse* inverse, const std::string& inverseText,
                            const std::string& factorFailure, const ConditionParams& params, Progress* progress) {
  SpectrumEstimate est;
  const Eigen::Index n = A.rows();
  const Eigen::Index ncv = std::min<Eigen::Index>(std::max<int64_t>(params.ncv, 3), n);
  est.tolerance = params.tolerance;
  bool okMax = false, okMin = false;
  std::string failMax, failMin;
  {
    ParallelSymProduct op(A);
    Spectra::SymEigsSolver<ParallelSymProduct> eigs(op, 1, ncv);
    eigs.init();
    eigs.compute(Spectra::SortRule::LargestAlge, params.max_restarts, params.tolerance);
    est.operations += eigs.num_operations();
    if (eigs.info() == Spectra::CompInfo::Successful) {
      est.lambdaMax = eigs.eigenvalues()[0];
      okMax = true;
    } else {
      failMax = " (NOT converged)";
    }
  }
  if (progress) progress->checkCancel();
  if (inverse) {
    FactoredInverse op = *inverse;
    Spectra::SymEigsShiftSolver<FactoredInverse> eigs(op, 1, ncv, 0.0);
    eigs.init();
    eigs.compute(Spectra::SortRule::LargestMagn, params.max_restarts, params.tolerance);
    est.operations += eigs.num_operations();
    if (eigs.info() == Spectra::CompInfo::Successful) {
      est.lambdaMin = eigs.eigenvalues()[0];
      okMin = true;
    } else {
      failMin = " (NOT converged)";
    }
  } else {
    failMin = " (failed: ";
    failMin += factorFailure;
    failMin += ")";
  }
  est.converged = okMax && okMin;
  if (est.converged) est.kappa = est.lambdaMax / est.lambdaMin;
  std::string m = "Spectra SymEigsSolver (restarted Lanczos, ncv ";
  m += std::to_string(ncv);
  m += ") for lambda_max";
  m += failMax;
  m += "; Spectra SymEigsShiftSolver (shift-invert at 0, ";
  m += inverseText;
  m += ") for lambda_min";
  m += failMin;
  m += "; relative tol ";
  m += fmt(params.tolerance);
  est.method = m;
  return est;
}

void checkSquareCompressed(const SparseMatrix& A) {
  if (A.rows() != A.cols()) throw InputError("condition number: the matrix is not square");
  if (!A.isCompressed()) throw InputError("condition number: the matrix must be compressed");
}

} // namespace

SpectrumEstimate spectraExtremes(const SparseMatrix& A, const ConditionParams& params, Progress* progress) {
  checkSquareCompressed(A);
  const Eigen::Index n = A.rows();
  if (n == 0) {
    SpectrumEstimate est;
    est.method = "empty matrix";
    return est;
  }
  if (n <= params.dense_limit || n < 3) return denseExtremes(A, params);
  Ldlt ldlt;
  ldlt.compute(A);
  const Eigen::VectorXd none;
  const FactoredInverse inv(ldlt, n, none);
  const bool ok = ldlt.info() == Eigen::Success;
  return spectraRun(A, ok ? &inv : nullptr, "Eigen SimplicialLDLT", "sparse LDL^T factorisation failed",
                    params, progress);
}

ConditionPair spectraConditionNumbers(const SparseMatrix& K, const ConditionParams& params, Progress* progress) {
  checkSquareCompressed(K);
  ConditionPair out;
  const Eigen::Index n = K.rows();
  if (n == 0) {
    out.matrix.method = out.jacobi.method = "empty matrix";
    return out;
  }
  const SparseMatrix S = jacobiScaled(K);
  if (n <= params.dense_limit || n < 3) {
    out.matrix = denseExtremes(K, params);
    out.jacobi = denseExtremes(S, params);
    return out;
  }
  Ldlt ldlt;
  ldlt.compute(K);
  const bool ok = ldlt.info() == Eigen::Success;
  if (progress) progress->checkCancel();
  const Eigen::VectorXd none;
  const Eigen::VectorXd sqrtD = K.diagonal().cwiseSqrt();
  const FactoredInverse invK(ldlt, n, none), invS(ldlt, n, sqrtD);
  const std::string failure = "sparse LDL^T factorisation of K failed";
  out.matrix = spectraRun(K, ok ? &invK : nullptr, "Eigen SimplicialLDLT", failure, params, progress);
  if (progress) progress->report(0.5);
  out.jacobi = spectraRun(S, ok ? &invS : nullptr, "S^-1 = D^1/2 K^-1 D^1/2 with Eigen SimplicialLDLT of K",
                          failure, params, progress);
  return out;
}

SparseMatrix jacobiScaled(const SparseMatrix& K) {
  if (!K.isCompressed()) throw InputError("jacobiScaled: the matrix must be compressed");
  const Eigen::VectorXd d = K.diagonal();
  Eigen::VectorXd s(d.size());
  for (Eigen::Index i = 0; i < d.size(); ++i) {
    if (!(d[i] > 0)) {
      std::ostringstream m;
      m << "Jacobi scaling: diagonal entry " << i << " is " << d[i] << "; it must be > 0";
      throw InputError(m.str());
    }
    s[i] = 1.0 / std::sqrt(d[i]);
  }
  SparseMatrix S = K;
  const int64_t n = S.cols();
  int* outer = S.outerIndexPtr();
  int* inner = S.innerIndexPtr();
  double* val = S.valuePtr();
#pragma omp parallel for schedule(static)
  for (int64_t j = 0; j < n; ++j)
    for (int p = outer[j]; p < outer[j + 1]; ++p) val[p] *= s[inner[p]] * s[j];
  return S;
}

namespace {
// Number of eigenvalues of T_k below x (Sturm sequence of the LDL^T pivots).
int64_t sturmCount(const std::vector<double>& d, const std::vector<double>& e, size_t k, double x) {
  int64_t count = 0;
  double q = 1.0;
  for (size_t i = 0; i < k; ++i) {
    const double e2 = i == 0 ? 0.0 : e[i - 1] * e[i - 1];
    q = d[i] - x - (i == 0 ? 0.0 : e2 / q);
    if (q == 0.0) q = -1e-300; // x is an eigenvalue of the leading block: perturb
    if (q < 0) ++count;
  }
  return count;
}
} // namespace

SpectrumEstimate lanczosEstimate(const LanczosTridiagonal& T, const std::string& what) {
  SpectrumEstimate est;
  const size_t k = T.steps();
  est.operations = int64_t(k);
  est.tolerance = 0.0;
  std::string m = "Ritz values of the Lanczos tridiagonal of ";
  m += what;
  m += " (";
  m += std::to_string(k);
  m += " steps, Sturm bisection): a lower bound of kappa";
  est.method = m;
  if (k == 0) return est;
  const auto& d = T.diagonal;
  const auto& e = T.offDiagonal;
  double lo = d[0], hi = d[0];
  for (size_t i = 0; i < k; ++i) {
    const double r = (i > 0 ? std::abs(e[i - 1]) : 0.0) + (i + 1 < k ? std::abs(e[i]) : 0.0);
    lo = std::min(lo, d[i] - r);
    hi = std::max(hi, d[i] + r);
  }
  auto bisect = [&](int64_t target) { // smallest x with count(x) >= target
    double a = lo, b = hi + std::abs(hi) * 1e-15 + 1e-300;
    for (int it = 0; it < 200; ++it) {
      const double mid = 0.5 * (a + b);
      if (mid <= a || mid >= b) break;
      if (sturmCount(d, e, k, mid) >= target)
        b = mid;
      else
        a = mid;
    }
    return 0.5 * (a + b);
  };
  est.lambdaMin = bisect(1);
  est.lambdaMax = bisect(int64_t(k));
  est.kappa = est.lambdaMax / est.lambdaMin;
  est.converged = std::isfinite(est.kappa) && est.lambdaMin > 0;
  return est;
}

} // namespace tetflow
