// P1 assembly (Algorithms/FEM/Assembly.h) and conductivity parsing (Conductivity.h).
#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Dense>

#include <cmath>
#include <map>
#include <set>
#include <random>

#include "Algorithms/FEM/Assembly.h"
#include "Algorithms/FEM/BoundaryConditions.h"
#include "Algorithms/FEM/Conductivity.h"
#include "FemTestMeshes.h"
#include "TestUtil.h"

using namespace tetflow;
using tetflow::test::kuhnBox;
using tetflow::test::perturbInterior;

namespace {
TetMesh perturbedBox(std::array<int, 3> n, unsigned seed,
                     const std::function<int32_t(int, int, int)>& label = nullptr) {
  const Vec3 lo{0, 0, 0}, hi{double(n[0]), double(n[1]), double(n[2])};
  TetMesh m = kuhnBox(n, lo, hi, label);
  perturbInterior(m, lo, hi, 1.0, 0.15, seed);
  return m;
}
} // namespace

TEST(FemAssembly, RowsSumToZeroAndMatrixIsSymmetricPositiveSemidefinite) {
  const TetMesh m = perturbedBox({4, 3, 3}, 7, [](int i, int, int) { return i < 2 ? 1 : 2; });
  ConductivityTable s;
  s.set(1, 0.33);
  s.set(2, 0.0042);
  NullProgress np;
  const SparseMatrix K = assembleStiffness(m, s, np);
  ASSERT_EQ(K.rows(), int64_t(m.numPoints()));
  EXPECT_TRUE(K.isCompressed());
  // Exactly symmetric (bitwise), constants in the null space.
  const Eigen::MatrixXd D(K);
  EXPECT_EQ((D - D.transpose()).cwiseAbs().maxCoeff(), 0.0);
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(K.rows());
  EXPECT_LT((K * ones).cwiseAbs().maxCoeff(), 1e-14 * D.cwiseAbs().maxCoeff());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(D);
  EXPECT_GT(es.eigenvalues()[0], -1e-12 * es.eigenvalues().maxCoeff());
  EXPECT_GT(es.eigenvalues()[1], 0.0); // connected mesh: one-dimensional null space
}

TEST(FemAssembly, EnergyOfLinearFunctionsIsExactIncludingAnisotropicTensors) {
  // u = g . x: u^T K u = sum_T vol_T g^T sigma_T g, exactly, for any SPD tensor per label.
  const TetMesh m = perturbedBox({3, 3, 3}, 11, [](int i, int j, int) { return 1 + (i + j) % 3; });
  ConductivityTable s;
  s.defaultSigma = 0.5;
  s.set(1, SymTensor6{2.0, 1.0, 0.5, 0.3, -0.2, 0.1});
  s.set(2, 0.7);
  // label 3 uses the default
  NullProgress np;
  const SparseMatrix K = assembleStiffness(m, s, np);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uni(-1, 1);
  for (int trial = 0; trial < 3; ++trial) {
    const Vec3 g{uni(rng), uni(rng), uni(rng)};
    Eigen::VectorXd u(Eigen::Index(m.numPoints()));
    for (size_t v = 0; v < m.numPoints(); ++v) u[Eigen::Index(v)] = dot(g, m.points[v]);
    double expected = 0;
    for (size_t t = 0; t < m.numTets(); ++t)
      expected += m.tetVolume(t) * dot(g, mul(tensorMatrix(s.tensor(m.materials[t])), g));
    EXPECT_NEAR(u.dot(K * u), expected, 1e-12 * std::abs(expected));
  }
}

