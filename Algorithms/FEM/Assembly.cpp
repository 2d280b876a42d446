#include "Assembly.h"
#include "TetLocator.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Quality/TetQuality.h"
#include "VertexStars.h"

namespace tetflow {

std::vector<int32_t> vertexDegrees(const TetMesh& mesh) {
  std::vector<int32_t> degree(mesh.numPoints(), 0);
  const int64_t nt = static_cast<int64_t>(mesh.numTets());
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < nt; ++t)
    for (int32_t v : mesh.tets[size_t(t)])
      std::atomic_ref<int32_t>(degree[size_t(v)]).fetch_add(1, std::memory_order_relaxed);
  return degree;
}

void checkTetVolumes(const TetMesh& mesh) {
  const int64_t nt = static_cast<int64_t>(mesh.numTets());
  int64_t first = std::numeric_limits<int64_t>::max();
#pragma omp parallel for schedule(static) reduction(min : first)
  for (int64_t t = 0; t < nt; ++t) {
    const auto& q = mesh.tets[size_t(t)];
    const Vec3 &p0 = mesh.points[q[0]], &p1 = mesh.points[q[1]], &p2 = mesh.points[q[2]],
               &p3 = mesh.points[q[3]];
    const double v = signedTetVolume(p0, p1, p2, p3);
    if (!(v > 0) || isZeroVolume(p0, p1, p2, p3)) first = std::min(first, t);
  }
  if (first == std::numeric_limits<int64_t>::max()) return;
  const auto& q = mesh.tets[size_t(first)];
  const double v = mesh.tetVolume(size_t(first));
  std::ostringstream m;
  m << "tet " << first << " (vertices " << q[0] << " " << q[1] << " " << q[2] << " " << q[3]
    << ") has ";
  if (v < 0 && !isZeroVolume(mesh.points[q[0]], mesh.points[q[1]], mesh.points[q[2]], mesh.points[q[3]]))
    m << "negative volume " << v << " mm^3 (inverted)";
  else
    m << "zero volume (" << v << " mm^3, degenerate)";
  m << "; P1 finite elements need every tet positively oriented with non-zero volume";
  throw InputError(m.str());
}

std::vector<uint8_t> boundaryVertexFlags(const TetMesh& mesh) {
  mesh.validateStructure("mesh");
  std::vector<uint8_t> flags(mesh.numPoints(), 0);
  const std::vector<int32_t> degree = vertexDegrees(mesh);
  // The faces of the star of v are (v, a, b) for the other two vertices a < b of each face of a
  // star tet that contains v; v is on the boundary when one of them occurs only once.
  int32_t maxDegree = 0;
  for (int32_t d : degree) maxDegree = std::max(maxDegree, d);
  // Reserved here, not grown inside the parallel loop (an allocation failure there would abort).
  std::vector<std::vector<uint64_t>> keys(static_cast<size_t>(omp_get_max_threads()));
  for (auto& k : keys) k.reserve(size_t(3) * size_t(maxDegree));
  NullProgress quiet;
  forEachVertexStar(mesh, degree, defaultStarBlockCorners(4 * int64_t(mesh.numTets())), quiet,
                    [&](int thread, int32_t v, const int32_t* tets, size_t n) {
    std::vector<uint64_t>& k = keys[size_t(thread)];
    k.clear();
    for (size_t s = 0; s < n; ++s) {
      int32_t o[3];
      int m = 0;
      for (int32_t w : mesh.tets[size_t(tets[s])])
        if (w != v && m < 3) o[m++] = w;
      if (m < 3) continue; // a tet naming v twice has no proper face at v
      for (int i = 0; i < 3; ++i) {
        uint32_t a = uint32_t(o[i]), b = uint32_t(o[(i + 1) % 3]);
        if (a > b) std::swap(a, b);
        k.push_back(uint64_t(a) << 32 | b);
      }
    }
    std::sort(k.begin(), k.end());
    for (size_t i = 0; i < k.size() && !flags[size_t(v)];) {
      size_t j = i + 1;
      while (j < k.size() && k[j] == k[i]) ++j;
      if (j - i == 1) flags[size_t(v)] = 1;
      i = j;
    }
  });
  return flags;
}

