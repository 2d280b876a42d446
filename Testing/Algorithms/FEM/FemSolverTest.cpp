// MINRES / CG (Algorithms/FEM/IterativeSolver.h) and conditioning (Conditioning.h).
#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Dense>
#include <unsupported/Eigen/IterativeSolvers>

#include <cmath>

#include "Algorithms/FEM/Conditioning.h"
#include "Algorithms/FEM/PoissonProblem.h"
#include "FemTestMeshes.h"
#include "TestUtil.h"

using namespace tetflow;
using tetflow::test::checkerElectrodeSystem;

namespace {

// ||r||_{M^-1} / ||b||_{M^-1} computed from scratch.
double preconditionedRelres(const SparseMatrix& K, const Eigen::VectorXd& b, const Eigen::VectorXd& x, bool jacobi) {
  const Eigen::VectorXd r = b - K * x;
  const Eigen::VectorXd minv = jacobi ? Eigen::VectorXd(K.diagonal().cwiseInverse())
                                      : Eigen::VectorXd::Ones(K.rows());
  return std::sqrt(r.dot(minv.cwiseProduct(r)) / b.dot(minv.cwiseProduct(b)));
}

} // namespace

TEST(FemSolver, MinresIterationCountMatchesEigensMinres) {
  // Eigen's unsupported MINRES stops when ||b||_2 * prod |s_k| < tol ||b||_2, i.e. on the same
  // preconditioned relative residual as ours (prod |s_k| = ||r_k||_{M^-1} / ||b||_{M^-1}), but
  // it does not count the iteration in which it stops: ours = Eigen's + 1.
  for (unsigned seed : {3u, 4u}) {
    const ReducedSystem sys = checkerElectrodeSystem({10, 6, 5}, seed);
    for (bool jacobi : {true, false})
      for (double tol : {1e-6, 1e-10}) {
        IterativeSolver mine({SolverKind::Minres, jacobi ? PreconditionerKind::Jacobi : PreconditionerKind::None, tol, 5000});
        mine.setOperator(sys.K);
        Eigen::VectorXd x;
        mine.solve(sys.b, x);
        ASSERT_TRUE(mine.converged());
        Eigen::VectorXd xe;
        int64_t eigenIters = 0;
        if (jacobi) {
          Eigen::MINRES<SparseMatrix, Eigen::Lower | Eigen::Upper, Eigen::DiagonalPreconditioner<double>> ref;
          ref.setTolerance(tol);
          ref.setMaxIterations(5000);
          ref.compute(sys.K);
          xe = ref.solve(sys.b);
          eigenIters = ref.iterations();
        } else {
          Eigen::MINRES<SparseMatrix, Eigen::Lower | Eigen::Upper, Eigen::IdentityPreconditioner> ref;
          ref.setTolerance(tol);
          ref.setMaxIterations(5000);
          ref.compute(sys.K);
          xe = ref.solve(sys.b);
          eigenIters = ref.iterations();
        }
        EXPECT_LE(std::abs(mine.iterations() - (eigenIters + 1)), 1)
            << "seed " << seed << " jacobi " << jacobi << " tol " << tol << ": ours " << mine.iterations()
            << ", Eigen " << eigenIters;
        EXPECT_LT((x - xe).norm(), 1e3 * tol * xe.norm());
        // The recurrence residual is the preconditioned residual of the iterate.
        const double direct = preconditionedRelres(sys.K, sys.b, x, jacobi);
        EXPECT_NEAR(direct, mine.relativeResidual(), 1e-3 * mine.relativeResidual() + 1e-14);
        EXPECT_LE(mine.relativeResidual(), tol);
        // MINRES residuals never increase.
        const auto& h = mine.residualHistory();
        ASSERT_EQ(int64_t(h.size()), mine.iterations() + 1);
        EXPECT_EQ(h[0], 1.0);
        for (size_t k = 1; k < h.size(); ++k) ASSERT_LE(h[k], h[k - 1] * (1 + 1e-12));
      }
  }
}

TEST(FemSolver, JacobiPreconditioningHelpsOnHighContrast) {
  const ReducedSystem sys = checkerElectrodeSystem({10, 6, 5}, 5);
  int64_t its[2];
  for (int i = 0; i < 2; ++i) {
    IterativeSolver s({SolverKind::Minres, i == 0 ? PreconditionerKind::Jacobi : PreconditionerKind::None, 1e-8, 5000});
    s.setOperator(sys.K);
    Eigen::VectorXd x;
    s.solve(sys.b, x);
    ASSERT_TRUE(s.converged());
    its[i] = s.iterations();
  }
  EXPECT_LT(its[0], its[1]);
}

