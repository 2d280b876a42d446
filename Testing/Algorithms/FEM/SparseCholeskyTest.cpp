// solver = cholesky (Algorithms/FEM/SparseCholesky.h, IterativeSolver.h): the factor solves what
// tight MINRES solves, lead fields agree with MINRES's for every source model, bad systems, a
// factor that would not fit and a cancelled factorisation are refused cleanly.
#include <gtest/gtest.h>

#include <chrono>
#include <random>
#include <thread>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/MemoryBudget.h"
#include "Algorithms/FEM/LeadField.h"
#include "Algorithms/FEM/PoissonProblem.h"
#include "Algorithms/FEM/SparseCholesky.h"
#include "FemTestMeshes.h"

using namespace tetflow;
using tetflow::test::checkerBox;
using tetflow::test::checkerElectrodeSystem;
using tetflow::test::checkerSigma;


TEST(SparseCholesky, SolvesWhatTightMinresSolvesOnRandomSystems) {
  std::mt19937 rng(7);
  for (unsigned seed = 1; seed <= 4; ++seed) {
    const std::array<int, 3> n{6 + int(seed), 5 + int(seed % 3), 4 + int(seed % 2)};
    const ReducedSystem sys = checkerElectrodeSystem(n, seed);
    Eigen::MatrixXd B(sys.K.rows(), 4);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    for (Eigen::Index i = 0; i < B.size(); ++i) B.data()[i] = uni(rng);
    B.col(0) = sys.b; // the electrode problem itself

    IterativeSolver chol({SolverKind::Cholesky, PreconditionerKind::Jacobi, 1e-8, 1});
    chol.setOperator(sys.K);
    EXPECT_GT(chol.setUp(), 0.0);
    EXPECT_EQ(chol.setUp(), 0.0) << "factorised once";
    ASSERT_NE(chol.cholesky(), nullptr);
    EXPECT_GT(chol.cholesky()->factorNonzeros(), double(sys.K.rows()));
    EXPECT_GT(chol.cholesky()->factorBytes(), 8.0 * chol.cholesky()->factorNonzeros() * 0.99);
    Eigen::MatrixXd X;
    chol.solveBlock(B, X);
    EXPECT_TRUE(chol.converged());
    EXPECT_EQ(chol.iterations(), 0);
    EXPECT_LT(chol.trueResidual(), 1e-12) << "seed " << seed;

    IterativeSolver minres({SolverKind::Minres, PreconditionerKind::Jacobi, 1e-13, 20000});
    minres.setOperator(sys.K);
    for (Eigen::Index j = 0; j < B.cols(); ++j) {
      Eigen::VectorXd x, y;
      minres.solve(B.col(j), x);
      ASSERT_TRUE(minres.converged());
      EXPECT_LT((X.col(j) - x).norm(), 1e-9 * x.norm()) << "seed " << seed << " column " << j;
      chol.solve(B.col(j), y); // one column through solve(): the same numbers as the block
      EXPECT_LT((y - X.col(j)).norm(), 1e-14 * x.norm() + 1e-300);
    }
  }
}

TEST(SparseCholesky, ANonPositiveDefiniteMatrixIsRefusedNamingTheColumn) {
  SparseMatrix K(6, 6);
  std::vector<Eigen::Triplet<double, int>> t;
  for (int i = 0; i < 6; ++i) t.emplace_back(i, i, i == 3 ? -1.0 : 2.0);
  K.setFromTriplets(t.begin(), t.end());
  K.makeCompressed();
  SparseCholesky f;
  f.analyze(K);
  NullProgress np;
  try {
    f.factorize(np);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not positive definite"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("column 3"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(f.factorized());
  Eigen::MatrixXd X;
  EXPECT_THROW(f.solve(Eigen::MatrixXd::Ones(6, 1), X), InputError);
}

TEST(SparseCholesky, AFactorThatWouldNotFitIsRefusedBeforeItIsComputed) {
  const ReducedSystem sys = checkerElectrodeSystem({8, 8, 8}, 3);
  SparseCholesky f;
  f.analyze(sys.K);
  setMemoryLimit(std::max<int64_t>(residentBytes(), 1) + int64_t(f.factorBytes() / 4));
  NullProgress np;
  std::string msg;
  try {
    f.factorize(np);
  } catch (const InputError& e) {
    msg = e.what();
  }
  setMemoryLimit(0);
  EXPECT_NE(msg.find("Cholesky factor"), std::string::npos) << msg;
  EXPECT_NE(msg.find("minres"), std::string::npos) << msg;
  EXPECT_FALSE(f.factorized());
  f.factorize(np); // with the limit lifted it goes through
  EXPECT_TRUE(f.factorized());
}

TEST(SparseCholesky, ACancelledFactorisationStopsAtOnceAndTheNextOneWorks) {
  const ReducedSystem sys = checkerElectrodeSystem({30, 30, 30}, 5); // ~27 000 unknowns
  NullProgress cancelled;
  cancelled.requestCancel();
  SparseCholesky f;
  f.analyze(sys.K);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_THROW(f.factorize(cancelled), Cancelled);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 0.5);
  EXPECT_FALSE(f.factorized());
  // A cancel requested while it runs (from another thread, as the GUI's Stop does).
  NullProgress later;
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    later.requestCancel();
  });
  IterativeSolver s({SolverKind::Cholesky, PreconditionerKind::Jacobi, 1e-8, 1});
  s.setOperator(sys.K);
  s.setProgress(&later);
  bool threw = false;
  try {
    s.setUp();
  } catch (const Cancelled&) {
    threw = true;
  }
  stopper.join();
  if (threw) {
    EXPECT_EQ(s.cholesky(), nullptr);
  }
  NullProgress np;
  s.setProgress(&np);
  s.setUp();
  Eigen::VectorXd x;
  s.solve(sys.b, x);
  EXPECT_LT(s.trueResidual(), 1e-12);
}

