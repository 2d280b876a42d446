#pragma once
// Dipole source models beside partial integration (Assembly.h addDipole): the multipolar
// St. Venant model (Buchner et al. 1997; Wolters et al. 2007, "Numerical mathematics of the
// subtraction method ..." and DUNEuro's default "venant").
//
// A current dipole with moment M (mA mm) at x is replaced by monopoles q_j (mA) at the mesh
// vertex x0 nearest to x and at the vertices that share a tet with x0 (C of them, typically
// 15-30). The q_j match the dipole's moments up to second order about x, each coordinate apart,
// scaled by a reference length a (the mean distance of the C vertices from x):
//   order 0: sum_j q_j = 0 (no net current);
//   order 1: sum_j q_j (dx_j / a) = M / a   (three rows, dx_j = x_j - x);
//   order 2: sum_j q_j (dx_j,k / a)^2 = 0   (k = x, y, z: three rows).
// The 7 x C system X q = T is solved in the least-squares sense with a Tikhonov term that
// favours charges near x: q = (X^T X + lambda W^T W)^-1 X^T T, W = diag(|dx_j| / a), lambda 1e-6;
// then the mean of q is subtracted, so that no net current remains to rounding.
// The load is linear in M, so the lead field of ComputeLeadField is exact for it by
// reciprocity (L = u_e^T q for unit moments).
//
// Compared with partial integration (the load m . grad phi_a on the 4 vertices of one tet),
// the monopoles spread over a vertex's whole star: the source is smoother and less sensitive to
// where inside a tet it sits, which matters for sources close to a conductivity jump (high
// eccentricity), where partial integration's error grows.
#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/Quality/LabelTopology.h"
#include "TetLocator.h"

namespace tetflow {

// The dipole source models AssembleFEMPoisson and the lead fields offer (parameter source_model).
enum class SourceModel { PartialIntegration, Venant, Subtraction };
const char* sourceModelName(SourceModel m); // "partial_integration", "venant", "subtraction"
SourceModel sourceModelFromName(const std::string& name); // InputError naming the choices

// The tets around each vertex (Quality/LabelTopology.h vertexStars), built once for many sources.
class VenantSources {
public:
  explicit VenantSources(const TetMesh& mesh);
  // Adds the Venant load of the dipole to b (indexed by mesh vertex). InputError when |M| = 0 or
  // x lies outside the mesh. Returns the vertices used (x0 first).
  std::vector<int32_t> add(const Vec3& position, const Vec3& moment, Eigen::VectorXd& b) const;
  // The monopoles (vertex, charge) without adding them anywhere.
  std::vector<std::pair<int32_t, double>> monopoles(const Vec3& position, const Vec3& moment) const;

private:
  const TetMesh& mesh_;
  VertexStars stars_;
  TetLocator locator_;
};

// The load of a unit dipole along each axis at each source, for lead fields: column 3 s + k is
// the list of (vertex, weight) pairs [offset[3 s + k], offset[3 s + k + 1]). Partial
// integration: the gradients' k-th components of the 4 barycentric functions of the source's tet
// (sourceTets[s]); Venant: the monopoles of a unit moment along axis k. A lead field entry is then
// sum weight * u_e[vertex] (reciprocity: exactly what a direct solve with that load gives).
struct DipoleLoads {
  std::vector<int64_t> offset;
  std::vector<int32_t> vertex;
  std::vector<double> weight;
  double apply(size_t column, const Eigen::VectorXd& u) const {
    double sum = 0;
    for (int64_t i = offset[column]; i < offset[column + 1]; ++i) sum += weight[size_t(i)] * u[vertex[size_t(i)]];
    return sum;
  }
};
// InputError for the subtraction model, whose load is not a few vertices' (the EEG lead field builds
// it per source, LeadField.cpp; the MEG lead field does not offer it).
DipoleLoads dipoleLoads(const TetMesh& mesh, const std::vector<Vec3>& sources, const std::vector<int64_t>& sourceTets,
                        SourceModel model);

} // namespace tetflow
