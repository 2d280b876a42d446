// The St. Venant dipole source model (see SourceModels.h).
#include "Algorithms/FEM/SourceModels.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <optional>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/FEM/Assembly.h"

namespace tetflow {

const char* sourceModelName(SourceModel m) {
  switch (m) {
  case SourceModel::Venant: return "venant";
  case SourceModel::Subtraction: return "subtraction";
  case SourceModel::PartialIntegration: break;
  }
  return "partial_integration";
}

SourceModel sourceModelFromName(const std::string& name) {
  for (SourceModel m : {SourceModel::PartialIntegration, SourceModel::Venant, SourceModel::Subtraction})
    if (name == sourceModelName(m)) return m;
  throw InputError("source_model '" + name + "': use partial_integration, venant or subtraction");
}

VenantSources::VenantSources(const TetMesh& mesh) : mesh_(mesh), stars_(vertexStars(mesh)), locator_(mesh) {}

std::vector<std::pair<int32_t, double>> VenantSources::monopoles(const Vec3& x, const Vec3& M) const {
  const double m = norm(M);
  if (!(m > 0) || !std::isfinite(m))
    throw InputError("dipole_moment: must be a non-zero finite vector (mA mm)");
  const auto loc = locator_.locate(x);
  if (!loc)
    throw InputError("dipole_position (" + std::to_string(x[0]) + ", " + std::to_string(x[1]) + ", " +
                     std::to_string(x[2]) + ") mm lies outside the mesh");
  const auto& tet = mesh_.tets[size_t(loc->tet)];
  int32_t x0 = tet[0];
  for (int a = 1; a < 4; ++a)
    if (norm(mesh_.points[size_t(tet[size_t(a)])] - x) < norm(mesh_.points[size_t(x0)] - x)) x0 = tet[size_t(a)];
  // x0 first, then the other vertices of the tets around it.
  std::vector<int32_t> verts;
  for (int64_t i = stars_.offset[size_t(x0)]; i < stars_.offset[size_t(x0) + 1]; ++i)
    for (int32_t w : mesh_.tets[size_t(stars_.tets[size_t(i)])])
      if (w != x0) verts.push_back(w);
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  verts.insert(verts.begin(), x0);
  const int C = int(verts.size());
  std::vector<Vec3> dx(static_cast<size_t>(C));
  double a = 0;
  for (int j = 0; j < C; ++j) {
    dx[size_t(j)] = mesh_.points[size_t(verts[size_t(j)])] - x;
    a += norm(dx[size_t(j)]);
  }
  a /= C;
  Eigen::MatrixXd X(7, C);
  Eigen::VectorXd T = Eigen::VectorXd::Zero(7), w(C);
  for (int j = 0; j < C; ++j) {
    const Vec3 d = (1.0 / a) * dx[size_t(j)];
    X(0, j) = 1.0;
    for (int k = 0; k < 3; ++k) {
      X(1 + k, j) = d[size_t(k)];
      X(4 + k, j) = d[size_t(k)] * d[size_t(k)];
    }
    w(j) = norm(d);
  }
  for (int k = 0; k < 3; ++k) T(1 + k) = M[size_t(k)] / a;
  const double lambda = 1e-6;
  Eigen::MatrixXd A = X.transpose() * X;
  A.diagonal() += lambda * w.cwiseProduct(w);
  Eigen::VectorXd q = A.ldlt().solve(X.transpose() * T);
  q.array() -= q.mean(); // no net current, exactly (the least squares leave ~1e-8 of it)
  std::vector<std::pair<int32_t, double>> out;
  for (int j = 0; j < C; ++j) out.push_back({verts[size_t(j)], q(j)});
  return out;
}

std::vector<int32_t> VenantSources::add(const Vec3& position, const Vec3& moment, Eigen::VectorXd& b) const {
  std::vector<int32_t> used;
  for (const auto& [v, q] : monopoles(position, moment)) {
    b[v] += q;
    used.push_back(v);
  }
  return used;
}

DipoleLoads dipoleLoads(const TetMesh& mesh, const std::vector<Vec3>& sources, const std::vector<int64_t>& sourceTets,
                        SourceModel model) {
  if (model == SourceModel::Subtraction)
    throw InputError("source_model subtraction: its load is not a few vertices' (ComputeLeadField handles it apart); the MEG lead field takes partial_integration or venant");
  const bool venant = model == SourceModel::Venant;
  DipoleLoads loads;
  loads.offset.push_back(0);
  std::optional<VenantSources> v;
  if (venant) v.emplace(mesh);
  for (size_t s = 0; s < sources.size(); ++s) {
    const TetGradients g = tetGradients(mesh, size_t(sourceTets[s]));
    for (int k = 0; k < 3; ++k) {
      if (venant) {
        Vec3 e{0, 0, 0};
        e[size_t(k)] = 1.0;
        for (const auto& [vertex, q] : v->monopoles(sources[s], e)) {
          loads.vertex.push_back(vertex);
          loads.weight.push_back(q);
        }
      } else {
        for (int a = 0; a < 4; ++a) {
          loads.vertex.push_back(mesh.tets[size_t(sourceTets[s])][size_t(a)]);
          loads.weight.push_back(g.grad[size_t(a)][size_t(k)]);
        }
      }
      loads.offset.push_back(int64_t(loads.vertex.size()));
    }
  }
  return loads;
}

} // namespace tetflow