std::vector<SurfaceSnap> snapToBoundary(const TetMesh& mesh, const std::vector<Vec3>& positions) {
  const std::vector<uint8_t> onBoundary = boundaryVertexFlags(mesh);
  std::vector<int32_t> boundary;
  for (size_t v = 0; v < onBoundary.size(); ++v)
    if (onBoundary[v]) boundary.push_back(int32_t(v));
  if (boundary.empty()) throw InputError("mesh: no boundary vertices to snap electrodes to (no tets?)");
  std::vector<SurfaceSnap> snaps(positions.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < int64_t(positions.size()); ++i) {
    SurfaceSnap best{boundary[0], std::numeric_limits<double>::infinity()};
    for (int32_t v : boundary)
      if (const double d = norm(mesh.points[size_t(v)] - positions[size_t(i)]); d < best.distance) best = {v, d};
    snaps[size_t(i)] = best;
  }
  return snaps;
}

std::vector<int32_t> vertexComponents(const TetMesh& mesh, int32_t& count) {
  const size_t np = mesh.numPoints();
  std::vector<int32_t> parent(np);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int32_t x) {
    while (parent[size_t(x)] != x) {
      parent[size_t(x)] = parent[size_t(parent[size_t(x)])];
      x = parent[size_t(x)];
    }
    return x;
  };
  std::vector<uint8_t> used(np, 0);
  for (const auto& t : mesh.tets) {
    for (int32_t v : t) used[size_t(v)] = 1;
    for (int i = 1; i < 4; ++i) {
      int32_t a = find(t[0]), b = find(t[i]);
      if (a == b) continue;
      if (a < b) std::swap(a, b);
      parent[size_t(a)] = b; // root = lowest vertex index of the component
    }
  }
  std::vector<int32_t> comp(np, -1);
  std::vector<int32_t> idOfRoot(np, -1);
  count = 0;
  for (size_t v = 0; v < np; ++v) {
    if (!used[v]) continue;
    const int32_t r = find(static_cast<int32_t>(v));
    if (idOfRoot[size_t(r)] < 0) idOfRoot[size_t(r)] = count++;
    comp[v] = idOfRoot[size_t(r)];
  }
  return comp;
}

TetGradients tetGradients(const TetMesh& mesh, size_t t) {
  const auto& q = mesh.tets[t];
  const Vec3& p0 = mesh.points[q[0]];
  const Vec3 e1 = mesh.points[q[1]] - p0, e2 = mesh.points[q[2]] - p0, e3 = mesh.points[q[3]] - p0;
  const Vec3 c23 = cross(e2, e3), c31 = cross(e3, e1), c12 = cross(e1, e2);
  const double D = dot(e1, c23);
  TetGradients g;
  g.volume = D / 6.0;
  const double inv = 1.0 / D;
  g.grad[1] = inv * c23;
  g.grad[2] = inv * c31;
  g.grad[3] = inv * c12;
  g.grad[0] = -1.0 * (g.grad[1] + g.grad[2] + g.grad[3]);
  return g;
}

