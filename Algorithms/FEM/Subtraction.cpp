// The subtraction source model (see Subtraction.h).
#include "Algorithms/FEM/Subtraction.h"

#include <omp.h>

#include <cmath>
#include <map>
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

// sum += w * value, for the integrands' types.
void accumulate(Vec3& sum, double w, const Vec3& v) {
  for (int k = 0; k < 3; ++k) sum[size_t(k)] += w * v[size_t(k)];
}
void accumulate(Mat3& sum, double w, const Mat3& v) {
  for (int k = 0; k < 3; ++k) accumulate(sum[size_t(k)], w, v[size_t(k)]);
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
    accumulate(sum, w[3] * area, g(x, l));
  }
}

} // namespace

SubtractionSources::SubtractionSources(const TetMesh& mesh, const ConductivityTable& sigma)
    : mesh_(mesh), locator_(mesh) {
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
  std::map<int32_t, double> area;
  double total = 0;
  for (const auto& face : faces_) {
    const Vec3& p0 = mesh.points[size_t(face[0])];
    const double a = 0.5 * norm(cross(mesh.points[size_t(face[1])] - p0, mesh.points[size_t(face[2])] - p0));
    for (int32_t v : face) area[v] += a / 3;
    total += a;
  }
  for (const auto& [v, a] : area) boundaryShare_.push_back({v, total > 0 ? a / total : 0.0});
}

double SubtractionSources::sigmaAt(const Vec3& x0) const {
  const auto loc = locator_.locate(x0);
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
  b += unitLoads(x0) * Eigen::Vector3d(M[0], M[1], M[2]);
}

Eigen::MatrixX3d SubtractionSources::unitLoads(const Vec3& x0) const {
  const double sigma = sigmaAt(x0);
  const SymTensor6 sInf = isotropicTensor(sigma);
  const Eigen::Index np = Eigen::Index(mesh_.numPoints());
  const int threads = omp_get_max_threads();
  std::vector<Eigen::MatrixX3d> local(size_t(threads), Eigen::MatrixX3d::Zero(np, 3));
  const std::array<double, 3> e0{1, 0, 0}, e1{0, 1, 0}, e2{0, 0, 1};
  // u_inf for the unit moments along x, y, z at once: (x - x0) / (4 pi sigma |x - x0|^3).
  auto potentials = [&](const Vec3& x, const std::array<double, 3>&) {
    const Vec3 r = x - x0;
    const double r2 = dot(r, r);
    if (!(r2 > 1e-18)) return Vec3{0, 0, 0};
    return (1.0 / (4 * kPi * sigma * r2 * std::sqrt(r2))) * r;
  };
  // Volume term: grad(phi_i) . (sigma_inf - sigma_T) int_T grad(u_inf), over the tets that differ.
#pragma omp parallel for schedule(dynamic, 256)
  for (int64_t t = 0; t < int64_t(mesh_.numTets()); ++t) {
    const SymTensor6& s = sigma_[size_t(t)];
    if (s == sInf) continue;
    const auto& q = mesh_.tets[size_t(t)];
    Mat3 flux{}; // flux[k]: int_T grad u_inf for the unit moment k = sum_F n_F int_F u_inf
    for (int f = 0; f < 4; ++f) {
      const Vec3& a = mesh_.points[size_t(q[size_t(kTetFaceVertices[f][0])])];
      const Vec3& bb = mesh_.points[size_t(q[size_t(kTetFaceVertices[f][1])])];
      const Vec3& c = mesh_.points[size_t(q[size_t(kTetFaceVertices[f][2])])];
      Vec3 n = cross(bb - a, c - a);
      if (dot(n, mesh_.points[size_t(q[size_t(f)])] - a) > 0) n = -1.0 * n;
      const double len = norm(n);
      if (!(len > 0)) continue;
      Vec3 integral{0, 0, 0};
      integrateTriangle(a, bb, c, e0, e1, e2, 0.5 * len, x0, 0, potentials, integral);
      for (int k = 0; k < 3; ++k) flux[size_t(k)] = flux[size_t(k)] + (integral[size_t(k)] / len) * n;
    }
    const Mat3 d = tensorMatrix({sigma - s[0], sigma - s[1], sigma - s[2], -s[3], -s[4], -s[5]});
    const TetGradients g = tetGradients(mesh_, size_t(t));
    Eigen::MatrixX3d& out = local[size_t(omp_get_thread_num())];
    for (int k = 0; k < 3; ++k) {
      const Vec3 j = mul(d, flux[size_t(k)]);
      for (int a = 0; a < 4; ++a) out(q[size_t(a)], k) += dot(g.grad[size_t(a)], j);
    }
  }
  // Boundary term: -sigma_inf int_F (grad u_inf . n) phi_a; grad u_inf . n for the unit moment k
  // is (n_k - 3 (r . n) r_k / r^2) / (4 pi sigma r^3).
#pragma omp parallel for schedule(dynamic, 256)
  for (int64_t f = 0; f < int64_t(faces_.size()); ++f) {
    const auto& face = faces_[size_t(f)];
    const Vec3 &a = mesh_.points[size_t(face[0])], &bb = mesh_.points[size_t(face[1])], &c = mesh_.points[size_t(face[2])];
    const Vec3 nn = cross(bb - a, c - a);
    const double len = norm(nn);
    if (!(len > 0)) continue;
    const Vec3 n = (1.0 / len) * nn;
    Mat3 sum{}; // sum[k][a]
    integrateTriangle(a, bb, c, e0, e1, e2, 0.5 * len, x0, 0,
                      [&](const Vec3& x, const std::array<double, 3>& l) {
                        const Vec3 r = x - x0;
                        const double r2 = dot(r, r);
                        Mat3 v{};
                        if (!(r2 > 1e-18)) return v;
                        const double scale = 1.0 / (4 * kPi * sigma * r2 * std::sqrt(r2)), rn = 3 * dot(r, n) / r2;
                        for (int k = 0; k < 3; ++k) {
                          const double gk = scale * (n[size_t(k)] - rn * r[size_t(k)]);
                          v[size_t(k)] = {gk * l[0], gk * l[1], gk * l[2]};
                        }
                        return v;
                      },
                      sum);
    Eigen::MatrixX3d& out = local[size_t(omp_get_thread_num())];
    for (int k = 0; k < 3; ++k)
      for (int v = 0; v < 3; ++v) out(face[size_t(v)], k) -= sigma * sum[size_t(k)][size_t(v)];
  }
  Eigen::MatrixX3d F = Eigen::MatrixX3d::Zero(np, 3);
  for (const auto& l : local) F += l;
  // The boundary flux of u_inf vanishes exactly, its quadrature to ~1e-6: the rest leaves through
  // the boundary evenly (lumped by area), so that the load carries no net current and the
  // solution does not depend on which vertex holds the reference.
  const Eigen::RowVector3d net = F.colwise().sum();
  for (const auto& [v, share] : boundaryShare_) F.row(v) -= share * net;
  return F;
}

} // namespace tetflow
