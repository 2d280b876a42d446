// The FEM Poisson problem (Algorithms/FEM/PoissonProblem.h) on problems with known answers.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <iostream>
#include <numbers>

#include "Algorithms/FEM/PoissonProblem.h"
#include "FemTestMeshes.h"
#include "TestUtil.h"

using namespace tetflow;
using tetflow::test::cubedShell;
using tetflow::test::kuhnBox;
using tetflow::test::perturbInterior;

namespace {

PoissonParams electrodeParams(int axis, double tol = 1e-12) {
  PoissonParams p;
  p.boundary = BoundaryCondition::Electrodes;
  p.electrode_axis = axis;
  p.solver.tolerance = tol;
  p.estimate_condition = false;
  return p;
}

using tetflow::test::maxAbs;

} // namespace

TEST(FemPoisson, ElectrodeProblemReproducesTheLinearPotentialOnPerturbedBoxes) {
  // u = 1 - (x_axis - min) / L is in the P1 space and solves the problem exactly (insulated
  // sides, f = 0), so the discrete solution equals it up to the solver tolerance.
  for (int axis = 0; axis < 3; ++axis)
    for (unsigned seed : {1u, 2u}) {
      std::array<int, 3> n{5, 4, 3};
      n[size_t(axis)] = 8;
      const Vec3 lo{-1.0, 2.0, 0.5};
      const Vec3 hi{lo[0] + 1.5 * n[0], lo[1] + 1.0 * n[1], lo[2] + 1.25 * n[2]};
      TetMesh m = kuhnBox(n, lo, hi);
      perturbInterior(m, lo, hi, 1.0, 0.15, seed);
      for (auto solver : {SolverKind::Minres, SolverKind::Cg}) {
        PoissonParams p = electrodeParams(axis);
        p.solver.kind = solver;
        // A diagonal anisotropic tensor keeps the linear solution exact (flux parallel to the axis).
        p.conductivities.set(1, SymTensor6{0.5, 2.0, 1.5, 0, 0, 0});
        NullProgress np;
        const PoissonResult r = solvePoisson(m, p, np);
        ASSERT_TRUE(r.converged);
        const double L = hi[size_t(axis)] - lo[size_t(axis)];
        double err = 0;
        for (size_t v = 0; v < m.numPoints(); ++v)
          err = std::max(err, std::abs(r.potential[v] - (1.0 - (m.points[v][size_t(axis)] - lo[size_t(axis)]) / L)));
        EXPECT_LT(err, 1e-9) << "axis " << axis << " seed " << seed;
        const double sigmaAxis = p.conductivities.tensor(1)[size_t(axis)];
        for (size_t t = 0; t < m.numTets(); ++t) {
          ASSERT_NEAR(r.gradMagnitude[t], 1.0 / L, 1e-8 / L);
          ASSERT_NEAR(r.currentDensity[t], sigmaAxis / L, 1e-8 * sigmaAxis / L);
        }
        // Current through the cross-section A: sigma * A / L mA in at the 1 V side, out at 0 V.
        const double A = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]) / L;
        ASSERT_EQ(r.electrodes.size(), 2u);
        EXPECT_NEAR(r.electrodes[0].current, sigmaAxis * A / L, 1e-8 * sigmaAxis * A / L);
        EXPECT_NEAR(r.electrodes[1].current, -sigmaAxis * A / L, 1e-8 * sigmaAxis * A / L);
        EXPECT_EQ(r.dofs + r.dirichletVertices, int64_t(m.numPoints()));
        EXPECT_EQ(r.dirichletVertices, 2 * (n[size_t((axis + 1) % 3)] + 1) * (n[size_t((axis + 2) % 3)] + 1));
      }
    }
}