namespace {

// Conductivity of each tet, found from its label without a per-tet array: a direct table over
// the label range when it is small, else a binary search in the sorted labels.
class TetConductivity {
public:
  TetConductivity(const TetMesh& mesh, const ConductivityTable& sigma) : mesh_(mesh) {
    std::vector<int32_t> labels(mesh.materials.begin(), mesh.materials.end());
    std::sort(labels.begin(), labels.end());
    labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
    labels_ = labels;
    for (int32_t l : labels) {
      const SymTensor6 s = sigma.tensor(l);
      tensors_.push_back(s);
      isotropic_.push_back(s[3] == 0 && s[4] == 0 && s[5] == 0 && s[0] == s[1] && s[1] == s[2]);
    }
    if (!labels.empty() && int64_t(labels.back()) - labels.front() < 65536) {
      base_ = labels.front();
      table_.assign(size_t(labels.back() - labels.front() + 1), 0);
      for (size_t i = 0; i < labels.size(); ++i) table_[size_t(labels[i] - base_)] = uint16_t(i);
    }
  }
  size_t index(size_t t) const {
    const int32_t l = mesh_.materials[t];
    if (!table_.empty()) return table_[size_t(l - base_)];
    return size_t(std::lower_bound(labels_.begin(), labels_.end(), l) - labels_.begin());
  }
  const SymTensor6& tensor(size_t i) const { return tensors_[i]; }
  bool isotropic(size_t i) const { return isotropic_[i]; }

private:
  const TetMesh& mesh_;
  std::vector<int32_t> labels_;
  std::vector<SymTensor6> tensors_;
  std::vector<bool> isotropic_;
  int32_t base_ = 0;
  std::vector<uint16_t> table_;
};

// g^T S h for the symmetric tensor S = (xx, yy, zz, xy, yz, xz), written so that swapping g and h
// gives the same bits (every product pair is symmetric), which keeps K exactly symmetric.
inline double bilinear(const SymTensor6& S, const Vec3& g, const Vec3& h) {
  return S[0] * (g[0] * h[0]) + S[1] * (g[1] * h[1]) + S[2] * (g[2] * h[2]) +
         S[3] * (g[0] * h[1] + g[1] * h[0]) + S[4] * (g[1] * h[2] + g[2] * h[1]) +
         S[5] * (g[0] * h[2] + g[2] * h[0]);
}

} // namespace

SparseMatrix assembleStiffness(const TetMesh& mesh, const ConductivityTable& sigma, Progress& progress) {
  return assembleStiffness(mesh, sigma, progress, 0);
}

