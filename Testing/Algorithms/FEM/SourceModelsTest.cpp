// Tests for the dipole source models beside partial integration: Algorithms/FEM/SourceModels (the
// St. Venant dipole: the monopoles carry no net current, reproduce the dipole moment and have no
// second moments, on perturbed random meshes; the load is linear in the moment) and
// Algorithms/FEM/Subtraction (the load carries no net current and is linear in the moment, the
// singular potential is the closed form, and on a homogeneous ball the solution is closer to the
// analytic potential than partial integration's and Venant's); errors are named.
#include "Algorithms/FEM/SourceModels.h"

#include <gtest/gtest.h>

#include <map>
#include <random>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/FEM/AnalyticSphere.h"
#include "Algorithms/FEM/PoissonProblem.h"
#include "Algorithms/FEM/Subtraction.h"
#include "FemTestMeshes.h"
#include "TestUtil.h"

namespace tetflow {
namespace {

TEST(VenantSource, MonopolesMatchTheDipolesMomentsOnRandomMeshes) {
  std::mt19937 rng(21);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int trial = 0; trial < 20; ++trial) {
    SCOPED_TRACE(trial);
    TetMesh m = test::kuhnBox({8, 8, 8}, {-8, -8, -8}, {8, 8, 8});
    test::perturbInterior(m, {-8, -8, -8}, {8, 8, 8}, 2.0, 0.2, unsigned(trial));
    const VenantSources venant(m);
    const Vec3 x{u(rng), u(rng), u(rng)};
    const Vec3 M{g(rng), g(rng), g(rng)};
    const auto q = venant.monopoles(x, M);
    ASSERT_GE(q.size(), 10u); // a vertex and its neighbours
    double total = 0, scale = 0;
    Vec3 first{0, 0, 0}, second{0, 0, 0}, secondAbs{0, 0, 0};
    for (const auto& [v, c] : q) {
      const Vec3 d = m.points[size_t(v)] - x;
      total += c;
      scale += std::abs(c);
      first = first + c * d;
      for (size_t k = 0; k < 3; ++k) {
        second[k] += c * d[k] * d[k];
        secondAbs[k] += std::abs(c) * d[k] * d[k];
      }
      EXPECT_LE(norm(d), 2.0 * std::sqrt(3.0) * 1.5) << "a monopole far from the dipole";
    }
    EXPECT_NEAR(total, 0.0, 1e-14 * scale);
    // The Tikhonov term (1e-6) leaves the moments within a small fraction of |M|.
    EXPECT_LT(norm(first - M), 1e-3 * norm(M));
    for (size_t k = 0; k < 3; ++k) EXPECT_LT(std::abs(second[k]), 1e-3 * secondAbs[k]);
    // Linear in the moment.
    const auto q2 = venant.monopoles(x, 2.5 * M);
    ASSERT_EQ(q2.size(), q.size());
    for (size_t i = 0; i < q.size(); ++i) {
      EXPECT_EQ(q2[i].first, q[i].first);
      EXPECT_NEAR(q2[i].second, 2.5 * q[i].second, 1e-9 * scale);
    }
  }
}

TEST(VenantSource, ErrorsAreNamed) {
  const TetMesh m = test::kuhnBox({2, 2, 2}, {0, 0, 0}, {1, 1, 1});
  const VenantSources venant(m);
  EXPECT_THROW_MSG(venant.monopoles({5, 5, 5}, {0, 0, 1}), InputError, "outside the mesh");
  EXPECT_THROW_MSG(venant.monopoles({0.5, 0.5, 0.5}, {0, 0, 0}), InputError, "non-zero");
}

// A ball of radius R: the Kuhn box [-1, 1]^3 (n cells per axis) with each point p moved to
// R |p|_inf p / |p|_2, so the box's surface lands on the sphere (its faces are chords of it).
TetMesh kuhnBall(int n, double R) {
  TetMesh m = test::kuhnBox({n, n, n}, {-1, -1, -1}, {1, 1, 1});
  for (Vec3& p : m.points) {
    const double inf = std::max({std::abs(p[0]), std::abs(p[1]), std::abs(p[2])}), two = norm(p);
    if (two > 0) p = (R * inf / two) * p;
  }
  return m;
}

TEST(SubtractionSource, LoadCarriesNoNetCurrentAndIsLinearInTheMoment) {
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int trial = 0; trial < 6; ++trial) {
    SCOPED_TRACE(trial);
    // Two materials: the dipole's (label 1, 0.33 S/m) inside |x|_inf < 5, label 2 (1.79 S/m) outside.
    TetMesh m = test::kuhnBox({10, 10, 10}, {-8, -8, -8}, {8, 8, 8}, [](int i, int j, int k) {
      auto in = [](int c) { return c >= 2 && c < 8; };
      return in(i) && in(j) && in(k) ? 1 : 2;
    });
    test::perturbInterior(m, {-8, -8, -8}, {8, 8, 8}, 1.6, 0.2, unsigned(trial));
    ConductivityTable sigma;
    sigma.set(1, 0.33);
    sigma.set(2, 1.79);
    const SubtractionSources sub(m, sigma);
    const Vec3 x{u(rng), u(rng), u(rng)};
    const Vec3 M{g(rng), g(rng), g(rng)}, M2{g(rng), g(rng), g(rng)};
    EXPECT_EQ(sub.sigmaAt(x), 0.33);
    const Eigen::Index n = Eigen::Index(m.numPoints());
    Eigen::VectorXd f = Eigen::VectorXd::Zero(n), f2 = Eigen::VectorXd::Zero(n), fs = Eigen::VectorXd::Zero(n);
    sub.addLoad(x, M, f);
    sub.addLoad(x, M2, f2);
    sub.addLoad(x, 2.5 * M + M2, fs);
    const double scale = f.cwiseAbs().sum();
    ASSERT_GT(scale, 0);
    // The volume term sums to 0 exactly (the gradients of the hat functions do); the boundary
    // term, the flux of grad u_inf out of a closed surface around the dipole, is made to.
    EXPECT_LT(std::abs(f.sum()), 1e-13 * scale);
    EXPECT_LT((fs - 2.5 * f - f2).cwiseAbs().maxCoeff(), 1e-12 * scale);
  }
}

