// The subtraction source model (see Subtraction.h).
#include "Algorithms/FEM/Subtraction.h"

#include <omp.h>

#include <cmath>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Progress.h"
#include "Algorithms/FEM/Assembly.h"
#include "Algorithms/Quality/LabelTopology.h"

namespace tetflow {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kMaxLevels = 6;
// Seven-point rule of degree 5 on a triangle (Strang & Fix): barycentric points, weights summing to 1.
constexpr double kA1 = 0.059715871789770, kB1 = 0.470142064105115, kW1 = 0.132394152788506;
constexpr double kA2 = 0.797426985353087, kB2 = 0.101286507323456, kW2 = 0.125939180544827;
constexpr double kRule[7][4] = {{1.0 / 3, 1.0 / 3, 1.0 / 3, 0.225},
                                {kA1, kB1, kB1, kW1}, {kB1, kA1, kB1, kW1}, {kB1, kB1, kA1, kW1},
                                {kA2, kB2, kB2, kW2}, {kB2, kA2, kB2, kW2}, {kB2, kB2, kA2, kW2}};

// grad u_inf at x (V/mm) for sigma_inf (S/m): (M / r^3 - 3 (M . r) r / r^5) / (4 pi sigma).
Vec3 singularGradient(const Vec3& x0, const Vec3& M, double sigma, const Vec3& x) {
  const Vec3 r = x - x0;
  const double r2 = dot(r, r);
  if (!(r2 > 1e-18)) return {0, 0, 0};
  const double r1 = std::sqrt(r2), r3 = r2 * r1;
  return (1.0 / (4 * kPi * sigma * r3)) * (M - (3 * dot(M, r) / r2) * r);
}

// Integrates g (a function of the point and its barycentric coordinates on the triangle (a, b,
// c), returning T) over the triangle, subdividing it until each piece is smaller than a quarter
// of its distance to x0. `area` is the triangle's area.
template <class T, class G>
void integrateTriangle(const Vec3& a, const Vec3& b, const Vec3& c, const std::array<double, 3>& la,
                       const std::array<double, 3>& lb, const std::array<double, 3>& lc, double area, const Vec3& x0,
                       int level, const G& g, T& sum) {
  const Vec3 centre = (1.0 / 3.0) * (a + b + c);
  const double size = std::max({norm(b - a), norm(c - b), norm(a - c)});
  if (level < kMaxLevels && size > 0.25 * norm(centre - x0)) {
    const Vec3 ab = 0.5 * (a + b), bc = 0.5 * (b + c), ca = 0.5 * (c + a);
    auto mid = [](const std::array<double, 3>& p, const std::array<double, 3>& q) {
      return std::array<double, 3>{0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1]), 0.5 * (p[2] + q[2])};
    };
    const auto lab = mid(la, lb), lbc = mid(lb, lc), lca = mid(lc, la);
    const double q = 0.25 * area;
    integrateTriangle(a, ab, ca, la, lab, lca, q, x0, level + 1, g, sum);
    integrateTriangle(ab, b, bc, lab, lb, lbc, q, x0, level + 1, g, sum);
    integrateTriangle(ca, bc, c, lca, lbc, lc, q, x0, level + 1, g, sum);
    integrateTriangle(ab, bc, ca, lab, lbc, lca, q, x0, level + 1, g, sum);
    return;
  }
  for (const auto& w : kRule) {
    const Vec3 x = w[0] * a + w[1] * b + w[2] * c;
    const std::array<double, 3> l{w[0] * la[0] + w[1] * lb[0] + w[2] * lc[0],
                                  w[0] * la[1] + w[1] * lb[1] + w[2] * lc[1],
                                  w[0] * la[2] + w[1] * lb[2] + w[2] * lc[2]};
    sum = sum + (w[3] * area) * g(x, l);
  }
}

} // namespace

SubtractionSources::SubtractionSources(const TetMesh& mesh, const ConductivityTable& sigma) : mesh_(mesh) {
  mesh.validateStructure("mesh");
  sigma_.resize(mesh.numTets());
  for (size_t t = 0; t < mesh.numTets(); ++t) sigma_[t] = sigma.tensor(mesh.materials[t]);
  NullProgress quiet;
  const std::vector<int32_t> nb = tetFaceNeighbours(mesh, quiet);
  for (size_t t = 0; t < mesh.numTets(); ++t)
    for (int f = 0; f < 4; ++f) {
      if (nb[4 * t + size_t(f)] != kNoNeighbour) continue;
      const auto& q = mesh.tets[t];
      std::array<int32_t, 3> face{q[size_t(kTetFaceVertices[f][0])], q[size_t(kTetFaceVertices[f][1])],
                                  q[size_t(kTetFaceVertices[f][2])]};
      const Vec3& p0 = mesh.points[size_t(face[0])];
      const Vec3 n = cross(mesh.points[size_t(face[1])] - p0, mesh.points[size_t(face[2])] - p0);
      if (dot(n, mesh.points[size_t(q[size_t(f)])] - p0) > 0) std::swap(face[1], face[2]); // outward
      faces_.push_back(face);
    }
}