TEST(FemPoisson, TwoLayerSeriesConductorHasItsExactPiecewiseLinearSolution) {
  // x in [0, 10]: sigma1 = 0.33 S/m for x < 4, sigma2 = 0.0042 S/m beyond; u(0) = 1, u(10) = 0.
  const double s1 = 0.33, s2 = 0.0042, x1 = 4.0, L = 10.0;
  const Vec3 lo{0, 0, 0}, hi{L, 4, 3};
  TetMesh m = kuhnBox({10, 4, 3}, lo, hi, [](int i, int, int) { return i < 4 ? 1 : 2; });
  // Interface vertices stay on the plane x = 4.
  perturbInterior(m, lo, hi, 1.0, 0.15, 42, [&](const Vec3& p, int axis) { return axis == 0 && p[0] == x1; });
  PoissonParams p = electrodeParams(0);
  p.conductivities = parseConductivities({"1:0.33", "2:0.0042"}, 1.0);
  NullProgress np;
  const PoissonResult r = solvePoisson(m, p, np);
  ASSERT_TRUE(r.converged);
  const double J = 1.0 / (x1 / s1 + (L - x1) / s2); // mA/mm^2
  auto exact = [&](double x) { return x <= x1 ? 1.0 - J * x / s1 : J * (L - x) / s2; };
  double err = 0;
  for (size_t v = 0; v < m.numPoints(); ++v) err = std::max(err, std::abs(r.potential[v] - exact(m.points[v][0])));
  EXPECT_LT(err, 1e-9);
  for (size_t t = 0; t < m.numTets(); ++t) {
    const double sigma = m.materials[t] == 1 ? s1 : s2;
    ASSERT_NEAR(r.gradMagnitude[t], J / sigma, 1e-7 * J / sigma) << t;
    ASSERT_NEAR(r.currentDensity[t], J, 1e-7 * J) << t;
  }
  const double A = 4.0 * 3.0;
  EXPECT_NEAR(r.electrodes[0].current, J * A, 1e-8 * J * A);
  EXPECT_NEAR(r.electrodes[1].current, -J * A, 1e-8 * J * A);
  Report rep;
  writePoissonReport(r, rep);
  EXPECT_NEAR(rep.number("resistance"), (x1 / s1 + (L - x1) / s2) / A, 1e-7 * rep.number("resistance"));
}

TEST(FemPoisson, ConcentricSpheresConvergeAtSecondOrder) {
  // Shell r0 < r < r2, sigma1 inside r1, sigma2 outside; u(r0) = 1 V, u(r2) = 0.
  // Exact: u = a_i + I / (4 pi sigma_i r) per layer, I = 4 pi / R,
  // R = (1/r0 - 1/r1) / sigma1 + (1/r1 - 1/r2) / sigma2.
  const double r0 = 10, r1 = 20, r2 = 30, s1 = 1.0, s2 = 0.25;
  const double R = (1 / r0 - 1 / r1) / s1 + (1 / r1 - 1 / r2) / s2;
  const double I = 4 * std::numbers::pi / R;
  const double a1 = 1.0 - I / (4 * std::numbers::pi * s1 * r0);
  const double a2 = -I / (4 * std::numbers::pi * s2 * r2);
  auto exact = [&](const Vec3& x, int32_t label) {
    const double r = norm(x);
    return label == 1 ? a1 + I / (4 * std::numbers::pi * s1 * r) : a2 + I / (4 * std::numbers::pi * s2 * r);
  };
  ConductivityTable sigma;
  sigma.set(1, s1);
  sigma.set(2, s2);
  std::vector<double> errors, currents;
  for (int level : {1, 2, 4}) {
    std::vector<int> shell;
    const TetMesh m = cubedShell(level, r0, r1, r2, shell);
    for (size_t t = 0; t < m.numTets(); ++t) ASSERT_GT(m.tetVolume(t), 0.0);
    NullProgress np;
    const SparseMatrix K = assembleStiffness(m, sigma, np);
    DirichletSet d(m.numPoints());
    for (size_t v = 0; v < m.numPoints(); ++v)
      if (shell[v] != 1) d.set(v, shell[v] == 0 ? 1.0 : 0.0);
    const Eigen::VectorXd f = Eigen::VectorXd::Zero(K.rows());
    const ReducedSystem sys = eliminateDirichlet(K, f, d);
    IterativeSolver solver({SolverKind::Minres, PreconditionerKind::Jacobi, 1e-12, 10000});
    solver.setOperator(sys.K);
    Eigen::VectorXd x;
    solver.solve(sys.b, x);
    ASSERT_TRUE(solver.converged());
    const Eigen::VectorXd u = sys.expand(x);
    // L2 error with the 4-point (degree 2) rule; relative to the L2 norm of u.
    const double qa = 0.5854101966249685, qb = 0.1381966011250105;
    double e2 = 0, u2 = 0;
    for (size_t t = 0; t < m.numTets(); ++t) {
      const auto& q = m.tets[t];
      const double w = m.tetVolume(t) / 4;
      for (int k = 0; k < 4; ++k) {
        Vec3 x{0, 0, 0};
        double uh = 0;
        for (int a = 0; a < 4; ++a) {
          const double l = a == k ? qa : qb;
          x = x + l * m.points[q[a]];
          uh += l * u[q[a]];
        }
        const double ue = exact(x, m.materials[t]);
        e2 += w * (uh - ue) * (uh - ue);
        u2 += w * ue * ue;
      }
    }
    errors.push_back(std::sqrt(e2 / u2));
    // Current injected at the inner sphere (reaction K u at its vertices).
    const Eigen::VectorXd ku = K * u;
    double Ih = 0;
    for (size_t v = 0; v < m.numPoints(); ++v)
      if (shell[v] == 0) Ih += ku[Eigen::Index(v)];
    currents.push_back(Ih);
  }
  const double order1 = std::log2(errors[0] / errors[1]);
  const double order2 = std::log2(errors[1] / errors[2]);
  std::cout << "concentric spheres: relative L2 errors " << errors[0] << " " << errors[1] << " "
            << errors[2] << ", currents " << currents[0] << " " << currents[1] << " " << currents[2]
            << " (exact " << I << ")\n";
  EXPECT_GT(order1, 1.6) << errors[0] << " " << errors[1];
  EXPECT_GT(order2, 1.8) << errors[1] << " " << errors[2];
  EXPECT_LT(order2, 2.4);
  EXPECT_LT(errors[2], 5e-3);
  // The current through the inner sphere (reaction at its vertices) converges to the analytic
  // one, also at second order.
  EXPECT_GT(std::log2((currents[1] - I) / (currents[2] - I)), 1.8);
  EXPECT_LT(std::abs(currents[2] - I) / I, 0.005);
}