TEST(FemSolver, CgAgreesWithMinresAndMeasuresTheSameResidual) {
  const ReducedSystem sys = checkerElectrodeSystem({8, 5, 5}, 6);
  Eigen::VectorXd xm, xc;
  for (auto prec : {PreconditionerKind::Jacobi, PreconditionerKind::None}) {
    IterativeSolver m({SolverKind::Minres, prec, 1e-11, 5000});
    m.setOperator(sys.K);
    m.solve(sys.b, xm);
    IterativeSolver c({SolverKind::Cg, prec, 1e-11, 5000});
    c.setOperator(sys.K);
    c.solve(sys.b, xc);
    ASSERT_TRUE(c.converged());
    EXPECT_LT((xm - xc).norm(), 1e-8 * xm.norm());
    EXPECT_NEAR(preconditionedRelres(sys.K, sys.b, xc, prec == PreconditionerKind::Jacobi), c.relativeResidual(),
                1e-3 * c.relativeResidual());
    EXPECT_LT(c.trueResidual(), 1e-8);
    EXPECT_NEAR(c.trueResidual(), (sys.b - sys.K * xc).norm() / sys.b.norm(), 1e-15);
    // CG and MINRES build the same Krylov spaces: similar iteration counts.
    EXPECT_LE(std::abs(c.iterations() - m.iterations()), m.iterations() / 5 + 2);
  }
}

TEST(FemSolver, NotConvergingIsAStatusNotAnException) {
  const ReducedSystem sys = checkerElectrodeSystem({8, 5, 5}, 7);
  for (auto kind : {SolverKind::Minres, SolverKind::Cg}) {
    IterativeSolver s({kind, PreconditionerKind::Jacobi, 1e-10, 3});
    s.setOperator(sys.K);
    Eigen::VectorXd x;
    EXPECT_NO_THROW(s.solve(sys.b, x));
    EXPECT_FALSE(s.converged());
    EXPECT_EQ(s.status(), SolverStatus::MaxIterations);
    EXPECT_EQ(s.iterations(), 3);
    EXPECT_EQ(s.residualHistory().size(), 4u);
    EXPECT_GT(s.relativeResidual(), 1e-10);
    EXPECT_TRUE(x.allFinite());
    EXPECT_STREQ(solverStatusName(s.status()), "max_iterations");
  }
  // CG on an indefinite matrix breaks down (status), MINRES copes.
  SparseMatrix A(3, 3);
  A.insert(0, 0) = 1;
  A.insert(1, 1) = -2;
  A.insert(2, 2) = 3;
  A.makeCompressed();
  Eigen::VectorXd b = Eigen::VectorXd::Ones(3), x;
  IterativeSolver cg({SolverKind::Cg, PreconditionerKind::None, 1e-12, 10});
  cg.setOperator(A);
  cg.solve(b, x);
  EXPECT_EQ(cg.status(), SolverStatus::Breakdown);
  IterativeSolver mr({SolverKind::Minres, PreconditionerKind::None, 1e-12, 10});
  mr.setOperator(A);
  mr.solve(b, x);
  EXPECT_TRUE(mr.converged());
  EXPECT_NEAR(x[1], -0.5, 1e-12);
}

TEST(FemSolver, ZeroRightHandSideAndMonitorAndCancellation) {
  const ReducedSystem sys = checkerElectrodeSystem({6, 4, 4}, 8);
  IterativeSolver s({SolverKind::Minres, PreconditionerKind::Jacobi, 1e-8, 100});
  s.setOperator(sys.K);
  Eigen::VectorXd x;
  s.solve(Eigen::VectorXd::Zero(sys.K.rows()), x);
  EXPECT_TRUE(s.converged());
  EXPECT_EQ(s.iterations(), 0);
  EXPECT_EQ(x.norm(), 0.0);
  // Monitor sees every iteration; cancelling from it stops the solve with Cancelled.
  NullProgress np;
  std::vector<int64_t> seen;
  s.setProgress(&np);
  s.setMonitor([&](int64_t k, double) {
    seen.push_back(k);
    if (k == 5) np.requestCancel();
  });
  EXPECT_THROW(s.solve(sys.b, x), Cancelled);
  EXPECT_EQ(seen, (std::vector<int64_t>{1, 2, 3, 4, 5}));
}

TEST(FemSolver, ResultsDoNotDependOnTheThreadCount) {
  // Large enough for the chunked vector kernels (> 8 chunks of 4096) and the mat-vec to run in
  // parallel.
  const ReducedSystem sys = checkerElectrodeSystem({36, 30, 30}, 12);
  ASSERT_GT(sys.K.rows(), 8 * 4096);
  const int saved = omp_get_max_threads();
  for (auto kind : {SolverKind::Minres, SolverKind::Cg}) {
    Eigen::VectorXd x[2];
    int64_t its[2];
    for (int t = 0; t < 2; ++t) {
      omp_set_num_threads(t + 1);
      IterativeSolver s({kind, PreconditionerKind::Jacobi, 1e-12, 40}); // 40 iterations suffice
      s.setOperator(sys.K);
      s.solve(sys.b, x[t]);
      its[t] = s.iterations();
    }
    EXPECT_EQ(its[0], 40);
    EXPECT_EQ(its[1], 40);
    EXPECT_EQ((x[0] - x[1]).cwiseAbs().maxCoeff(), 0.0) << solverKindName(kind);
  }
  omp_set_num_threads(saved);
}

