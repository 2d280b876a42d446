// The analytic multi-shell sphere (Algorithms/FEM/AnalyticSphere.h): closed forms, invariances,
// an independent radial finite-volume solve of single Legendre degrees, and the error measures.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/FEM/AnalyticSphere.h"
#include "FemTestMeshes.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {

const SphereShells kHead{{78, 80, 86, 92}, {0.33, 1.79, 0.0042, 0.33}}; // brain CSF skull scalp

using tetflow::test::randomUnit;

// Fibonacci points on the unit sphere scaled to radius R.
std::vector<Vec3> electrodes(int n, double R) {
  std::vector<Vec3> e;
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n, s = std::sqrt(1.0 - z * z), ph = 2.399963229 * i;
    e.push_back({R * s * std::cos(ph), R * s * std::sin(ph), R * z});
  }
  return e;
}

// Homogeneous insulated sphere, r on the surface (Frank 1952; Brody, Terry & Ideker 1973):
// m . grad_r0 of the point-source potential I/(4 pi sigma) [2/d + (1/R) ln(2R^2/(R^2 - r.r0 + R d))]
// (generating functions of sum (2l+1)/l t^l P_l), d = |r - r0|; zero mean over the sphere.
double homogeneousSphere(double R, double sigma, const Vec3& r0, const Vec3& m, const Vec3& r) {
  const Vec3 dr = r - r0;
  const double d = norm(dr);
  const double direct = 2.0 * dot(m, dr) / (d * d * d);
  const double image = dot(m, d * r + R * dr) / (R * d * (R * d + R * R - dot(r, r0)));
  return (direct + image) / (4.0 * std::numbers::pi * sigma);
}

using tetflow::test::maxAbs;

// Independent check of one Legendre degree: the radial equation of a unit point source at radius
// a, -(sigma r^2 f')' + l(l+1) sigma f = (2l+1)/(4 pi) delta(r - a), f(0) = 0, f'(R) = 0, by
// node-centred finite volumes (nodes at 0, a and every interface, `perMm` cells per mm); f(R).
double radialFiniteVolume(const SphereShells& s, int l, double a, double perMm) {
  std::vector<double> breaks{0.0, a};
  breaks.insert(breaks.end(), s.radii.begin(), s.radii.end());
  std::vector<double> r{0.0}, sig; // nodes, conductivity per cell
  size_t source = 0;
  for (size_t k = 0; k + 1 < breaks.size(); ++k) {
    const int n = std::max(4, int(std::ceil((breaks[k + 1] - breaks[k]) * perMm)));
    const double sigma = s.conductivities[k == 0 ? 0 : k - 1];
    for (int i = 1; i <= n; ++i) {
      r.push_back(breaks[k] + (breaks[k + 1] - breaks[k]) * i / n);
      sig.push_back(sigma);
    }
    if (k == 0) source = r.size() - 1;
  }
  const size_t N = r.size();
  std::vector<double> lo(N, 0), di(N, 0), up(N, 0), rhs(N, 0);
  const double ll = l * (l + 1.0);
  for (size_t c = 0; c + 1 < N; ++c) { // cell [r_c, r_c+1]
    const double h = r[c + 1] - r[c], mid = 0.5 * (r[c] + r[c + 1]);
    const double k = sig[c] * mid * mid / h, react = 0.5 * ll * sig[c] * h;
    di[c] += k + react;
    di[c + 1] += k + react;
    up[c] -= k;
    lo[c + 1] -= k;
  }
  rhs[source] = (2.0 * l + 1.0) / (4.0 * std::numbers::pi);
  di[0] = 1.0, up[0] = 0.0, rhs[0] = 0.0; // f(0) = 0
  for (size_t i = 1; i < N; ++i) {      // Thomas
    const double w = lo[i] / di[i - 1];
    di[i] -= w * up[i - 1];
    rhs[i] -= w * rhs[i - 1];
  }
  std::vector<double> f(N);
  f[N - 1] = rhs[N - 1] / di[N - 1];
  for (size_t i = N - 1; i-- > 0;) f[i] = (rhs[i] - up[i] * f[i + 1]) / di[i];
  return f[N - 1];
}

} // namespace