TEST(FemPoisson, BoundaryProblemOnTheUnitCubeConvergesToTheSeriesSolution) {
  // -lap u = 1 on (0,1)^3, u = 0 on the boundary: u(centre) = sum over odd i, j, k of
  // 64 (-1)^((i+j+k-3)/2) / (pi^5 i j k (i^2 + j^2 + k^2)).
  double series = 0;
  for (int i = 1; i < 400; i += 2)
    for (int j = 1; j < 400; j += 2)
      for (int k = 1; k < 400; k += 2) {
        const double sgn = ((i + j + k - 3) / 2) % 2 ? -1.0 : 1.0;
        series += sgn * 64.0 / (std::pow(std::numbers::pi, 5) * i * j * k * double(i * i + j * j + k * k));
      }
  std::vector<double> err;
  for (int N : {8, 16}) {
    const TetMesh m = kuhnBox({N, N, N}, {0, 0, 0}, {1, 1, 1});
    PoissonParams p;
    p.boundary = BoundaryCondition::Boundary;
    p.solver.tolerance = 1e-12;
    p.estimate_condition = false;
    NullProgress np;
    const PoissonResult r = solvePoisson(m, p, np);
    ASSERT_TRUE(r.converged);
    const int32_t centre = (N / 2) + (N + 1) * ((N / 2) + (N + 1) * (N / 2));
    err.push_back(std::abs(r.potential[size_t(centre)] - series));
    EXPECT_NEAR(r.potentialMax, r.potential[size_t(centre)], 1e-12);
    EXPECT_EQ(r.dofs, int64_t(N - 1) * (N - 1) * (N - 1));
  }
  EXPECT_LT(err[1] / series, 0.01);
  EXPECT_GT(std::log2(err[0] / err[1]), 1.8);
}