TEST(SubtractionSource, SingularPotentialIsTheUnboundedDipolesPotential) {
  const TetMesh m = kuhnBall(4, 10);
  ConductivityTable sigma;
  sigma.set(1, 0.5);
  const SubtractionSources sub(m, sigma);
  const Vec3 x0{1, -2, 0.5}, M{0.3, 0.1, -0.2};
  const std::vector<double> u = sub.singularPotential(x0, M);
  ASSERT_EQ(u.size(), m.numPoints());
  for (size_t v = 0; v < m.numPoints(); ++v) {
    const Vec3 r = m.points[v] - x0;
    const double expect = dot(M, r) / (4 * M_PI * 0.5 * std::pow(norm(r), 3));
    EXPECT_NEAR(u[v], expect, 1e-12 * std::abs(expect) + 1e-15);
  }
  // Positive ahead of the moment, negative behind it, 1/r^2 along it (V; mA mm, S/m, mm).
  EXPECT_NEAR(SubtractionSources::singularPotential({0, 0, 0}, {0, 0, 1}, 1.0, {0, 0, 2}), 1 / (16 * M_PI), 1e-15);
  EXPECT_NEAR(SubtractionSources::singularPotential({0, 0, 0}, {0, 0, 1}, 1.0, {0, 0, -4}), -1 / (64 * M_PI), 1e-15);
}