TEST(SparseCholesky, BadConfigurationsAreInputErrors) {
  SolverParams p{SolverKind::Cholesky, PreconditionerKind::Jacobi, 1e-8, 1};
  p.backend = SolverBackend::Petsc;
  try {
    p.validate();
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("solver_backend = eigen"), std::string::npos) << e.what();
  }
  EXPECT_EQ(solverKindFromName("cholesky"), SolverKind::Cholesky);
  EXPECT_STREQ(solverKindName(SolverKind::Cholesky), "cholesky");
  IterativeSolver minres;
  const ReducedSystem sys = checkerElectrodeSystem({4, 4, 4}, 1);
  minres.setOperator(sys.K);
  Eigen::MatrixXd X;
  EXPECT_THROW(minres.solveBlock(Eigen::MatrixXd::Ones(sys.K.rows(), 2), X), InputError);
}

// Every source model's lead field, Cholesky against tight MINRES, on random boxes.
TEST(SparseCholesky, LeadFieldsAgreeWithTightMinresForEverySourceModel) {
  for (unsigned seed : {11u, 12u}) {
    const std::array<int, 3> n{9, 8, 7};
    const TetMesh m = checkerBox(n, seed);
    LeadFieldParams p;
    p.conductivities = checkerSigma();
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> uy(0.0, n[1]), uz(0.0, n[2]), ux(1.5, n[0] - 1.5);
    for (int e = 0; e < 10; ++e) // on the x = 0 and x = hi faces and the y = 0 face
      p.electrodes.push_back({std::string("E").append(std::to_string(e)),
                              e < 4 ? Vec3{0.0, uy(rng), uz(rng)}
                                    : e < 7 ? Vec3{double(n[0]), uy(rng), uz(rng)} : Vec3{ux(rng), 0.0, uz(rng)},
                              e + 1});
    for (int s = 0; s < 4; ++s) p.sourcePoints.push_back({ux(rng), 2.0 + 0.5 * s, 2.5 + 0.6 * s});
    for (SourceModel model : {SourceModel::PartialIntegration, SourceModel::Venant, SourceModel::Subtraction}) {
      p.sourceModel = model;
      NullProgress np;
      p.solver = SolverParams{SolverKind::Minres, PreconditionerKind::Jacobi, 1e-13, 20000};
      const LeadFieldResult ref = computeLeadField(m, p, np);
      p.solver = SolverParams{SolverKind::Cholesky, PreconditionerKind::Jacobi, 1e-8, 1};
      const LeadFieldResult lf = computeLeadField(m, p, np);
      ASSERT_EQ(lf.matrix.rows(), ref.matrix.rows());
      ASSERT_EQ(lf.matrix.cols(), ref.matrix.cols());
      EXPECT_EQ(lf.solves, ref.solves);
      EXPECT_EQ(lf.iterationsTotal, 0);
      EXPECT_TRUE(lf.converged);
      EXPECT_GT(lf.setupSeconds, 0.0);
      bool noted = false;
      for (const auto& note : lf.notes) noted = noted || note.rfind("cholesky: ", 0) == 0;
      EXPECT_TRUE(noted);
      for (Eigen::Index c = 0; c < ref.matrix.cols(); ++c)
        EXPECT_LT((lf.matrix.col(c) - ref.matrix.col(c)).norm(), 1e-6 * ref.matrix.col(c).norm())
            << "seed " << seed << " model " << sourceModelName(model) << " column " << c;
    }
  }
}