TEST(FemAssembly, ElementMatrixOfTheCornerTet) {
  // Corner tet (0,0,0),(1,0,0),(0,1,0),(0,0,1), sigma = 2: K = sigma/6 * [[3,-1,-1,-1],[-1,1,0,0],...].
  TetMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.tets = {{0, 1, 2, 3}};
  m.materials = {4};
  ConductivityTable s;
  s.set(4, 2.0);
  NullProgress np;
  const Eigen::MatrixXd K(assembleStiffness(m, s, np));
  Eigen::MatrixXd E(4, 4);
  E << 3, -1, -1, -1, -1, 1, 0, 0, -1, 0, 1, 0, -1, 0, 0, 1;
  E *= 2.0 / 6.0;
  EXPECT_LT((K - E).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(FemAssembly, ResultDoesNotDependOnTheThreadCount) {
  const TetMesh m = perturbedBox({14, 12, 10}, 5, [](int i, int j, int k) { return (i + j + k) % 2; });
  ConductivityTable s;
  s.set(0, 1.3);
  s.set(1, SymTensor6{1, 2, 3, 0.1, 0.2, 0.3});
  NullProgress np;
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  const SparseMatrix K1 = assembleStiffness(m, s, np);
  omp_set_num_threads(2);
  const SparseMatrix K2 = assembleStiffness(m, s, np);
  omp_set_num_threads(saved);
  ASSERT_EQ(K1.nonZeros(), K2.nonZeros());
  for (int64_t i = 0; i < K1.nonZeros(); ++i) {
    ASSERT_EQ(K1.innerIndexPtr()[i], K2.innerIndexPtr()[i]);
    ASSERT_EQ(K1.valuePtr()[i], K2.valuePtr()[i]);
  }
}

TEST(FemAssembly, ResultDoesNotDependOnTheStarBlockSizeAndIsExactlySymmetric) {
  // The vertex stars are produced in blocks of at most `blockCorners` tet corners (VertexStars.h):
  // one corner per block, 37, and everything at once give the same bits. The anisotropic tensor
  // exercises the symmetric bilinear form.
  const TetMesh m = perturbedBox({6, 5, 4}, 9, [](int i, int j, int) { return (i + 2 * j) % 3; });
  ConductivityTable s;
  s.set(0, 0.7);
  s.set(1, SymTensor6{1.5, 0.5, 2.5, -0.3, 0.2, 0.4});
  s.set(2, SymTensor6{1, 1, 1, 0, 0, 0.9});
  NullProgress np;
  const SparseMatrix ref = assembleStiffness(m, s, np, int64_t(1) << 40);
  for (int64_t block : {1, 37, 1000}) {
    const SparseMatrix K = assembleStiffness(m, s, np, block);
    ASSERT_EQ(K.nonZeros(), ref.nonZeros()) << block;
    for (int64_t i = 0; i < K.nonZeros(); ++i) {
      ASSERT_EQ(K.innerIndexPtr()[i], ref.innerIndexPtr()[i]) << block;
      ASSERT_EQ(K.valuePtr()[i], ref.valuePtr()[i]) << block;
    }
  }
  const SparseMatrix T = ref.transpose();
  ASSERT_EQ(T.nonZeros(), ref.nonZeros());
  for (int64_t i = 0; i < T.nonZeros(); ++i) {
    ASSERT_EQ(T.innerIndexPtr()[i], ref.innerIndexPtr()[i]);
    ASSERT_EQ(T.valuePtr()[i], ref.valuePtr()[i]); // bitwise
  }
  // Columns are sorted and hold exactly the vertices sharing a tet with the column's vertex.
  for (int j = 0; j < ref.cols(); ++j) {
    std::set<int> expected;
    for (const auto& t : m.tets)
      if (t[0] == j || t[1] == j || t[2] == j || t[3] == j) expected.insert(t.begin(), t.end());
    std::vector<int> got(ref.innerIndexPtr() + ref.outerIndexPtr()[j], ref.innerIndexPtr() + ref.outerIndexPtr()[j + 1]);
    ASSERT_EQ(got, std::vector<int>(expected.begin(), expected.end())) << "column " << j;
  }
}

TEST(FemAssembly, CancellingStopsBetweenStarBlocks) {
  struct CancelOnFirstReport : Progress {
    void onReport(double) override { requestCancel(); }
  };
  const TetMesh m = perturbedBox({6, 5, 4}, 3);
  ConductivityTable s;
  CancelOnFirstReport cancel;
  EXPECT_THROW(assembleStiffness(m, s, cancel, 50), Cancelled);
}

TEST(FemAssembly, BoundaryVerticesMatchAFaceCountOnRandomSubsets) {
  // Random subsets of a box's tets (holes, pinched vertices, separate pieces): a vertex is on the
  // boundary exactly when it lies on a face used by one tet.
  std::mt19937 rng(21);
  for (int trial = 0; trial < 20; ++trial) {
    TetMesh m = perturbedBox({4, 4, 3}, unsigned(trial));
    std::vector<TetMesh::Tet> kept;
    for (const auto& t : m.tets)
      if (rng() % 3 != 0) kept.push_back(t);
    m.tets = kept;
    m.materials.assign(kept.size(), 1);
    std::map<std::array<int32_t, 3>, int> faces;
    for (const auto& t : m.tets)
      for (int k = 0; k < 4; ++k) {
        std::array<int32_t, 3> f;
        int n = 0;
        for (int i = 0; i < 4; ++i)
          if (i != k) f[size_t(n++)] = t[size_t(i)];
        std::sort(f.begin(), f.end());
        ++faces[f];
      }
    std::vector<uint8_t> expected(m.numPoints(), 0);
    for (const auto& [f, c] : faces)
      if (c == 1)
        for (int32_t v : f) expected[size_t(v)] = 1;
    EXPECT_EQ(boundaryVertexFlags(m), expected) << "trial " << trial;
  }
}

TEST(FemAssembly, LoadVectorsAreConsistent) {
  const TetMesh m = perturbedBox({3, 2, 2}, 2);
  double vol = 0;
  for (size_t t = 0; t < m.numTets(); ++t) vol += m.tetVolume(t);
  const Eigen::VectorXd b = assembleLoad(m, 2.5);
  EXPECT_NEAR(b.sum(), 2.5 * vol, 1e-12 * vol);
  // Piecewise linear f = 1 + x: integral of f phi_i summed = integral of f = vol + int x.
  std::vector<double> f;
  for (const auto& p : m.points) f.push_back(1.0 + p[0]);
  const Eigen::VectorXd bf = assembleLoad(m, f);
  double integral = 0;
  for (size_t t = 0; t < m.numTets(); ++t) {
    Vec3 c{0, 0, 0};
    for (int32_t v : m.tets[t]) c = c + 0.25 * m.points[v];
    integral += m.tetVolume(t) * (1.0 + c[0]);
  }
  EXPECT_NEAR(bf.sum(), integral, 1e-12 * integral);
  // Constant f through the per-vertex form equals the constant form.
  const Eigen::VectorXd bc = assembleLoad(m, std::vector<double>(m.numPoints(), 2.5));
  EXPECT_LT((bc - b).cwiseAbs().maxCoeff(), 1e-13);
}

TEST(FemAssembly, BoundaryVerticesOfABox) {
  const TetMesh m = kuhnBox({4, 3, 2}, {0, 0, 0}, {4, 3, 2});
  const auto flags = boundaryVertexFlags(m);
  int64_t count = 0;
  for (auto f : flags) count += f;
  EXPECT_EQ(count, 5 * 4 * 3 - 3 * 2 * 1); // all grid vertices minus the interior ones
  int32_t comps = 0;
  const auto comp = vertexComponents(m, comps);
  EXPECT_EQ(comps, 1);
  EXPECT_EQ(comp[0], 0);
}

TEST(FemAssembly, DipoleLoadActsOnLinearFunctionsAsTheMoment) {
  // sum_a b_a w_a = m . g for w = g . x, both for the limit form and for the monopole pair.
  const TetMesh m = perturbedBox({4, 4, 4}, 9);
  const Vec3 g{0.3, -1.2, 0.7};
  std::vector<double> w;
  for (const auto& p : m.points) w.push_back(dot(g, p));
  const Vec3 pos{1.9, 2.2, 2.05}, mom{0.5, 1.0, -2.0};
  for (double sep : {0.0, 0.5}) {
    Eigen::VectorXd b = Eigen::VectorXd::Zero(Eigen::Index(m.numPoints()));
    const auto tets = addDipole(m, pos, mom, sep, b);
    EXPECT_EQ(tets.size(), sep == 0.0 ? 1u : 2u);
    double s = 0;
    for (size_t v = 0; v < m.numPoints(); ++v) s += b[Eigen::Index(v)] * w[v];
    EXPECT_NEAR(s, dot(mom, g), 1e-12) << "separation " << sep;
    EXPECT_NEAR(b.sum(), 0.0, 1e-12);
  }
  // Point location: barycentric coordinates reproduce the point.
  const auto loc = locatePoint(m, pos);
  ASSERT_TRUE(loc.has_value());
  Vec3 back{0, 0, 0};
  for (int a = 0; a < 4; ++a) back = back + loc->bary[size_t(a)] * m.points[m.tets[size_t(loc->tet)][size_t(a)]];
  EXPECT_LT(norm(back - pos), 1e-12);
  EXPECT_FALSE(locatePoint(m, {9, 9, 9}).has_value());
}

TEST(FemAssembly, SymmetricEliminationKeepsAPrincipalSubmatrix) {
  const TetMesh m = perturbedBox({3, 3, 3}, 4);
  ConductivityTable s;
  NullProgress np;
  const SparseMatrix K = assembleStiffness(m, s, np);
  Eigen::VectorXd f = Eigen::VectorXd::LinSpaced(K.rows(), 0.0, 1.0);
  DirichletSet d(m.numPoints());
  d.set(0, 2.0);
  d.set(5, -1.0);
  d.set(17, 0.5);
  const ReducedSystem r = eliminateDirichlet(K, f, d);
  ASSERT_EQ(r.K.rows(), K.rows() - 3);
  const Eigen::MatrixXd D(K), R(r.K);
  Eigen::VectorXd ud = Eigen::VectorXd::Zero(K.rows());
  ud[0] = 2.0;
  ud[5] = -1.0;
  ud[17] = 0.5;
  const Eigen::VectorXd full = f - D * ud;
  for (Eigen::Index a = 0; a < R.rows(); ++a) {
    EXPECT_NEAR(r.b[a], full[r.freeVertex[size_t(a)]], 1e-14);
    for (Eigen::Index c = 0; c < R.cols(); ++c)
      ASSERT_EQ(R(a, c), D(r.freeVertex[size_t(a)], r.freeVertex[size_t(c)]));
  }
  const Eigen::VectorXd u = r.expand(Eigen::VectorXd::Zero(R.rows()));
  EXPECT_EQ(u[5], -1.0);
  EXPECT_EQ(u[1], 0.0);
}

TEST(FemAssembly, InvertedOrDegenerateTetIsAnInputErrorNamingIt) {
  TetMesh m = kuhnBox({2, 2, 2}, {0, 0, 0}, {2, 2, 2});
  std::swap(m.tets[7][0], m.tets[7][1]);
  ConductivityTable s;
  NullProgress np;
  EXPECT_THROW_MSG(assembleStiffness(m, s, np), InputError, "tet 7 ", "inverted");
  m = kuhnBox({2, 2, 2}, {0, 0, 0}, {2, 2, 2});
  m.tets[12][3] = m.tets[12][2]; // repeated vertex: zero volume
  EXPECT_THROW_MSG(assembleStiffness(m, s, np), InputError, "tet 12 ", "zero volume");
}

TEST(FemConductivity, ParsesIsotropicAndTensorEntries) {
  const auto t = parseConductivities({"1:0.33", " 2 : 0.0042 ", "5:0.1 0.1 1.0 0 0 0", "-3:1,2,3,0,0,0", ""}, 0.25);
  EXPECT_EQ(t.defaultSigma, 0.25);
  EXPECT_EQ(t.tensor(1), isotropicTensor(0.33));
  EXPECT_EQ(t.tensor(2), isotropicTensor(0.0042));
  EXPECT_EQ(t.tensor(5), (SymTensor6{0.1, 0.1, 1.0, 0, 0, 0}));
  EXPECT_EQ(t.tensor(-3), (SymTensor6{1, 2, 3, 0, 0, 0}));
  EXPECT_EQ(t.tensor(9), isotropicTensor(0.25));
  EXPECT_TRUE(t.isotropic(1));
  EXPECT_FALSE(t.isotropic(5));
  const auto lv = parseLabelValues({"5:1", "6: -0.5"}, "electrode_potentials");
  EXPECT_EQ(lv.at(5), 1.0);
  EXPECT_EQ(lv.at(6), -0.5);
  EXPECT_EQ(parseVec3("1, -2 3.5", "dipole_position"), (Vec3{1, -2, 3.5}));
}

TEST(FemConductivity, BadTextIsAnInputErrorNamingTheEntry) {
  EXPECT_THROW_MSG(parseConductivities({"scalp:0.33"}, 1), InputError, "conductivities", "'scalp:0.33'", "not an integer");
  EXPECT_THROW_MSG(parseConductivities({"1 0.33"}, 1), InputError, "conductivities", "no ':'");
  EXPECT_THROW_MSG(parseConductivities({"1:abc"}, 1), InputError, "'abc' is not a finite number");
  EXPECT_THROW_MSG(parseConductivities({"1:-2"}, 1), InputError, "'1:-2'", "> 0");
  EXPECT_THROW_MSG(parseConductivities({"1:1 2"}, 1), InputError, "1 value", "6", "not 2");
  EXPECT_THROW_MSG(parseConductivities({"1:1 1 1 5 0 0"}, 1), InputError, "not positive definite");
  EXPECT_THROW_MSG(parseConductivities({"1:1", "1:2"}, 1), InputError, "label 1 is listed twice");
  EXPECT_THROW_MSG(parseConductivities({}, 0.0), InputError, "default_conductivity");
  EXPECT_THROW_MSG(parseLabelValues({"5:x"}, "electrode_potentials"), InputError, "electrode_potentials", "'x'");
  EXPECT_THROW_MSG(parseVec3("1 2", "dipole_moment"), InputError, "dipole_moment", "three");
  EXPECT_EQ(parseNumbers("78, 80 86  92", "radii"), (std::vector<double>{78, 80, 86, 92}));
  EXPECT_TRUE(parseNumbers("  ", "radii").empty());
  EXPECT_THROW_MSG(parseNumbers("78 80 x", "radii"), InputError, "radii", "'x'", "not a finite number");
  EXPECT_THROW_MSG(parseNumbers("1 inf", "radii"), InputError, "'inf'");
  EXPECT_EQ(parseLabels({"4", " -2 "}, "source_labels"), (std::vector<int32_t>{4, -2}));
  EXPECT_THROW_MSG(parseLabels({"brain"}, "source_labels"), InputError, "source_labels", "'brain'", "integer label");
  EXPECT_THROW_MSG(parseLabels({"4000000000"}, "source_labels"), InputError, "'4000000000'");
}