TEST(FemPoisson, CubeGridConditionNumberIsCot2OfPiHOver2) {
  // On the Kuhn (6 tets per cube, all sharing the cube diagonal) grid of the unit cube with
  // spacing h = 1/N, the P1 stiffness matrix of -lap is exactly h times the 7-point stencil
  // (6 on the diagonal, -1 for the 6 axis neighbours; the face- and body-diagonal couplings
  // cancel). With u = 0 on the boundary its eigenvalues are h * sum_d 4 sin^2(k_d pi h / 2),
  // k_d = 1..N-1, so kappa(K) = cot^2(pi h / 2), and, the diagonal being constant (6h), the
  // Jacobi-scaled matrix has the same kappa. (This exact match needs the Kuhn split; other
  // splits give other stencils.)
  for (int N : {4, 10}) {
    const double h = 1.0 / N;
    const TetMesh m = kuhnBox({N, N, N}, {0, 0, 0}, {1, 1, 1});
    PoissonParams p;
    p.boundary = BoundaryCondition::Boundary;
    p.solver.tolerance = 1e-12;
    p.condition.tolerance = 1e-11;
    NullProgress np;
    const PoissonResult r = solvePoisson(m, p, np);
    ASSERT_TRUE(r.converged);
    // The stencil.
    const SparseMatrix& K = *r.matrix;
    const int n = N - 1;
    ASSERT_EQ(K.rows(), n * n * n);
    for (int j = 0; j < K.outerSize(); ++j)
      for (SparseMatrix::InnerIterator it(K, j); it; ++it) {
        const int i = int(it.row());
        const int d = std::abs(i - j);
        const bool axisNeighbour = d == 1 || d == n || d == n * n;
        const double expected = i == j ? 6 * h : axisNeighbour ? -h : 0.0;
        ASSERT_NEAR(it.value(), expected, 1e-14) << i << " " << j;
      }
    const double cot = 1.0 / std::tan(std::numbers::pi * h / 2);
    const double kappa = cot * cot;
    EXPECT_NEAR(r.kappa.kappa, kappa, 1e-8 * kappa) << r.kappa.method;
    EXPECT_NEAR(r.kappaJacobi.kappa, kappa, 1e-8 * kappa) << r.kappaJacobi.method;
    EXPECT_NEAR(r.kappa.lambdaMin, 12 * h * std::pow(std::sin(std::numbers::pi * h / 2), 2), 1e-10);
    EXPECT_TRUE(r.kappa.converged);
    const std::string method = N == 4 ? "dense" : "Spectra SymEigsShiftSolver";
    EXPECT_NE(r.kappa.method.find(method), std::string::npos) << r.kappa.method;
    // The solve's Lanczos estimate is a lower bound that is close here.
    EXPECT_LE(r.lanczos.kappa, kappa * (1 + 1e-9));
    EXPECT_GT(r.lanczos.kappa, 0.95 * kappa) << r.lanczos.method;
    // Without the eigen solves both figures come from Lanczos runs.
    p.estimate_condition = false;
    const PoissonResult e = solvePoisson(m, p, np);
    EXPECT_NE(e.kappa.method.find("CG on K, random"), std::string::npos) << e.kappa.method;
    EXPECT_NE(e.kappaJacobi.method.find("MINRES on M^-1 K"), std::string::npos) << e.kappaJacobi.method;
    EXPECT_LE(e.kappa.kappa, kappa * (1 + 1e-9));
    EXPECT_GT(e.kappa.kappa, 0.95 * kappa);
  }
}

TEST(FemPoisson, MaterialElectrodesHoldTheirMaterialsAtTheirPotentials) {
  // Layers along x: label 5 (x < 1), label 1, label 6 (x > 7): u = 1 up to x = 1, linear to 0 at 7.
  const Vec3 lo{0, 0, 0}, hi{8, 3, 3};
  TetMesh m = kuhnBox({8, 3, 3}, lo, hi, [](int i, int, int) { return i == 0 ? 5 : i == 7 ? 6 : 1; });
  perturbInterior(m, lo, hi, 1.0, 0.15, 8, [](const Vec3& p, int axis) { return axis == 0 && (p[0] == 1 || p[0] == 7); });
  PoissonParams p;
  p.boundary = BoundaryCondition::MaterialElectrodes;
  p.electrode_potentials = parseLabelValues({"5:1", "6:0"}, "electrode_potentials");
  p.solver.tolerance = 1e-12;
  p.estimate_condition = false;
  NullProgress np;
  const PoissonResult r = solvePoisson(m, p, np);
  ASSERT_TRUE(r.converged);
  for (size_t v = 0; v < m.numPoints(); ++v) {
    const double x = m.points[v][0];
    const double expected = x <= 1 ? 1.0 : x >= 7 ? 0.0 : (7 - x) / 6;
    ASSERT_NEAR(r.potential[v], expected, 1e-9) << v;
  }
  ASSERT_EQ(r.electrodes.size(), 2u);
  EXPECT_EQ(r.electrodes[0].name, "label_5");
  EXPECT_NEAR(r.electrodes[0].current, 1.0 * 9.0 / 6.0, 1e-8); // sigma A / L with default sigma 1
  EXPECT_NEAR(r.electrodes[1].current, -1.5, 1e-8);
  Report rep;
  writePoissonReport(r, rep);
  EXPECT_NEAR(rep.number("electrode_label_5_current"), 1.5, 1e-8);

  // Touching electrode materials at different potentials, absent labels, no entries.
  const TetMesh touching = kuhnBox({4, 2, 2}, lo, {4, 2, 2}, [](int i, int, int) { return i == 0 ? 5 : i == 1 ? 6 : 1; });
  EXPECT_THROW_MSG(solvePoisson(touching, p, np), InputError, "electrode materials 5 and 6 touch", "different potentials");
  p.electrode_potentials = {{5, 1.0}, {9, 0.0}};
  EXPECT_THROW_MSG(solvePoisson(m, p, np), InputError, "electrode_potentials: label 9 does not occur", "1 5 6");
  p.electrode_potentials.clear();
  EXPECT_THROW_MSG(solvePoisson(m, p, np), InputError, "electrode_potentials", "at least one");
}

