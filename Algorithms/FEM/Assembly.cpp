#include "Assembly.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Quality/TetQuality.h"

namespace tetflow {

namespace {

// Index of the (a,b) entry, a <= b, of a symmetric 4x4 local matrix stored as 10 numbers.
constexpr int kSym[4][4] = {{0, 1, 2, 3}, {1, 4, 5, 6}, {2, 5, 7, 8}, {3, 6, 8, 9}};

bool contains(const TetMesh::Tet& t, int32_t v) {
  return t[0] == v || t[1] == v || t[2] == v || t[3] == v;
}

} // namespace

VertexTets buildVertexTets(const TetMesh& mesh) {
  VertexTets a;
  const size_t np = mesh.numPoints();
  a.offsets.assign(np + 1, 0);
  for (const auto& t : mesh.tets)
    for (int32_t v : t) ++a.offsets[size_t(v) + 1];
  for (size_t v = 0; v < np; ++v) a.offsets[v + 1] += a.offsets[v];
  a.tets.resize(size_t(a.offsets[np]));
  std::vector<int64_t> fill(a.offsets.begin(), a.offsets.end() - 1);
  for (size_t t = 0; t < mesh.numTets(); ++t)
    for (int32_t v : mesh.tets[t]) a.tets[size_t(fill[size_t(v)]++)] = static_cast<int32_t>(t);
  return a;
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

std::vector<uint8_t> boundaryVertexFlags(const TetMesh& mesh, const VertexTets& adj) {
  std::vector<uint8_t> flags(mesh.numPoints(), 0);
  const int64_t nt = static_cast<int64_t>(mesh.numTets());
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < nt; ++t) {
    const auto& q = mesh.tets[size_t(t)];
    for (int k = 0; k < 4; ++k) {
      int32_t f[3];
      int n = 0;
      for (int i = 0; i < 4; ++i)
        if (i != k) f[n++] = q[i];
      // Scan the tets around the face vertex with the fewest incident tets.
      int32_t a = f[0];
      for (int i = 1; i < 3; ++i)
        if (adj.count(size_t(f[i])) < adj.count(size_t(a))) a = f[i];
      bool shared = false;
      for (int64_t s = adj.offsets[size_t(a)]; s < adj.offsets[size_t(a) + 1] && !shared; ++s) {
        const int32_t other = adj.tets[size_t(s)];
        if (other == t) continue;
        const auto& o = mesh.tets[size_t(other)];
        shared = contains(o, f[0]) && contains(o, f[1]) && contains(o, f[2]);
      }
      if (!shared)
        for (int32_t v : f) std::atomic_ref<uint8_t>(flags[size_t(v)]).store(1, std::memory_order_relaxed);
    }
  }
  return flags;
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

SparseMatrix assembleStiffness(const TetMesh& mesh, const ConductivityTable& sigma, Progress& progress) {
  mesh.validateStructure("mesh");
  const VertexTets adj = buildVertexTets(mesh);
  return assembleStiffness(mesh, sigma, adj, progress);
}

SparseMatrix assembleStiffness(const TetMesh& mesh, const ConductivityTable& sigma,
                               const VertexTets& adj, Progress& progress) {
  mesh.validateStructure("mesh");
  sigma.validate();
  checkTetVolumes(mesh);
  const int64_t nt = static_cast<int64_t>(mesh.numTets());
  const int64_t np = static_cast<int64_t>(mesh.numPoints());
  if (np >= int64_t(std::numeric_limits<int>::max()))
    throw InputError("mesh has too many vertices for 32-bit sparse indices");

  // Tensors per label (map lookups once, not per tet).
  std::vector<int32_t> labels(mesh.materials.begin(), mesh.materials.end());
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  std::vector<Mat3> tensors;
  for (int32_t l : labels) tensors.push_back(tensorMatrix(sigma.tensor(l)));
  std::vector<uint16_t> labelIndex;
  const bool fewLabels = labels.size() < 65536;
  if (fewLabels) {
    labelIndex.resize(size_t(nt));
#pragma omp parallel for schedule(static)
    for (int64_t t = 0; t < nt; ++t)
      labelIndex[size_t(t)] = static_cast<uint16_t>(
          std::lower_bound(labels.begin(), labels.end(), mesh.materials[size_t(t)]) - labels.begin());
  }

  // Local matrix of tet t (10 unique entries). Computed where needed (once per tet corner in the
  // fill below) rather than stored: the same code gives the same bits every time, so K stays
  // exactly symmetric, and no 80 B/tet array is needed.
  auto localMatrix = [&](int64_t t, double* out) {
    const TetGradients g = tetGradients(mesh, size_t(t));
    const size_t li = fewLabels ? labelIndex[size_t(t)]
                                : size_t(std::lower_bound(labels.begin(), labels.end(),
                                                          mesh.materials[size_t(t)]) - labels.begin());
    const Mat3& S = tensors[li];
    Vec3 sg[4];
    for (int b = 0; b < 4; ++b) sg[b] = mul(S, g.grad[b]);
    for (int a = 0; a < 4; ++a)
      for (int b = a; b < 4; ++b) out[kSym[a][b]] = g.volume * dot(g.grad[a], sg[b]);
  };
  progress.report(0.1);

  // 2. Sparsity pattern: column j holds the vertices of the tets around j (sorted, unique).
  SparseMatrix K(np, np);
  std::vector<int64_t> colCount(size_t(np) + 1, 0);
  auto neighbours = [&](int64_t j, std::vector<int32_t>& buf) {
    buf.clear();
    for (int64_t s = adj.offsets[size_t(j)]; s < adj.offsets[size_t(j) + 1]; ++s)
      for (int32_t v : mesh.tets[size_t(adj.tets[size_t(s)])]) buf.push_back(v);
    std::sort(buf.begin(), buf.end());
    buf.erase(std::unique(buf.begin(), buf.end()), buf.end());
  };
#pragma omp parallel
  {
    std::vector<int32_t> buf;
#pragma omp for schedule(dynamic, 4096)
    for (int64_t j = 0; j < np; ++j) {
      neighbours(j, buf);
      colCount[size_t(j) + 1] = int64_t(buf.size());
    }
  }
  progress.checkCancel();
  for (int64_t j = 0; j < np; ++j) colCount[size_t(j) + 1] += colCount[size_t(j)];
  const int64_t nnz = colCount[size_t(np)];
  if (nnz >= int64_t(std::numeric_limits<int>::max()))
    throw InputError("stiffness matrix has too many non-zeros for 32-bit sparse indices");
  K.resizeNonZeros(nnz);
  int* outer = K.outerIndexPtr();
  int* inner = K.innerIndexPtr();
  double* values = K.valuePtr();
  for (int64_t j = 0; j <= np; ++j) outer[j] = static_cast<int>(colCount[size_t(j)]);
  progress.report(0.5);

  // 3. Fill column by column: each column is owned by one thread; contributions are added in
  //    ascending tet order, so the sums do not depend on the thread count.
#pragma omp parallel
  {
    std::vector<int32_t> buf;
#pragma omp for schedule(dynamic, 4096)
    for (int64_t j = 0; j < np; ++j) {
      neighbours(j, buf);
      const int64_t start = colCount[size_t(j)];
      for (size_t k = 0; k < buf.size(); ++k) {
        inner[start + int64_t(k)] = buf[k];
        values[start + int64_t(k)] = 0.0;
      }
      for (int64_t s = adj.offsets[size_t(j)]; s < adj.offsets[size_t(j) + 1]; ++s) {
        const int32_t t = adj.tets[size_t(s)];
        const auto& q = mesh.tets[size_t(t)];
        int lj = 0;
        while (q[lj] != j) ++lj;
        double loc[10];
        localMatrix(t, loc);
        for (int a = 0; a < 4; ++a) {
          const auto pos = std::lower_bound(buf.begin(), buf.end(), q[a]) - buf.begin();
          values[start + pos] += loc[kSym[a][lj]];
        }
      }
    }
  }
  progress.checkCancel();
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
  constexpr double kEps = 1e-10;
#pragma omp parallel for schedule(static) reduction(min : best)
  for (int64_t t = 0; t < nt; ++t) {
    const auto& q = mesh.tets[size_t(t)];
    // Quick bounding-box rejection.
    bool out = false;
    for (int c = 0; c < 3 && !out; ++c) {
      double lo = mesh.points[q[0]][c], hi = lo;
      for (int i = 1; i < 4; ++i) {
        lo = std::min(lo, mesh.points[q[i]][c]);
        hi = std::max(hi, mesh.points[q[i]][c]);
      }
      const double pad = 1e-9 * (hi - lo);
      out = p[c] < lo - pad || p[c] > hi + pad;
    }
    if (out) continue;
    const TetGradients g = tetGradients(mesh, size_t(t));
    if (!(g.volume > 0)) continue;
    const Vec3 d = p - mesh.points[q[0]];
    double l[4];
    l[1] = dot(g.grad[1], d);
    l[2] = dot(g.grad[2], d);
    l[3] = dot(g.grad[3], d);
    l[0] = 1.0 - l[1] - l[2] - l[3];
    if (l[0] >= -kEps && l[1] >= -kEps && l[2] >= -kEps && l[3] >= -kEps) best = std::min(best, t);
  }
  if (best == std::numeric_limits<int64_t>::max()) return std::nullopt;
  PointLocation loc;
  loc.tet = best;
  const TetGradients g = tetGradients(mesh, size_t(best));
  const Vec3 d = p - mesh.points[mesh.tets[size_t(best)][0]];
  for (int a = 1; a < 4; ++a) loc.bary[size_t(a)] = dot(g.grad[size_t(a)], d);
  loc.bary[0] = 1.0 - loc.bary[1] - loc.bary[2] - loc.bary[3];
  return loc;
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
