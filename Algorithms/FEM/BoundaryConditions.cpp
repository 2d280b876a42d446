#include "BoundaryConditions.h"

#include <algorithm>

#include "Algorithms/Core/Errors.h"

namespace tetflow {

namespace {
constexpr std::pair<BoundaryCondition, const char*> kBcNames[] = {
    {BoundaryCondition::Boundary, "boundary"},
    {BoundaryCondition::Electrodes, "electrodes"},
    {BoundaryCondition::MaterialElectrodes, "material_electrodes"},
    {BoundaryCondition::Dipole, "dipole"}};
} // namespace

const char* boundaryConditionName(BoundaryCondition bc) {
  for (const auto& [b, n] : kBcNames)
    if (b == bc) return n;
  return "?";
}

BoundaryCondition boundaryConditionFromName(const std::string& name) {
  for (const auto& [b, n] : kBcNames)
    if (name == n) return b;
  std::string msg = "boundary_condition '";
  msg += name;
  msg += "' is unknown; use one of:";
  for (const auto& [b, n] : kBcNames) {
    msg += ' ';
    msg += n;
  }
  throw InputError(msg);
}

size_t DirichletSet::count() const {
  return size_t(std::count(fixed.begin(), fixed.end(), uint8_t(1)));
}

Eigen::VectorXd ReducedSystem::expand(const Eigen::VectorXd& x) const {
  Eigen::VectorXd u(Eigen::Index(reducedIndex.size()));
  for (size_t v = 0; v < reducedIndex.size(); ++v)
    u[Eigen::Index(v)] = reducedIndex[v] >= 0 ? x[reducedIndex[v]] : fixedValue[v];
  return u;
}

ReducedSystem eliminateDirichlet(const SparseMatrix& K, const Eigen::VectorXd& f, const DirichletSet& d) {
  const int64_t n = K.cols();
  if (K.rows() != n || f.size() != n || int64_t(d.fixed.size()) != n || int64_t(d.value.size()) != n)
    throw InputError("eliminateDirichlet: matrix, load vector and Dirichlet set sizes disagree");
  if (!K.isCompressed()) throw InputError("eliminateDirichlet: the matrix must be compressed");
  ReducedSystem r;
  r.reducedIndex.assign(size_t(n), -1);
  r.fixedValue.assign(size_t(n), 0.0);
  for (int64_t v = 0; v < n; ++v) {
    if (d.fixed[size_t(v)]) {
      r.fixedValue[size_t(v)] = d.value[size_t(v)];
    } else {
      r.reducedIndex[size_t(v)] = static_cast<int32_t>(r.freeVertex.size());
      r.freeVertex.push_back(static_cast<int32_t>(v));
    }
  }
  const int64_t m = int64_t(r.freeVertex.size());
  const int* outer = K.outerIndexPtr();
  const int* inner = K.innerIndexPtr();
  const double* val = K.valuePtr();

  // Count the free rows of each free column, then copy; the row map is monotone, so rows stay
  // sorted. b_F = f_F - K_FD u_D uses column i = row i (symmetry).
  std::vector<int64_t> start(size_t(m) + 1, 0);
#pragma omp parallel for schedule(static)
  for (int64_t c = 0; c < m; ++c) {
    const int j = r.freeVertex[size_t(c)];
    int64_t k = 0;
    for (int p = outer[j]; p < outer[j + 1]; ++p) k += d.fixed[size_t(inner[p])] ? 0 : 1;
    start[size_t(c) + 1] = k;
  }
  for (int64_t c = 0; c < m; ++c) start[size_t(c) + 1] += start[size_t(c)];
  r.K.resize(m, m);
  r.K.resizeNonZeros(start[size_t(m)]);
  for (int64_t c = 0; c <= m; ++c) r.K.outerIndexPtr()[c] = static_cast<int>(start[size_t(c)]);
  int* rinner = r.K.innerIndexPtr();
  double* rval = r.K.valuePtr();
  r.b.resize(m);
#pragma omp parallel for schedule(static)
  for (int64_t c = 0; c < m; ++c) {
    const int j = r.freeVertex[size_t(c)];
    int64_t k = start[size_t(c)];
    double rhs = f[j];
    for (int p = outer[j]; p < outer[j + 1]; ++p) {
      const int i = inner[p];
      if (d.fixed[size_t(i)]) {
        rhs -= val[p] * d.value[size_t(i)];
      } else {
        rinner[k] = r.reducedIndex[size_t(i)];
        rval[k] = val[p];
        ++k;
      }
    }
    r.b[c] = rhs;
  }
  return r;
}

} // namespace tetflow