TEST(FemPoisson, DipoleInAPointSymmetricBoxGivesAnAntisymmetricPotential) {
  // The Kuhn grid of [-4,4]^3 is invariant under x -> -x, the +-I pole pair at +-(d/2) m^ is
  // mapped onto itself with opposite sign, so u(x) + u(-x) is the same constant at every vertex
  // (the reference vertex fixes the constant).
  const int N = 8;
  const TetMesh m = kuhnBox({N, N, N}, {-4, -4, -4}, {4, 4, 4});
  PoissonParams p;
  p.boundary = BoundaryCondition::Dipole;
  p.dipole_position = {0, 0, 0};
  p.dipole_moment = {0.3, 0.5, 0.8};
  p.dipole_separation = 1.3;
  p.solver.tolerance = 1e-12;
  p.estimate_condition = false;
  NullProgress np;
  const PoissonResult r = solvePoisson(m, p, np);
  ASSERT_TRUE(r.converged);
  ASSERT_EQ(r.referenceVertices.size(), 1u);
  EXPECT_EQ(r.referenceVertices[0], 0); // corners are the farthest boundary vertices; lowest index
  EXPECT_EQ(r.potential[0], 0.0);
  EXPECT_EQ(r.dipoleTets.size(), 2u);
  const size_t np1 = m.numPoints();
  const size_t centre = np1 / 2; // grid vertex at the origin
  ASSERT_LT(norm(m.points[centre]), 1e-12);
  const double scale = maxAbs(r.potential);
  for (size_t v = 0; v < np1; ++v)
    ASSERT_NEAR(r.potential[v] + r.potential[np1 - 1 - v], 2 * r.potential[centre], 1e-8 * scale) << v;
  // Higher potential on the side the moment points to.
  const Vec3 dir = (1.0 / norm(p.dipole_moment)) * p.dipole_moment;
  double up = 0, down = 0;
  for (size_t v = 0; v < np1; ++v) {
    const double s = dot(m.points[v], dir);
    if (s > 3) up = std::max(up, r.potential[v]);
    if (s < -3) down = std::max(down, r.potential[v]);
  }
  EXPECT_GT(up, down);
  // The limit form (separation 0) gives a nearby far field.
  p.dipole_separation = 0.0;
  const PoissonResult lim = solvePoisson(m, p, np);
  ASSERT_TRUE(lim.converged);
  EXPECT_EQ(lim.dipoleTets.size(), 1u);
  Report rep;
  writePoissonReport(lim, rep);
  EXPECT_EQ(std::get<int64_t>(*rep.find("reference_vertex")), 0);
  // Errors.
  p.dipole_position = {10, 0, 0};
  EXPECT_THROW_MSG(solvePoisson(m, p, np), InputError, "dipole_position", "outside the mesh");
  p.dipole_position = {0, 0, 0};
  p.dipole_moment = {0, 0, 0};
  EXPECT_THROW_MSG(solvePoisson(m, p, np), InputError, "dipole_moment", "non-zero");
}