TEST(AnalyticSphere, OneShellMatchesTheHomogeneousClosedForm) {
  std::mt19937 rng(20240517);
  std::uniform_real_distribution<double> ecc(0.0, 0.9), mag(0.001, 0.1);
  const double R = 85.0, sigma = 0.33;
  const SphereShells one{{R}, {sigma}};
  for (int trial = 0; trial < 20; ++trial) {
    const Vec3 r0 = ecc(rng) * R * randomUnit(rng), m = mag(rng) * randomUnit(rng);
    std::vector<Vec3> el;
    for (int i = 0; i < 30; ++i) el.push_back(R * randomUnit(rng));
    el.push_back((R / norm(r0)) * r0); // closest surface point
    const std::vector<double> v = sphereDipolePotentials(one, r0, m, el);
    const double scale = maxAbs(v);
    for (size_t i = 0; i < el.size(); ++i)
      EXPECT_NEAR(v[i], homogeneousSphere(R, sigma, r0, m, el[i]), 1e-9 * scale)
          << "trial " << trial << " electrode " << i;
  }
}

TEST(AnalyticSphere, EqualConductivitiesEqualOneShell) {
  const SphereShells many{{40, 55, 56, 70, 92}, {0.5, 0.5, 0.5, 0.5, 0.5}}, one{{92}, {0.5}};
  std::mt19937 rng(7);
  const std::vector<Vec3> el = electrodes(64, 92);
  for (int trial = 0; trial < 5; ++trial) {
    const Vec3 r0 = 35.0 * randomUnit(rng), m = 0.01 * randomUnit(rng);
    const std::vector<double> a = sphereDipolePotentials(many, r0, m, el);
    const std::vector<double> b = sphereDipolePotentials(one, r0, m, el);
    for (size_t i = 0; i < el.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-10 * maxAbs(b));
  }
}

TEST(AnalyticSphere, DipoleAtTheCentreIsTheDegreeOneTerm) {
  const double R = 92, sigma = 0.33;
  const Vec3 m{0.003, -0.01, 0.02};
  std::mt19937 rng(3);
  for (int i = 0; i < 10; ++i) {
    const Vec3 rhat = randomUnit(rng);
    int terms = 0;
    const double v = sphereDipolePotential({{R}, {sigma}}, {0, 0, 0}, m, 50.0 * rhat, 100, 1e-12,
                                           &terms);
    EXPECT_NEAR(v, 3.0 * dot(m, rhat) / (4 * std::numbers::pi * sigma * R * R), 1e-15);
    EXPECT_EQ(terms, 1);
    // 4 shells: still exactly l = 1, a cosine of the angle to the moment.
    const double w = sphereDipolePotential(kHead, {0, 0, 0}, m, rhat, 100, 1e-12, &terms);
    EXPECT_EQ(terms, 1);
    const double c = sphereDipolePotential(kHead, {0, 0, 0}, m, m);
    EXPECT_NEAR(w, c * dot(m, rhat) / norm(m), 1e-12 * std::abs(c));
  }
}

TEST(AnalyticSphere, LinearInTheMomentAndRotationInvariant) {
  std::mt19937 rng(11);
  const std::vector<Vec3> el = electrodes(50, 92);
  const Vec3 r0{10, -25, 45}, m1{0.01, 0.002, -0.004}, m2{-0.003, 0.007, 0.005};
  const std::vector<double> v1 = sphereDipolePotentials(kHead, r0, m1, el);
  const std::vector<double> v2 = sphereDipolePotentials(kHead, r0, m2, el);
  const std::vector<double> v12 = sphereDipolePotentials(kHead, r0, 2.0 * m1 + (-3.0) * m2, el);
  for (size_t i = 0; i < el.size(); ++i)
    EXPECT_NEAR(v12[i], 2 * v1[i] - 3 * v2[i], 1e-11 * maxAbs(v12));
  for (int trial = 0; trial < 3; ++trial) { // rotation (Rodrigues) of everything
    const Vec3 k = randomUnit(rng);
    const double t = 0.3 + 2.0 * trial, c = std::cos(t), s = std::sin(t);
    Mat3 Q;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        Q[i][j] = (i == j ? c : 0.0) + (1 - c) * k[i] * k[j] +
                  s * (i == j ? 0.0 : ((j - i + 3) % 3 == 1 ? -k[3 - i - j] : k[3 - i - j]));
    EXPECT_NEAR(det(Q), 1.0, 1e-12);
    std::vector<Vec3> elQ;
    for (const Vec3& e : el) elQ.push_back(mul(Q, e));
    const std::vector<double> w = sphereDipolePotentials(kHead, mul(Q, r0), mul(Q, m1), elQ);
    for (size_t i = 0; i < el.size(); ++i) EXPECT_NEAR(w[i], v1[i], 1e-11 * maxAbs(v1));
  }
}