TEST(SubtractionSource, OnAHomogeneousBallItBeatsTheOtherModels) {
  // The ball's surface vertices lie on the sphere: the analytic potential of a one-shell sphere
  // there is the exact answer. The subtraction model leaves only the smooth correction to the
  // mesh, so its error is the smallest of the three, for dipoles near the centre and near the
  // surface alike.
  const double R = 50;
  const TetMesh m = kuhnBall(14, R);
  const SphereShells shell{{R}, {0.33}};
  std::vector<int32_t> surface;
  std::vector<Vec3> electrodes;
  {
    const std::vector<uint8_t> b = boundaryVertexFlags(m);
    for (size_t v = 0; v < b.size(); ++v)
      if (b[v]) surface.push_back(int32_t(v)), electrodes.push_back(m.points[v]);
  }
  for (const auto& [x, M] : std::vector<std::pair<Vec3, Vec3>>{{{3, -2, 12}, {0.002, 0.001, 0.01}},
                                                              {{10, 20, 25}, {0.01, -0.004, 0.003}}}) {
    SCOPED_TRACE(norm(x) / R);
    const std::vector<double> exact = sphereDipolePotentials(shell, x, M, electrodes);
    std::map<SourceModel, double> rdm;
    for (SourceModel model : {SourceModel::PartialIntegration, SourceModel::Venant, SourceModel::Subtraction}) {
      PoissonParams p;
      p.boundary = BoundaryCondition::Dipole;
      p.conductivities.set(1, 0.33);
      p.dipole_position = x;
      p.dipole_moment = M;
      p.sourceModel = model;
      p.condition_numbers = false;
      NullProgress np;
      const PoissonResult r = solvePoisson(m, p, np);
      ASSERT_TRUE(r.converged);
      EXPECT_EQ(r.potential[size_t(r.referenceVertices[0])], 0.0);
      EXPECT_EQ(r.singularPotential.empty(), model != SourceModel::Subtraction);
      std::vector<double> fem;
      for (int32_t v : surface) fem.push_back(r.potential[size_t(v)]);
      const ForwardErrors e = compareToAnalytic(fem, exact);
      rdm[model] = e.rdm;
      std::printf("ball R %g, ecc %.2f, %s: RDM %.4f, MAG %.4f\n", R, norm(x) / R, sourceModelName(model), e.rdm,
                  e.mag);
      if (model == SourceModel::Subtraction) {
        EXPECT_LT(std::abs(e.lnMag), 0.02);
      }
    }
    // Measured (n = 14, 7 mm cells): RDM 0.126 / 0.060 / 0.003 at eccentricity 0.25 and
    // 0.189 / 0.098 / 0.013 at 0.67 (partial integration / Venant / subtraction).
    EXPECT_LT(rdm[SourceModel::Subtraction], 0.5 * rdm[SourceModel::PartialIntegration]);
    EXPECT_LT(rdm[SourceModel::Subtraction], 0.5 * rdm[SourceModel::Venant]);
    EXPECT_LT(rdm[SourceModel::Subtraction], 0.02);
  }
}

TEST(SubtractionSource, ErrorsAreNamed) {
  TetMesh m = test::kuhnBox({2, 2, 2}, {0, 0, 0}, {1, 1, 1}, [](int i, int, int) { return i == 0 ? 1 : 2; });
  ConductivityTable sigma;
  sigma.set(1, 0.33);
  sigma.set(2, SymTensor6{0.1, 0.2, 0.3, 0, 0, 0});
  const SubtractionSources sub(m, sigma);
  Eigen::VectorXd f = Eigen::VectorXd::Zero(Eigen::Index(m.numPoints()));
  EXPECT_THROW_MSG(sub.addLoad({5, 5, 5}, {0, 0, 1}, f), InputError, "outside the mesh");
  EXPECT_THROW_MSG(sub.addLoad({0.25, 0.5, 0.5}, {0, 0, 0}, f), InputError, "non-zero");
  EXPECT_THROW_MSG(sub.addLoad({0.75, 0.5, 0.5}, {0, 0, 1}, f), InputError, "(label 2) is anisotropic");
  EXPECT_NO_THROW(sub.addLoad({0.25, 0.5, 0.5}, {0, 0, 1}, f));
  PoissonParams p;
  p.boundary = BoundaryCondition::Dipole;
  p.conductivities = sigma;
  p.dipole_position = {0.25, 0.5, 0.5};
  p.dipole_separation = 0.1;
  p.sourceModel = SourceModel::Subtraction;
  NullProgress np;
  EXPECT_THROW_MSG(solvePoisson(m, p, np), InputError, "dipole_separation must be 0");
  EXPECT_THROW_MSG(sourceModelFromName("dipole"), InputError, "use partial_integration, venant or subtraction");
  EXPECT_THROW_MSG(dipoleLoads(m, {{0.25, 0.5, 0.5}}, {0}, SourceModel::Subtraction), InputError,
                   "the MEG lead field takes partial_integration or venant");
}

} // namespace
} // namespace tetflow