TEST(FemSolver, BadConfigurationIsAnInputError) {
  const ReducedSystem sys = checkerElectrodeSystem({4, 3, 3}, 9);
  Eigen::VectorXd x;
  IterativeSolver none;
  EXPECT_THROW_MSG(none.solve(sys.b, x), InputError, "no operator");
  IterativeSolver s({SolverKind::Minres, PreconditionerKind::Jacobi, 1e-8, 0});
  s.setOperator(sys.K);
  EXPECT_THROW_MSG(s.solve(sys.b, x), InputError, "max_iterations");
  s.setParams({SolverKind::Minres, PreconditionerKind::Jacobi, 1.5, 10});
  EXPECT_THROW_MSG(s.solve(sys.b, x), InputError, "tolerance");
  s.setParams({});
  EXPECT_THROW_MSG(s.solve(Eigen::VectorXd::Ones(3), x), InputError, "right-hand side");
  SparseMatrix Z(2, 2);
  Z.insert(0, 0) = 1;
  Z.insert(1, 1) = 0;
  Z.makeCompressed();
  s.setOperator(Z);
  EXPECT_THROW_MSG(s.solve(Eigen::VectorXd::Ones(2), x), InputError, "diagonal entry 1");
}

TEST(FemConditioning, SpectraAgreesWithADenseEigenSolve) {
  const ReducedSystem sys = checkerElectrodeSystem({8, 5, 4}, 10); // a few hundred dofs
  ASSERT_GT(sys.K.rows(), 200);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> dense((Eigen::MatrixXd(sys.K)));
  const double kmin = dense.eigenvalues()[0], kmax = dense.eigenvalues()[sys.K.rows() - 1];
  ConditionParams cp;
  cp.tolerance = 1e-10;
  NullProgress np;
  const SpectrumEstimate s = spectraExtremes(sys.K, cp, &np);
  ASSERT_TRUE(s.converged) << s.method;
  EXPECT_NEAR(s.lambdaMin, kmin, 1e-8 * kmin);
  EXPECT_NEAR(s.lambdaMax, kmax, 1e-8 * kmax);
  EXPECT_NEAR(s.kappa, kmax / kmin, 1e-7 * kmax / kmin);
  EXPECT_NE(s.method.find("SimplicialLDLT"), std::string::npos);
  EXPECT_NE(s.method.find("tol 1e-10"), std::string::npos) << s.method;
  // Jacobi scaling: unit diagonal, spectrum of M^-1 K.
  const SparseMatrix S = jacobiScaled(sys.K);
  EXPECT_LT((S.diagonal() - Eigen::VectorXd::Ones(S.rows())).cwiseAbs().maxCoeff(), 1e-15);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> ds((Eigen::MatrixXd(S)));
  const SpectrumEstimate sj = spectraExtremes(S, cp, &np);
  const double kj = ds.eigenvalues()[S.rows() - 1] / ds.eigenvalues()[0];
  EXPECT_NEAR(sj.kappa, kj, 1e-7 * kj);
  EXPECT_LT(kj, s.kappa); // the contrast 100 is mostly removed by the scaling
  // Lanczos estimates from the solvers: lower bounds, tight once converged far.
  for (auto kind : {SolverKind::Minres, SolverKind::Cg}) {
    IterativeSolver solver({kind, PreconditionerKind::Jacobi, 1e-13, 5000});
    solver.setOperator(sys.K);
    Eigen::VectorXd x;
    solver.solve(sys.b, x);
    const SpectrumEstimate l = lanczosEstimate(solver.lanczos(), "test");
    EXPECT_EQ(l.operations, solver.iterations());
    EXPECT_LE(l.kappa, kj * (1 + 1e-8));
    EXPECT_GT(l.kappa, 0.9 * kj) << solverKindName(kind);
    EXPECT_GE(l.lambdaMin, ds.eigenvalues()[0] * (1 - 1e-8));
    EXPECT_LE(l.lambdaMax, ds.eigenvalues()[S.rows() - 1] * (1 + 1e-8));
  }
}

TEST(FemConditioning, TridiagonalExtremesBySturmBisection) {
  // T = tridiag(-1, 2, -1) of size k: eigenvalues 2 - 2 cos(j pi / (k + 1)).
  LanczosTridiagonal T;
  const int k = 50;
  T.diagonal.assign(k, 2.0);
  T.offDiagonal.assign(k, -1.0); // one extra entry, as the solvers store it
  const SpectrumEstimate e = lanczosEstimate(T, "tridiag");
  const double lmin = 2 - 2 * std::cos(M_PI / (k + 1)), lmax = 2 - 2 * std::cos(k * M_PI / (k + 1));
  EXPECT_NEAR(e.lambdaMin, lmin, 1e-13);
  EXPECT_NEAR(e.lambdaMax, lmax, 1e-13);
  EXPECT_TRUE(e.converged);
  EXPECT_FALSE(lanczosEstimate(LanczosTridiagonal{}, "empty").converged);
}