TEST(AnalyticSphere, ElectrodesAreProjectedAndTheVectorVersionAgrees) {
  const Vec3 r0{0, 30, 20}, m{0.01, 0, 0.01};
  const std::vector<Vec3> el = electrodes(20, 92);
  const std::vector<double> v = sphereDipolePotentials(kHead, r0, m, el);
  for (size_t i = 0; i < el.size(); ++i) {
    EXPECT_EQ(sphereDipolePotential(kHead, r0, m, el[i]), v[i]);
    EXPECT_NEAR(sphereDipolePotential(kHead, r0, m, 0.7 * el[i]), v[i], 1e-14 * maxAbs(v));
  }
}

TEST(AnalyticSphere, DegreesMatchAnIndependentRadialFiniteVolumeSolve) {
  // Transfer recursion vs a direct discretisation of the radial equation through all four shells
  // (Richardson-extrapolated second-order finite volumes; agreement ~ 1e-10), sources at 40, 70 mm.
  for (double a : {40.0, 70.0})
    for (int l : {1, 2, 3, 5, 8}) {
      const double coarse = radialFiniteVolume(kHead, l, a, 20);
      const double fine = radialFiniteVolume(kHead, l, a, 40);
      const double fv = (4 * fine - coarse) / 3, series = spherePointSourceCoefficient(kHead, l, a);
      EXPECT_NEAR(series, fv, 1e-8 * std::abs(series)) << "l = " << l << ", a = " << a;
    }
  // The same check on one shell, where the coefficient is (2l+1)/l a^l / (4 pi sigma R^(l+1)).
  const SphereShells one{{90}, {0.4}};
  for (int l : {1, 4}) {
    const double exact = (2.0 * l + 1) / l * std::pow(50.0 / 90, l) / (4 * std::numbers::pi * 0.4 * 90);
    EXPECT_NEAR(spherePointSourceCoefficient(one, l, 50), exact, 1e-14 * exact);
    EXPECT_NEAR(radialFiniteVolume(one, l, 50, 40), exact, 1e-4 * exact);
  }
}

TEST(AnalyticSphere, TheSkullAttenuatesTheScalpPotential) {
  SphereShells homogeneous = kHead;
  homogeneous.conductivities = {0.33, 0.33, 0.33, 0.33};
  const std::vector<Vec3> el = electrodes(100, 92);
  for (const Vec3& m : {Vec3{0, 0, 0.01}, Vec3{0.01, 0, 0}}) {
    const std::vector<double> head = sphereDipolePotentials(kHead, {0, 0, 40}, m, el);
    const std::vector<double> hom = sphereDipolePotentials(homogeneous, {0, 0, 40}, m, el);
    const ForwardErrors e = compareToAnalytic(head, hom);
    EXPECT_LT(e.mag, 0.6);  // ~ 0.5: the resistive skull shields the scalp
    EXPECT_GT(e.rdm, 0.15); // ~ 0.25: and smears the topography
  }
  // Low-pass: each higher degree is attenuated more (head / homogeneous 0.56, 0.31, 0.20, ...).
  double previous = 1.0;
  for (int l = 1; l <= 10; ++l) {
    const double ratio = spherePointSourceCoefficient(kHead, l, 40) /
                         spherePointSourceCoefficient(homogeneous, l, 40);
    EXPECT_LT(ratio, l == 1 ? 0.6 : 0.9 * previous) << "l = " << l;
    previous = ratio;
  }
}

TEST(AnalyticSphere, EccentricDipolesConvergeAndTheCapIsAProcessingError) {
  const std::vector<Vec3> el = electrodes(40, 92);
  for (double ecc : {0.5, 0.8, 0.9, 0.95}) {
    int terms = 0;
    const std::vector<double> v =
        sphereDipolePotentials(kHead, {0, 0, ecc * 78}, {0.01, 0, 0.01}, el, 10000, 1e-12, &terms);
    EXPECT_GT(terms, 10);
    EXPECT_LT(terms, 400);
    for (double x : v) EXPECT_TRUE(std::isfinite(x));
  }
  int terms = 0; // one shell at 0.95: the slowest case still converges, to the closed form
  const Vec3 r0{0, 0, 0.95 * 92}, m{0, 0.01, 0.01}, el0{0, 20, 90};
  const double v = sphereDipolePotential({{92}, {0.33}}, r0, m, el0, 10000, 1e-12, &terms);
  EXPECT_NEAR(v, homogeneousSphere(92, 0.33, r0, m, (92 / norm(el0)) * el0), 1e-9 * std::abs(v));
  EXPECT_LT(terms, 10000);
  EXPECT_THROW(sphereDipolePotential(kHead, {0, 0, 70}, {0, 0, 1}, {0, 1, 1}, 5), ProcessingError);
}