SparseMatrix assembleStiffness(const TetMesh& mesh, const ConductivityTable& sigma, Progress& progress,
                               int64_t blockCorners) {
  mesh.validateStructure("mesh");
  sigma.validate();
  checkTetVolumes(mesh);
  const int64_t np = static_cast<int64_t>(mesh.numPoints());
  if (np >= int64_t(std::numeric_limits<int>::max()))
    throw InputError("mesh has too many vertices for 32-bit sparse indices");
  if (int64_t(mesh.numTets()) >= int64_t(std::numeric_limits<int32_t>::max()))
    throw InputError("mesh has too many tets for 32-bit tet indices");
  const TetConductivity cond(mesh, sigma);
  const std::vector<int32_t> degree = vertexDegrees(mesh);
  if (blockCorners <= 0) blockCorners = defaultStarBlockCorners(4 * int64_t(mesh.numTets()));
  const int threads = omp_get_max_threads();
  // Per thread: mark[v] == j while column j is gathered (reset to -1 first).
  // Allocated here, not inside the parallel loops (an allocation failure there would abort).
  std::vector<std::vector<int32_t>> mark(static_cast<size_t>(threads), std::vector<int32_t>(size_t(np), -1));
  std::vector<std::vector<int32_t>> rows(static_cast<size_t>(threads));
  int32_t maxDegree = 0;
  for (int32_t d : degree) maxDegree = std::max(maxDegree, d);
  for (auto& r : rows) r.reserve(size_t(4) * size_t(maxDegree));
  // Gathers the distinct vertices of the star of j (j included) into rows[thread], unsorted.
  auto gather = [&](int thread, int32_t j, const int32_t* tets, size_t n) -> std::vector<int32_t>& {
    std::vector<int32_t>& mk = mark[size_t(thread)];
    std::vector<int32_t>& r = rows[size_t(thread)];
    r.clear();
    for (size_t s = 0; s < n; ++s)
      for (int32_t v : mesh.tets[size_t(tets[s])])
        if (mk[size_t(v)] != j) {
          mk[size_t(v)] = j;
          r.push_back(v);
        }
    return r;
  };
  progress.report(0.05);

  // 1. Pattern: column j holds the distinct vertices of the tets around j.
  SparseMatrix K(np, np);
  int* outer = K.outerIndexPtr();
  std::fill(outer, outer + np + 1, 0);
  forEachVertexStar(mesh, degree, blockCorners, progress, [&](int thread, int32_t j, const int32_t* tets, size_t n) {
    outer[j + 1] = static_cast<int>(gather(thread, j, tets, n).size());
  });
  int64_t nnz = 0;
  for (int64_t j = 0; j < np; ++j) {
    nnz += outer[j + 1];
    if (nnz >= int64_t(std::numeric_limits<int>::max()))
      throw InputError("stiffness matrix has too many non-zeros for 32-bit sparse indices");
    outer[j + 1] = static_cast<int>(nnz);
  }
  K.resizeNonZeros(nnz);
  int* inner = K.innerIndexPtr();
  double* values = K.valuePtr();
  for (auto& mk : mark) std::fill(mk.begin(), mk.end(), -1);
  progress.report(0.4);

  // 2. Values, column by column: column j is written by one thread, which adds the tets around j
  //    in ascending tet order; entry (a, j) of tet t is vol * g_a^T S g_j computed symmetrically,
  //    so K(a, j) and K(j, a) are the same sums in the same order.
  forEachVertexStar(mesh, degree, blockCorners, progress, [&](int thread, int32_t j, const int32_t* tets, size_t n) {
    std::vector<int32_t>& r = gather(thread, j, tets, n);
    std::sort(r.begin(), r.end());
    const int start = outer[j];
    int* rowIdx = inner + start;
    double* col = values + start;
    std::copy(r.begin(), r.end(), rowIdx);
    std::fill(col, col + r.size(), 0.0);
    int* const rowEnd = rowIdx + r.size();
    for (size_t s = 0; s < n; ++s) {
      const size_t t = size_t(tets[s]);
      const auto& q = mesh.tets[t];
      const TetGradients g = tetGradients(mesh, t);
      int lj = 0;
      while (q[lj] != j) ++lj;
      const size_t ci = cond.index(t);
      const Vec3& gj = g.grad[size_t(lj)];
      if (cond.isotropic(ci)) {
        const double w = cond.tensor(ci)[0] * g.volume;
        for (int a = 0; a < 4; ++a)
          col[std::lower_bound(rowIdx, rowEnd, q[a]) - rowIdx] += w * dot(g.grad[size_t(a)], gj);
      } else {
        const SymTensor6& S = cond.tensor(ci);
        for (int a = 0; a < 4; ++a)
          col[std::lower_bound(rowIdx, rowEnd, q[a]) - rowIdx] += g.volume * bilinear(S, g.grad[size_t(a)], gj);
      }
    }
  });
  progress.report(1.0);
  return K;
}

Eigen::VectorXd assembleLoad(const TetMesh& mesh, double f) {
  Eigen::VectorXd b = Eigen::VectorXd::Zero(Eigen::Index(mesh.numPoints()));
  for (size_t t = 0; t < mesh.numTets(); ++t) {
    const double w = f * mesh.tetVolume(t) / 4.0;
    for (int32_t v : mesh.tets[t]) b[v] += w;
  }
  return b;
}

Eigen::VectorXd assembleLoad(const TetMesh& mesh, const std::vector<double>& fv) {
  if (fv.size() != mesh.numPoints())
    throw InputError("source values: " + std::to_string(fv.size()) + " values for " +
                     std::to_string(mesh.numPoints()) + " vertices");
  Eigen::VectorXd b = Eigen::VectorXd::Zero(Eigen::Index(mesh.numPoints()));
  for (size_t t = 0; t < mesh.numTets(); ++t) {
    const auto& q = mesh.tets[t];
    const double w = mesh.tetVolume(t) / 20.0;
    const double sum = fv[q[0]] + fv[q[1]] + fv[q[2]] + fv[q[3]];
    for (int32_t v : q) b[v] += w * (fv[size_t(v)] + sum);
  }
  return b;
}