double SubtractionSources::sigmaAt(const Vec3& x0) const {
  const auto loc = locatePoint(mesh_, x0);
  if (!loc) {
    std::ostringstream m;
    m << "dipole_position (" << x0[0] << ", " << x0[1] << ", " << x0[2] << ") mm lies outside the mesh";
    throw InputError(m.str());
  }
  const SymTensor6& s = sigma_[size_t(loc->tet)];
  if (!(s[3] == 0 && s[4] == 0 && s[5] == 0 && s[0] == s[1] && s[1] == s[2]))
    throw InputError("source_model subtraction: the conductivity at the dipole (label " +
                     std::to_string(mesh_.materials[size_t(loc->tet)]) +
                     ") is anisotropic; the subtraction model needs an isotropic one there (use venant)");
  return s[0];
}

double SubtractionSources::singularPotential(const Vec3& x0, const Vec3& M, double sigma, const Vec3& x) {
  const Vec3 r = x - x0;
  const double r2 = dot(r, r);
  if (!(r2 > 1e-18)) return 0.0;
  return dot(M, r) / (4 * kPi * sigma * r2 * std::sqrt(r2));
}

std::vector<double> SubtractionSources::singularPotential(const Vec3& x0, const Vec3& M) const {
  const double sigma = sigmaAt(x0);
  std::vector<double> u(mesh_.numPoints());
#pragma omp parallel for schedule(static)
  for (int64_t v = 0; v < int64_t(u.size()); ++v) u[size_t(v)] = singularPotential(x0, M, sigma, mesh_.points[size_t(v)]);
  return u;
}

void SubtractionSources::addLoad(const Vec3& x0, const Vec3& M, Eigen::VectorXd& b) const {
  const double m = norm(M);
  if (!(m > 0) || !std::isfinite(m)) throw InputError("dipole_moment: must be a non-zero finite vector (mA mm)");
  const double sigma = sigmaAt(x0);
  const SymTensor6 sInf = isotropicTensor(sigma);
  const int threads = omp_get_max_threads();
  std::vector<Eigen::VectorXd> local(size_t(threads), Eigen::VectorXd::Zero(b.size()));
  const std::array<double, 3> e0{1, 0, 0}, e1{0, 1, 0}, e2{0, 0, 1};
  // Volume term: grad(phi_i) . (sigma_inf - sigma_T) int_T grad(u_inf), over the tets that differ.
#pragma omp parallel for schedule(dynamic, 256)
  for (int64_t t = 0; t < int64_t(mesh_.numTets()); ++t) {
    const SymTensor6& s = sigma_[size_t(t)];
    if (s == sInf) continue;
    const auto& q = mesh_.tets[size_t(t)];
    Vec3 flux{0, 0, 0}; // int_T grad u_inf = sum_F n_F int_F u_inf
    for (int f = 0; f < 4; ++f) {
      const Vec3& a = mesh_.points[size_t(q[size_t(kTetFaceVertices[f][0])])];
      Vec3 bb = mesh_.points[size_t(q[size_t(kTetFaceVertices[f][1])])];
      Vec3 c = mesh_.points[size_t(q[size_t(kTetFaceVertices[f][2])])];
      Vec3 n = cross(bb - a, c - a);
      if (dot(n, mesh_.points[size_t(q[size_t(f)])] - a) > 0) n = -1.0 * n;
      const double len = norm(n);
      if (!(len > 0)) continue;
      double integral = 0;
      integrateTriangle(a, bb, c, e0, e1, e2, 0.5 * len, x0, 0,
                        [&](const Vec3& x, const std::array<double, 3>&) { return singularPotential(x0, M, sigma, x); },
                        integral);
      flux = flux + (integral / len) * n;
    }
    const Mat3 d = tensorMatrix({sigma - s[0], sigma - s[1], sigma - s[2], -s[3], -s[4], -s[5]});
    const Vec3 j = mul(d, flux);
    const TetGradients g = tetGradients(mesh_, size_t(t));
    Eigen::VectorXd& out = local[size_t(omp_get_thread_num())];
    for (int a = 0; a < 4; ++a) out[q[size_t(a)]] += dot(g.grad[size_t(a)], j);
  }
  // Boundary term: -sigma_inf int_F (grad u_inf . n) phi_a.
#pragma omp parallel for schedule(dynamic, 256)
  for (int64_t f = 0; f < int64_t(faces_.size()); ++f) {
    const auto& face = faces_[size_t(f)];
    const Vec3 &a = mesh_.points[size_t(face[0])], &bb = mesh_.points[size_t(face[1])], &c = mesh_.points[size_t(face[2])];
    const Vec3 nn = cross(bb - a, c - a);
    const double len = norm(nn);
    if (!(len > 0)) continue;
    const Vec3 n = (1.0 / len) * nn;
    Vec3 sum{0, 0, 0}; // per vertex of the face
    integrateTriangle(a, bb, c, e0, e1, e2, 0.5 * len, x0, 0,
                      [&](const Vec3& x, const std::array<double, 3>& l) {
                        const double g = dot(singularGradient(x0, M, sigma, x), n);
                        return Vec3{g * l[0], g * l[1], g * l[2]};
                      },
                      sum);
    Eigen::VectorXd& out = local[size_t(omp_get_thread_num())];
    for (int k = 0; k < 3; ++k) out[face[size_t(k)]] -= sigma * sum[size_t(k)];
  }
  for (const auto& l : local) b += l;
}

} // namespace tetflow