TEST(AnalyticSphere, ForwardErrorMeasures) {
  const std::vector<double> u{1.0, -2.0, 0.5, 3.0, -1.5};
  std::vector<double> u2, neg, shifted;
  for (double x : u) u2.push_back(2 * x), neg.push_back(-x), shifted.push_back(x + 7.0);
  ForwardErrors e = compareToAnalytic(u, u);
  EXPECT_EQ(e.rdm, 0.0);
  EXPECT_EQ(e.mag, 1.0);
  EXPECT_EQ(e.lnMag, 0.0);
  e = compareToAnalytic(u2, u);
  EXPECT_NEAR(e.rdm, 0.0, 1e-15);
  EXPECT_NEAR(e.mag, 2.0, 1e-15);
  EXPECT_NEAR(e.lnMag, std::log(2.0), 1e-15);
  e = compareToAnalytic(neg, u);
  EXPECT_NEAR(e.rdm, 2.0, 1e-15);
  EXPECT_NEAR(e.mag, 1.0, 1e-15);
  e = compareToAnalytic(shifted, u); // average reference: a constant offset is invisible
  EXPECT_NEAR(e.rdm, 0.0, 1e-15);
  EXPECT_NEAR(e.mag, 1.0, 1e-14);
  // Orthogonal (after referencing) topographies: RDM = sqrt(2).
  e = compareToAnalytic({1, -1, 0, 0}, {0, 0, 1, -1});
  EXPECT_NEAR(e.rdm, std::sqrt(2.0), 1e-15);
}

namespace {
template <class F>
void expectInputError(F f, const std::string& part) {
  try {
    f();
    ADD_FAILURE() << "no InputError, expected one mentioning \"" << part << "\"";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}
} // namespace

TEST(AnalyticSphere, BadInputsAreInputErrors) {
  const Vec3 p{0, 0, 10}, m{0, 0, 1}, el{0, 0, 92};
  auto pot = [&](const SphereShells& s) { return [&, s] { sphereDipolePotential(s, p, m, el); }; };
  expectInputError(pot({{}, {}}), "no shells");
  expectInputError(pot({{78, 92}, {0.33}}), "2 radii but 1 conductivities");
  expectInputError(pot({{78, 0}, {0.33, 0.33}}), "radius 1 = 0 mm must be positive");
  expectInputError(pot({{-78}, {0.33}}), "must be positive");
  expectInputError(pot({{78, 92, 86}, {1, 1, 1}}), "radii must ascend");
  expectInputError(pot({{78, 78}, {1, 1}}), "radii must ascend");
  expectInputError(pot({{78, 92}, {0.33, 0.0}}), "conductivity of shell 1");
  expectInputError(pot({{78, 92}, {-0.33, 1.0}}), "conductivity of shell 0");
  expectInputError([&] { sphereDipolePotential(kHead, {0, 0, 78}, m, el); },
                   "not strictly inside the innermost sphere");
  expectInputError([&] { sphereDipolePotential(kHead, {0, 60, 60}, m, el); },
                   "not strictly inside the innermost sphere");
  expectInputError([&] { sphereDipolePotential(kHead, p, m, {0, 0, 0}); }, "electrode at the centre");
  expectInputError([&] { sphereDipolePotential(kHead, p, {NAN, 0, 0}, el); }, "finite");
  expectInputError([&] { sphereDipolePotential(kHead, p, m, el, 0); }, "maxTerms");
  expectInputError([&] { sphereDipolePotential(kHead, p, m, el, 100, 0.0); }, "tol");
  expectInputError([&] { spherePointSourceCoefficient(kHead, 0, 10); }, "degree");
  expectInputError([&] { spherePointSourceCoefficient(kHead, 1, 80); }, "source radius");
  expectInputError([] { compareToAnalytic({}, {}); }, "non-empty and of equal length");
  expectInputError([] { compareToAnalytic({1, 2}, {1, 2, 3}); }, "equal length");
  expectInputError([] { compareToAnalytic({1, 1, 1}, {1, 2, 3}); }, "numerical potentials are constant");
  expectInputError([] { compareToAnalytic({1, 2, 3}, {0, 0, 0}); }, "analytic potentials are constant");
  expectInputError([] { compareToAnalytic({1, NAN, 3}, {1, 2, 3}); }, "non-finite");
}