std::optional<PointLocation> locatePoint(const TetMesh& mesh, const Vec3& p) {
  const int64_t nt = static_cast<int64_t>(mesh.numTets());
  int64_t best = std::numeric_limits<int64_t>::max();
#pragma omp parallel for schedule(static) reduction(min : best)
  for (int64_t t = 0; t < nt; ++t)
    if (tetContainsPoint(mesh, t, p)) best = std::min(best, t);
  if (best == std::numeric_limits<int64_t>::max()) return std::nullopt;
  return pointLocationIn(mesh, best, p);
}

namespace {
std::string vecText(const Vec3& v) {
  std::ostringstream s;
  s << "(" << v[0] << " " << v[1] << " " << v[2] << ")";
  return s.str();
}
PointLocation requireLocation(const TetMesh& mesh, const Vec3& p, const std::string& what) {
  auto loc = locatePoint(mesh, p);
  if (!loc) {
    std::string msg = what;
    msg += " at ";
    msg += vecText(p);
    msg += " mm lies outside the mesh";
    throw InputError(msg);
  }
  return *loc;
}
} // namespace

PointLocation addPointSource(const TetMesh& mesh, const Vec3& p, double current, Eigen::VectorXd& b,
                             const std::string& what) {
  const PointLocation loc = requireLocation(mesh, p, what);
  const auto& q = mesh.tets[size_t(loc.tet)];
  for (int a = 0; a < 4; ++a) b[q[a]] += current * loc.bary[size_t(a)];
  return loc;
}

std::vector<PointLocation> addDipole(const TetMesh& mesh, const Vec3& position, const Vec3& moment,
                                     double separation, Eigen::VectorXd& b) {
  const double m = norm(moment);
  if (!(m > 0) || !std::isfinite(m))
    throw InputError("dipole_moment " + vecText(moment) + " mA mm: must be a non-zero finite vector");
  if (!(separation >= 0) || !std::isfinite(separation))
    throw InputError("dipole_separation must be a finite number >= 0 mm");
  if (separation == 0.0) {
    const PointLocation loc = requireLocation(mesh, position, "dipole_position");
    const TetGradients g = tetGradients(mesh, size_t(loc.tet));
    const auto& q = mesh.tets[size_t(loc.tet)];
    for (int a = 0; a < 4; ++a) b[q[a]] += dot(moment, g.grad[size_t(a)]);
    return {loc};
  }
  const Vec3 dir = (1.0 / m) * moment;
  const double I = m / separation;
  const Vec3 plus = position + (0.5 * separation) * dir;
  const Vec3 minus = position - (0.5 * separation) * dir;
  PointLocation a = addPointSource(mesh, plus, I, b, "dipole source pole (dipole_position + separation/2)");
  PointLocation c = addPointSource(mesh, minus, -I, b, "dipole sink pole (dipole_position - separation/2)");
  return {a, c};
}

void multiplySymmetric(const SparseMatrix& K, const Eigen::VectorXd& x, Eigen::VectorXd& y) {
  y.resize(K.cols());
  multiplySymmetric(K, x.data(), y.data());
}

void multiplySymmetric(const SparseMatrix& K, const double* xp, double* yp) {
  const int64_t n = K.cols();
  const int* outer = K.outerIndexPtr();
  const int* inner = K.innerIndexPtr();
  const double* val = K.valuePtr();
#pragma omp parallel for schedule(static, 1024) if (K.nonZeros() > 20000)
  for (int64_t j = 0; j < n; ++j) {
    double s = 0.0;
    for (int p = outer[j]; p < outer[j + 1]; ++p) s += val[p] * xp[inner[p]];
    yp[j] = s;
  }
}

} // namespace tetflow
