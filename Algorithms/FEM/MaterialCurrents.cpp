#include "MaterialCurrents.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "Algorithms/Core/CancellableSort.h"
#include "Assembly.h"

namespace tetflow {

namespace {
struct FaceRef {
  std::array<int32_t, 3> key; // sorted vertex ids
  int32_t tet;
  int32_t local; // the face opposite vertex `local`
  bool operator<(const FaceRef& o) const { return key < o.key || (key == o.key && tet < o.tet); }
};
} // namespace

std::map<int32_t, double> materialCurrents(const TetMesh& mesh, const ConductivityTable& sigma,
                                           const Eigen::VectorXd& u, Progress& progress) {
  const size_t nt = mesh.numTets();
  std::map<int32_t, Mat3> tensors;
  for (int32_t l : mesh.materials)
    if (!tensors.count(l)) tensors[l] = tensorMatrix(sigma.tensor(l));
  // Current density per tet (mA/mm^2).
  std::vector<Vec3> J(nt);
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < int64_t(nt); ++t) {
    const TetGradients g = tetGradients(mesh, size_t(t));
    Vec3 grad{0, 0, 0};
    for (int a = 0; a < 4; ++a) grad = grad + u[mesh.tets[size_t(t)][a]] * g.grad[size_t(a)];
    J[size_t(t)] = -1.0 * mul(tensors.at(mesh.materials[size_t(t)]), grad);
  }
  // Faces between different labels: found by sorting every tet face by its vertices.
  std::vector<FaceRef> faces;
  faces.reserve(4 * nt);
  for (size_t t = 0; t < nt; ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<int32_t, 3> k;
      for (int i = 0, j = 0; i < 4; ++i)
        if (i != f) k[size_t(j++)] = mesh.tets[t][i];
      std::sort(k.begin(), k.end());
      faces.push_back({k, int32_t(t), f});
    }
  progress.checkCancel();
  cancellableSort(faces, progress);
  std::map<int32_t, double> through;
  for (int32_t l : mesh.materials) through.emplace(l, 0.0);
  for (size_t i = 0; i + 1 < faces.size(); ++i) {
    const FaceRef& a = faces[i];
    const FaceRef& b = faces[i + 1];
    if (a.key != b.key) continue;
    const int32_t la = mesh.materials[size_t(a.tet)], lb = mesh.materials[size_t(b.tet)];
    if (la == lb) continue;
    const Vec3& p0 = mesh.points[size_t(a.key[0])];
    Vec3 n = 0.5 * cross(mesh.points[size_t(a.key[1])] - p0, mesh.points[size_t(a.key[2])] - p0); // area vector
    const Vec3 opposite = mesh.points[size_t(mesh.tets[size_t(a.tet)][a.local])];
    if (dot(n, opposite - p0) > 0) n = -1.0 * n; // out of a's tet
    through[la] += 0.5 * std::abs(dot(J[size_t(a.tet)], n));
    through[lb] += 0.5 * std::abs(dot(J[size_t(b.tet)], n));
    ++i;
  }
  return through;
}

} // namespace tetflow