TEST(FemPoisson, FloatingPiecesGetAReferenceVertex) {
  // Box A spans x in [0, 6] (touches both electrodes); box B (x in [2, 4]) touches neither.
  TetMesh a = kuhnBox({6, 2, 2}, {0, 0, 0}, {6, 2, 2});
  const TetMesh b = kuhnBox({2, 2, 2}, {2, 4, 0}, {4, 6, 2});
  const int32_t off = int32_t(a.numPoints());
  a.points.insert(a.points.end(), b.points.begin(), b.points.end());
  for (auto t : b.tets) {
    for (auto& v : t) v += off;
    a.tets.push_back(t);
  }
  a.materials.insert(a.materials.end(), b.materials.begin(), b.materials.end());
  a.points.push_back({100, 100, 100}); // a vertex used by no tet
  PoissonParams p = electrodeParams(0);
  NullProgress np;
  const PoissonResult r = solvePoisson(a, p, np);
  ASSERT_TRUE(r.converged);
  EXPECT_EQ(r.components, 2);
  EXPECT_EQ(r.unusedVertices, 1);
  ASSERT_EQ(r.referenceVertices.size(), 1u);
  EXPECT_EQ(r.referenceVertices[0], off);
  ASSERT_EQ(r.notes.size(), 1u);
  EXPECT_NE(r.notes[0].find("held at 0 V"), std::string::npos);
  for (size_t v = size_t(off); v < a.numPoints(); ++v) EXPECT_NEAR(r.potential[v], 0.0, 1e-12);
  EXPECT_NEAR(r.potential[5], 1.0 - 5.0 / 6.0, 1e-9);
}

TEST(FemPoisson, NotConvergingIsReportedAsAStatus) {
  const TetMesh m = kuhnBox({8, 8, 8}, {0, 0, 0}, {1, 1, 1});
  PoissonParams p;
  p.solver.max_iterations = 2;
  p.estimate_condition = false;
  NullProgress np;
  const PoissonResult r = solvePoisson(m, p, np);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.status, SolverStatus::MaxIterations);
  EXPECT_EQ(r.iterations, 2);
  EXPECT_GT(r.relativeResidual, p.solver.tolerance);
  ASSERT_FALSE(r.notes.empty());
  EXPECT_NE(r.notes.back().find("did not converge"), std::string::npos);
  Report rep;
  writePoissonReport(r, rep);
  EXPECT_EQ(std::get<bool>(*rep.find("converged")), false);
  EXPECT_EQ(std::get<std::string>(*rep.find("solver_status")), "max_iterations");
  for (const char* key : {"dofs", "nnz", "kappa", "kappa_jacobi", "iterations", "relative_residual",
                          "true_residual", "converged", "assemble_seconds", "solve_seconds",
                          "condition_seconds", "kappa_method", "kappa_jacobi_method"})
    EXPECT_TRUE(rep.has(key)) << key;
  // Stage names.
  std::vector<std::string> stages;
  for (const auto& s : np.stageTimes()) stages.push_back(s.name);
  EXPECT_EQ(stages, (std::vector<std::string>{"assemble", "boundary conditions", "solve", "condition", "fields"}));
}

TEST(FemPoisson, BadInputsAreInputErrors) {
  const TetMesh m = kuhnBox({2, 2, 2}, {0, 0, 0}, {1, 1, 1});
  NullProgress np;
  PoissonParams p;
  p.conductivities = parseConductivities({"1:0.33", "9:0.5"}, 1.0);
  EXPECT_THROW_MSG(solvePoisson(m, p, np), InputError, "conductivities: label 9 does not occur in the mesh",
                   "labels present: 1");
  EXPECT_THROW_MSG(boundaryConditionFromName("neumann"), InputError, "boundary_condition 'neumann'",
                   "boundary electrodes material_electrodes dipole");
  EXPECT_THROW_MSG(solverKindFromName("gmres"), InputError, "solver 'gmres'", "minres cg");
  EXPECT_THROW_MSG(preconditionerKindFromName("ilu"), InputError, "preconditioner 'ilu'", "jacobi none");
  EXPECT_EQ(boundaryConditionFromName("material_electrodes"), BoundaryCondition::MaterialElectrodes);
  PoissonParams q;
  q.solver.tolerance = 0;
  EXPECT_THROW_MSG(solvePoisson(m, q, np), InputError, "tolerance");
  q = PoissonParams{};
  q.boundary = BoundaryCondition::Electrodes;
  q.electrode_axis = 3;
  EXPECT_THROW_MSG(solvePoisson(m, q, np), InputError, "electrode_axis");
  TetMesh inverted = m;
  std::swap(inverted.tets[3][1], inverted.tets[3][2]);
  EXPECT_THROW_MSG(solvePoisson(inverted, PoissonParams{}, np), InputError, "tet 3 ", "inverted");
  EXPECT_THROW_MSG(solvePoisson(TetMesh{}, PoissonParams{}, np), InputError, "no tets");
}
