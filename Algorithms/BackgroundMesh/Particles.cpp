#include "Particles.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/MemoryBudget.h"
#include "BarnesHut.h"
#include "TetgenDelaunay.h"

namespace tetflow {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int64_t kMaxParticles = int64_t(1) << 28;
// Peak bytes per particle of the whole kind (docs/reliability.md; aims high).
constexpr double kParticleBytes = 4000.0;

std::string num(double x) {
  std::ostringstream o;
  o << x;
  return o.str();
}

// Target spacing l(x) at a local point: the sizing volume interpolated trilinearly (constant
// beyond its outer sample centres), times size_scale, clamped.
class SpacingField {
public:
  SpacingField(const GridGeometry& grid, const ScalarVolume& s, const ParticleParams& p)
      : grid_(grid), s_(s), scale_(p.size_scale), lo_(p.min_size), hi_(p.max_size) {
    const Mat3& d = s.grid.direction;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) inv_[r][c] = d[c][r] / s.grid.spacing[r];
  }
  double at(const Vec3& local) const {
    const Vec3 phys = grid_.origin + mul(grid_.direction, local);
    const Vec3 q = mul(inv_, phys - s_.grid.origin);
    int64_t i0[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
      const int64_t n = s_.grid.dims[size_t(a)];
      const double x = std::clamp(q[a], 0.0, double(n - 1));
      i0[a] = std::min<int64_t>(int64_t(std::floor(x)), std::max<int64_t>(n - 2, 0));
      f[a] = n > 1 ? x - double(i0[a]) : 0.0;
    }
    double v = 0;
    for (int c = 0; c < 8; ++c) {
      double w = 1;
      int64_t idx[3];
      for (int a = 0; a < 3; ++a) {
        const int bit = (c >> a) & 1;
        w *= bit ? f[a] : 1 - f[a];
        idx[a] = std::min<int64_t>(i0[a] + bit, s_.grid.dims[size_t(a)] - 1);
      }
      if (w != 0) v += w * double(s_.at(idx[0], idx[1], idx[2]));
    }
    v *= scale_;
    if (lo_ > 0) v = std::max(v, lo_);
    if (hi_ > 0) v = std::min(v, hi_);
    return v;
  }

private:
  const GridGeometry& grid_;
  const ScalarVolume& s_;
  Mat3 inv_;
  double scale_, lo_, hi_;
};

struct Particle {
  Vec3 x;
  double charge;
};

// A regular grid of nodes over the box: values per node, trilinear interpolation.
struct NodeGrid {
  Vec3 lo{0, 0, 0}, h{1, 1, 1};
  int64_t n[3] = {0, 0, 0}; // cells per axis (nodes n + 1)
  int64_t nodes() const { return (n[0] + 1) * (n[1] + 1) * (n[2] + 1); }
  int64_t id(int64_t i, int64_t j, int64_t k) const { return i + (n[0] + 1) * (j + (n[1] + 1) * k); }
  Vec3 node(int64_t i, int64_t j, int64_t k) const {
    return {lo[0] + double(i) * h[0], lo[1] + double(j) * h[1], lo[2] + double(k) * h[2]};
  }
  // Corner ids and weights of the cell holding x (clamped to the grid).
  void weights(const Vec3& x, int64_t ids[8], double w[8]) const {
    int64_t c[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
      const double t = std::clamp((x[a] - lo[a]) / h[a], 0.0, double(n[a]));
      c[a] = std::min<int64_t>(int64_t(t), n[a] - 1);
      f[a] = t - double(c[a]);
    }
    for (int q = 0; q < 8; ++q) {
      const int b0 = q & 1, b1 = (q >> 1) & 1, b2 = (q >> 2) & 1;
      ids[q] = id(c[0] + b0, c[1] + b1, c[2] + b2);
      w[q] = (b0 ? f[0] : 1 - f[0]) * (b1 ? f[1] : 1 - f[1]) * (b2 ? f[2] : 1 - f[2]);
    }
  }
};

// Points on the segment a -> b at equal steps of the integral of 1/l (interior points only).
std::vector<Vec3> edgePoints(const Vec3& a, const Vec3& b, const SpacingField& l, double lmin) {
  const double len = norm(b - a);
  const int64_t m = std::clamp<int64_t>(int64_t(std::ceil(8 * len / lmin)), 64, 1 << 22);
  std::vector<double> cum(size_t(m) + 1, 0.0);
  for (int64_t i = 0; i < m; ++i) {
    const Vec3 mid = a + ((double(i) + 0.5) / double(m)) * (b - a);
    cum[size_t(i) + 1] = cum[size_t(i)] + (len / double(m)) / l.at(mid);
  }
  const double total = cum.back();
  const int64_t segs = std::max<int64_t>(1, std::llround(total));
  std::vector<Vec3> out;
  size_t j = 0;
  for (int64_t k = 1; k < segs; ++k) {
    const double target = total * double(k) / double(segs);
    while (j + 1 < cum.size() && cum[j + 1] < target) ++j;
    const double t = (double(j) + (target - cum[j]) / std::max(cum[j + 1] - cum[j], 1e-300)) / double(m);
    out.push_back(a + t * (b - a));
  }
  return out;
}

// Error-diffusion rounding of expected counts (in the given cell order) into whole counts.
std::vector<int64_t> diffuseCounts(const std::vector<double>& expected) {
  std::vector<int64_t> c(expected.size());
  double carry = 0;
  for (size_t i = 0; i < expected.size(); ++i) {
    const double want = expected[i] + carry;
    c[i] = std::max<int64_t>(0, std::llround(want));
    carry = want - double(c[i]);
  }
  return c;
}

} // namespace

ParticleMeshResult generateParticleMesh(const GridGeometry& grid, const ScalarVolume& sizing, const ParticleParams& p,
                                        Progress& progress) {
  grid.validate("background mesh: volume");
  auto need = [](bool ok, const std::string& what) {
    if (!ok) throw InputError(what);
  };
  need(p.padding >= 0 && std::isfinite(p.padding), "padding must be >= 0 mm");
  need(p.min_size >= 0 && std::isfinite(p.min_size), "particle min_cell_size must be >= 0 mm (0 = none)");
  need(p.max_size >= 0 && std::isfinite(p.max_size), "particle max_cell_size must be >= 0 mm (0 = none)");
  need(p.max_size == 0 || p.max_size >= p.min_size, "min_cell_size is larger than max_cell_size");
  need(p.size_scale > 0 && std::isfinite(p.size_scale), "particle_size_scale must be > 0");
  need(p.max_iterations >= 0 && p.max_iterations <= 100000, "particle_iterations must be in [0, 100000]");
  need(p.theta >= 0 && p.theta <= 1.5, "particle_theta must be in [0, 1.5]");
  need(p.move_tolerance > 0 && std::isfinite(p.move_tolerance), "particle_tolerance must be > 0");
  need(p.poisson_samples >= 8 && p.poisson_samples <= 512, "particle poisson_samples must be in [8, 512]");
  const SizeRange range = checkSizingField(sizing);

  ParticleMeshResult res;
  ParticleStats& st = res.stats;
  const SpacingField L(grid, sizing, p);
  Vec3 lo, hi, len;
  for (int a = 0; a < 3; ++a) {
    lo[a] = -0.5 * grid.spacing[a] - p.padding;
    len[a] = double(grid.dims[a]) * grid.spacing[a] + 2.0 * p.padding;
    hi[a] = lo[a] + len[a];
  }
  const double longest = std::max({len[0], len[1], len[2]});

  // Smallest spacing the field asks for anywhere (an estimate for the grid below).
  double lminGuess = double(range.min) * p.size_scale;
  if (p.min_size > 0) lminGuess = std::max(lminGuess, p.min_size);
  if (p.max_size > 0) lminGuess = std::min(lminGuess, p.max_size);
  // Poisson / seeding grid.
  NodeGrid ng;
  {
    // poisson_samples along the longest axis, or fewer when that is finer than half the smallest
    // spacing the field asks for (small boxes).
    const double h = std::max(longest / double(p.poisson_samples - 1), 0.5 * lminGuess);
    for (int a = 0; a < 3; ++a) {
      ng.n[a] = std::max<int64_t>(2, std::llround(len[a] / h));
      ng.h[a] = len[a] / double(ng.n[a]);
    }
    ng.lo = lo;
  }
  const int64_t nodes = ng.nodes();
  std::vector<double> lNode(static_cast<size_t>(nodes));
#pragma omp parallel for schedule(static)
  for (int64_t k = 0; k <= ng.n[2]; ++k)
    for (int64_t j = 0; j <= ng.n[1]; ++j)
      for (int64_t i = 0; i <= ng.n[0]; ++i) lNode[size_t(ng.id(i, j, k))] = L.at(ng.node(i, j, k));
  double lmin = *std::min_element(lNode.begin(), lNode.end());
  // Background charge of each node (trapezoid weight x rho, before the neutralising scale); their
  // sum is the ideal particle count, known before anything is allocated for it.
  std::vector<double> nodeCharge(static_cast<size_t>(nodes));
  {
    double q = 0;
    for (int64_t k = 0; k <= ng.n[2]; ++k)
      for (int64_t j = 0; j <= ng.n[1]; ++j)
        for (int64_t i = 0; i <= ng.n[0]; ++i) {
          const int64_t id = ng.id(i, j, k);
          const double w = (i == 0 || i == ng.n[0] ? 0.5 : 1.0) * (j == 0 || j == ng.n[1] ? 0.5 : 1.0) *
                           (k == 0 || k == ng.n[2] ? 0.5 : 1.0) * ng.h[0] * ng.h[1] * ng.h[2];
          nodeCharge[size_t(id)] = w * std::sqrt(2.0) / std::pow(lNode[size_t(id)], 3);
          q += nodeCharge[size_t(id)];
        }
    st.backgroundCharge = q;
    if (!(q < double(kMaxParticles)))
      throw InputError("the sizing field asks for " + num(q) + " particles (more than 2^28); raise min_cell_size, the "
                       "sizing field's min_size or particle_size_scale");
    // Peak: TetGen's Delaunay structures and the mesh improvement's (about 6.5 tets per particle).
    requireMemory(kParticleBytes * q, "the particle background (" + num(std::round(q)) + " particles)",
                  [&](double avail) {
                    return "use particle_size_scale >= " +
                           num(roundUpForAdvice(p.size_scale * std::cbrt(kParticleBytes * q / avail)));
                  });
  }

  // ---- boundary ------------------------------------------------------------------------------
  progress.beginStage("boundary");
  std::vector<Particle> parts;
  for (int c = 0; c < 8; ++c)
    parts.push_back({{(c & 1) ? hi[0] : lo[0], (c & 2) ? hi[1] : lo[1], (c & 4) ? hi[2] : lo[2]}, 0.125});
  st.corners = 8;
  for (int a = 0; a < 3; ++a)
    for (int e = 0; e < 4; ++e) {
      const int b = (a + 1) % 3, c = (a + 2) % 3;
      Vec3 A, B;
      A[b] = B[b] = (e & 1) ? hi[b] : lo[b];
      A[c] = B[c] = (e & 2) ? hi[c] : lo[c];
      A[a] = lo[a];
      B[a] = hi[a];
      for (const Vec3& x : edgePoints(A, B, L, lmin)) parts.push_back({x, 0.25});
    }
  st.edgeParticles = int64_t(parts.size()) - 8;
  progress.checkCancel();
  std::mt19937_64 rng(p.seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const size_t edgeEnd = parts.size();
  for (int a = 0; a < 3; ++a)
    for (int side = 0; side < 2; ++side) {
      const int b = (a + 1) % 3, c = (a + 2) % 3;
      const double plane = side ? hi[a] : lo[a];
      auto onFace = [&](const Vec3& x) { return x[a] == plane; };
      std::vector<size_t> fixedIds;
      for (size_t i = 0; i < edgeEnd; ++i)
        if (onFace(parts[i].x)) fixedIds.push_back(i);
      // Face grid for seeding.
      const int64_t nb = std::clamp<int64_t>(int64_t(std::ceil(len[b] / (0.5 * lmin))), 1, 1024);
      const int64_t nc = std::clamp<int64_t>(int64_t(std::ceil(len[c] / (0.5 * lmin))), 1, 1024);
      const double gb = len[b] / double(nb), gc = len[c] / double(nc);
      std::vector<double> expect(size_t(nb * nc));
      std::vector<int64_t> order;
      order.reserve(expect.size());
      double total = 0;
      for (int64_t jc = 0; jc < nc; ++jc)
        for (int64_t jb0 = 0; jb0 < nb; ++jb0) {
          const int64_t jb = (jc & 1) ? nb - 1 - jb0 : jb0; // serpentine, so the carry stays local
          Vec3 x;
          x[a] = plane;
          x[b] = lo[b] + (double(jb) + 0.5) * gb;
          x[c] = lo[c] + (double(jc) + 0.5) * gc;
          const double l = L.at(x);
          const double e = 2.0 / std::sqrt(3.0) / (l * l) * gb * gc;
          expect[order.size()] = e;
          order.push_back(jb + nb * jc);
          total += e;
        }
      const double want = std::max(0.0, std::round(total - 0.5 * double(fixedIds.size())));
      if (total > 0)
        for (double& e : expect) e *= want / total;
      const std::vector<int64_t> counts = diffuseCounts(expect);
      const size_t first = parts.size();
      for (size_t o = 0; o < order.size(); ++o) {
        const int64_t jb = order[o] % nb, jc = order[o] / nb;
        for (int64_t k = 0; k < counts[o]; ++k) {
          Vec3 x;
          x[a] = plane;
          x[b] = lo[b] + (double(jb) + uni(rng)) * gb;
          x[c] = lo[c] + (double(jc) + uni(rng)) * gc;
          parts.push_back({x, 0.5});
        }
      }
      const size_t last = parts.size();
      if (last == first) continue;
      // Relax in the face's plane: DistMesh-style springs between points closer than 1.2 x
      // their mean spacing; the face's edge and corner points are fixed.
      std::vector<size_t> ids = fixedIds;
      for (size_t i = first; i < last; ++i) ids.push_back(i);
      const double cell = 1.2 * lmin;
      const int64_t cb = std::max<int64_t>(1, int64_t(std::ceil(len[b] / cell)));
      const int64_t cc = std::max<int64_t>(1, int64_t(std::ceil(len[c] / cell)));
      std::vector<double> lp(parts.size(), 0.0);
      const int faceIterations = 80;
      for (int it = 0; it < faceIterations; ++it) {
        for (size_t i : ids) lp[i] = L.at(parts[i].x);
        std::vector<std::vector<size_t>> bins(size_t(cb * cc));
        auto binOf = [&](const Vec3& x, int64_t& ib, int64_t& ic) {
          ib = std::clamp<int64_t>(int64_t((x[b] - lo[b]) / cell), 0, cb - 1);
          ic = std::clamp<int64_t>(int64_t((x[c] - lo[c]) / cell), 0, cc - 1);
        };
        for (size_t i : ids) {
          int64_t ib, ic;
          binOf(parts[i].x, ib, ic);
          bins[size_t(ib + cb * ic)].push_back(i);
        }
        std::vector<Vec3> moves(last - first, Vec3{0, 0, 0});
#pragma omp parallel for schedule(dynamic, 64)
        for (int64_t ii = int64_t(first); ii < int64_t(last); ++ii) {
          const size_t i = size_t(ii);
          const Vec3& xi = parts[i].x;
          const double R = 1.8 * lp[i];
          int64_t ib, ic;
          binOf(xi, ib, ic);
          const int64_t rad = int64_t(std::ceil(R / cell));
          Vec3 f{0, 0, 0};
          for (int64_t dc = -rad; dc <= rad; ++dc)
            for (int64_t db = -rad; db <= rad; ++db) {
              const int64_t xb = ib + db, xc = ic + dc;
              if (xb < 0 || xc < 0 || xb >= cb || xc >= cc) continue;
              for (size_t j : bins[size_t(xb + cb * xc)]) {
                if (j == i) continue;
                const Vec3 d = xi - parts[j].x;
                const double r = norm(d);
                const double r0 = 0.6 * (lp[i] + lp[j]);
                if (r >= r0) continue;
                if (r < 1e-12 * r0) { // coincident: push apart along a fixed in-plane direction
                  f[b] += 1.0;
                  continue;
                }
                f = f + ((r0 - r) / r0 / r) * d;
              }
            }
          Vec3 mv = (0.2 * lp[i]) * f;
          const double m = norm(mv);
          if (m > 0.2 * lp[i]) mv = (0.2 * lp[i] / m) * mv;
          moves[i - first] = mv;
        }
        for (size_t i = first; i < last; ++i) {
          Vec3& x = parts[i].x;
          x = x + moves[i - first];
          const double margin = 0.25 * lp[i];
          for (int ax : {b, c}) {
            const double m = std::min(margin, 0.5 * len[ax]);
            x[ax] = std::clamp(x[ax], lo[ax] + m, hi[ax] - m);
          }
          x[a] = plane;
        }
        progress.checkCancel();
      }
      st.faceIterations = faceIterations;
    }
  st.faceParticles = int64_t(parts.size() - edgeEnd);
  const size_t boundaryEnd = parts.size();
  double qBoundary = 0;
  for (const Particle& q : parts) qBoundary += q.charge;

  // ---- interior seeding (in proportion to rho over the Poisson grid's cells) ----------------
  {
    std::vector<double> expect;
    std::vector<int64_t> cellOf;
    double total = 0;
    for (int64_t k = 0; k < ng.n[2]; ++k)
      for (int64_t j0 = 0; j0 < ng.n[1]; ++j0) {
        const int64_t j = (k & 1) ? ng.n[1] - 1 - j0 : j0;
        for (int64_t i0 = 0; i0 < ng.n[0]; ++i0) {
          const int64_t i = ((j0 + k) & 1) ? ng.n[0] - 1 - i0 : i0;
          const Vec3 c = ng.node(i, j, k) + 0.5 * ng.h;
          const double l = L.at(c);
          const double e = std::sqrt(2.0) / (l * l * l) * ng.h[0] * ng.h[1] * ng.h[2];
          expect.push_back(e);
          cellOf.push_back(i + ng.n[0] * (j + ng.n[1] * k));
          total += e;
        }
      }
    const double want = std::max(0.0, std::round(total - qBoundary));
    if (total > 0)
      for (double& e : expect) e *= want / total;
    const std::vector<int64_t> counts = diffuseCounts(expect);
    for (size_t o = 0; o < counts.size(); ++o) {
      const int64_t i = cellOf[o] % ng.n[0], j = (cellOf[o] / ng.n[0]) % ng.n[1], k = cellOf[o] / (ng.n[0] * ng.n[1]);
      for (int64_t m = 0; m < counts[o]; ++m) {
        Vec3 x = ng.node(i, j, k);
        for (int a = 0; a < 3; ++a) x[a] += uni(rng) * ng.h[a];
        const double margin = 0.25 * L.at(x);
        for (int a = 0; a < 3; ++a) x[a] = std::clamp(x[a], lo[a] + std::min(margin, 0.5 * len[a]), hi[a] - std::min(margin, 0.5 * len[a]));
        parts.push_back({x, 1.0});
      }
    }
  }
  st.interiorParticles = int64_t(parts.size() - boundaryEnd);
  double qTotal = 0;
  for (const Particle& q : parts) qTotal += q.charge;

  // ---- potential of the background charge ----------------------------------------------------
  progress.beginStage("potential");
  std::vector<double> phi(size_t(nodes), 0.0);
  std::vector<Vec3> efield(size_t(nodes), Vec3{0, 0, 0});
  double scale = 0;
  {
    std::vector<Vec3> pn(static_cast<size_t>(nodes));
    for (int64_t k = 0; k <= ng.n[2]; ++k)
      for (int64_t j = 0; j <= ng.n[1]; ++j)
        for (int64_t i = 0; i <= ng.n[0]; ++i) pn[size_t(ng.id(i, j, k))] = ng.node(i, j, k);
    scale = st.backgroundCharge > 0 ? qTotal / st.backgroundCharge : 0.0;
    std::vector<double> qn = std::move(nodeCharge);
    for (double& q : qn) q *= scale;
    // Dirichlet values: free-space potential of the (negative) background charges.
    const BarnesHutTree tree(pn, qn);
    const double hbar = std::cbrt(ng.h[0] * ng.h[1] * ng.h[2]);
    std::vector<int64_t> bnodes;
    for (int64_t k = 0; k <= ng.n[2]; ++k)
      for (int64_t j = 0; j <= ng.n[1]; ++j)
        for (int64_t i = 0; i <= ng.n[0]; ++i)
          if (i == 0 || j == 0 || k == 0 || i == ng.n[0] || j == ng.n[1] || k == ng.n[2]) bnodes.push_back(ng.id(i, j, k));
    LoopCancel lc(progress);
#pragma omp parallel for schedule(dynamic, 256)
    for (int64_t b = 0; b < int64_t(bnodes.size()); ++b) {
      if (lc.skip()) continue; // every node: each is a full tree walk
      const int64_t id = bnodes[size_t(b)];
      // Self term: the potential of a node's own cell of charge at its centre (a cube of edge h
      // gives 2.38 rho h^2 = q / (0.42 h); halves and quarters at the box keep the ratio).
      phi[size_t(id)] = -(tree.evaluate(pn[size_t(id)], id, 0.3, 0.0).potential + qn[size_t(id)] / (0.42 * hbar));
    }
    lc.rethrow();
    // Interior: 7-point Laplacian, lap(phi) = 4 pi rho'.
    const int64_t mi = ng.n[0] - 1, mj = ng.n[1] - 1, mk = ng.n[2] - 1;
    const int64_t m = mi * mj * mk;
    st.poissonNodes = int(nodes);
    if (m > 0) {
      auto uid = [&](int64_t i, int64_t j, int64_t k) { return (i - 1) + mi * ((j - 1) + mj * (k - 1)); };
      std::vector<Eigen::Triplet<double>> trip;
      trip.reserve(size_t(m) * 7);
      Eigen::VectorXd rhs(m);
      const double ih2[3] = {1 / (ng.h[0] * ng.h[0]), 1 / (ng.h[1] * ng.h[1]), 1 / (ng.h[2] * ng.h[2])};
      for (int64_t k = 1; k < ng.n[2]; ++k)
        for (int64_t j = 1; j < ng.n[1]; ++j)
          for (int64_t i = 1; i < ng.n[0]; ++i) {
            const int64_t r = uid(i, j, k);
            const int64_t id = ng.id(i, j, k);
            // -lap(phi) = -4 pi rho'
            double b = -4 * kPi * scale * std::sqrt(2.0) / std::pow(lNode[size_t(id)], 3);
            trip.emplace_back(r, r, 2 * (ih2[0] + ih2[1] + ih2[2]));
            const int64_t nb[6][3] = {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k}, {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}};
            for (int d = 0; d < 6; ++d) {
              const int64_t a = nb[d][0], bb = nb[d][1], c = nb[d][2];
              const double w = ih2[d / 2];
              if (a == 0 || bb == 0 || c == 0 || a == ng.n[0] || bb == ng.n[1] || c == ng.n[2])
                b += w * phi[size_t(ng.id(a, bb, c))];
              else
                trip.emplace_back(r, uid(a, bb, c), -w);
            }
            rhs[r] = b;
          }
      Eigen::SparseMatrix<double> A(m, m);
      A.setFromTriplets(trip.begin(), trip.end());
      trip.clear();
      trip.shrink_to_fit();
      Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper> cg;
      cg.setTolerance(1e-8);
      cg.setMaxIterations(int(20 * (mi + mj + mk) + 100));
      cg.compute(A);
      progress.checkCancel();
      // One uninterrupted solve (0.3 s on the head's 64^3 grid); restarting it in rounds to poll
      // for cancellation would change the iterates.
      const Eigen::VectorXd x = cg.solve(rhs);
      progress.checkCancel();
      st.poissonIterations = int(cg.iterations());
      st.poissonResidual = cg.error();
      for (int64_t k = 1; k < ng.n[2]; ++k)
        for (int64_t j = 1; j < ng.n[1]; ++j)
          for (int64_t i = 1; i < ng.n[0]; ++i) phi[size_t(ng.id(i, j, k))] = x[uid(i, j, k)];
    }
    // E = -grad(phi): central differences, one-sided on the box.
    for (int64_t k = 0; k <= ng.n[2]; ++k)
      for (int64_t j = 0; j <= ng.n[1]; ++j)
        for (int64_t i = 0; i <= ng.n[0]; ++i) {
          const int64_t c[3] = {i, j, k};
          Vec3 e;
          for (int a = 0; a < 3; ++a) {
            int64_t up[3] = {i, j, k}, dn[3] = {i, j, k};
            up[a] = std::min(c[a] + 1, ng.n[a]);
            dn[a] = std::max(c[a] - 1, int64_t(0));
            e[a] = -(phi[size_t(ng.id(up[0], up[1], up[2]))] - phi[size_t(ng.id(dn[0], dn[1], dn[2]))]) /
                   (double(up[a] - dn[a]) * ng.h[a]);
          }
          efield[size_t(ng.id(i, j, k))] = e;
        }
  }

  // ---- relaxation ----------------------------------------------------------------------------
  progress.beginStage("relax");
  const int64_t np = int64_t(parts.size());
  {
    std::vector<Vec3> pos(static_cast<size_t>(np));
    std::vector<double> chg(static_cast<size_t>(np));
    for (int64_t i = 0; i < np; ++i) {
      pos[size_t(i)] = parts[size_t(i)].x;
      chg[size_t(i)] = parts[size_t(i)].charge;
    }
    std::vector<double> e(static_cast<size_t>(np));
    std::vector<Vec3> force(static_cast<size_t>(np));
    std::vector<double> lAt(static_cast<size_t>(np));
    double step = 0.5;
    double best = std::numeric_limits<double>::infinity(), prev = best;
    int sinceBest = 0;
    st.stopReason = "max_iterations";
    const auto t0 = std::chrono::steady_clock::now();
    int it = 0;
    for (; it < p.max_iterations && np > int64_t(boundaryEnd); ++it) {
      const BarnesHutTree tree(pos, chg);
      LoopCancel lc(progress);
#pragma omp parallel for schedule(dynamic, 128)
      for (int64_t i = 0; i < np; ++i) {
        if (lc.skip(i)) continue;
        const Vec3& x = pos[size_t(i)];
        const double l = L.at(x);
        lAt[size_t(i)] = l;
        const BarnesHutTree::Sample s = tree.evaluate(x, i, p.theta, 0.1 * l);
        int64_t ids[8];
        double w[8];
        ng.weights(x, ids, w);
        double pb = 0;
        Vec3 eb{0, 0, 0};
        for (int q = 0; q < 8; ++q) {
          pb += w[q] * phi[size_t(ids[q])];
          eb = eb + w[q] * efield[size_t(ids[q])];
        }
        e[size_t(i)] = chg[size_t(i)] * (0.5 * s.potential + pb);
        force[size_t(i)] = chg[size_t(i)] * (s.field + eb);
      }
      lc.rethrow();
      double energy = 0;
      for (int64_t i = 0; i < np; ++i) energy += e[size_t(i)];
      if (it == 0) st.energyFirst = energy;
      st.energyLast = energy;
      if (energy > prev) step = std::max(0.05, step * 0.7);
      else step = std::min(1.0, step * 1.05);
      prev = energy;
      if (it == 0 || energy < best - 1e-12 * std::abs(best)) {
        best = energy;
        sinceBest = 0;
      } else if (++sinceBest >= 15) {
        st.stopReason = "energy";
        break;
      }
      double maxMove = 0;
#pragma omp parallel for schedule(static) reduction(max : maxMove)
      for (int64_t i = int64_t(boundaryEnd); i < np; ++i) {
        const double l = lAt[size_t(i)];
        const double k = (4 * kPi / 3) * scale * std::sqrt(2.0) / (l * l * l);
        Vec3 mv = (step / k) * force[size_t(i)];
        const double m = norm(mv);
        if (m > 0.3 * l) mv = (0.3 * l / m) * mv;
        Vec3 x = pos[size_t(i)] + mv;
        for (int a = 0; a < 3; ++a) {
          const double mg = std::min(0.2 * l, 0.5 * len[a]);
          x[a] = std::clamp(x[a], lo[a] + mg, hi[a] - mg);
        }
        maxMove = std::max(maxMove, norm(x - pos[size_t(i)]) / l);
        pos[size_t(i)] = x;
      }
      st.lastMaxMove = maxMove;
      progress.report(double(it + 1) / double(std::max(1, p.max_iterations)));
      if (maxMove < p.move_tolerance) {
        ++it;
        st.stopReason = "largest_move";
        break;
      }
    }
    st.iterations = it;
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    st.secondsPerIteration = it > 0 ? secs / it : 0.0;
    for (int64_t i = 0; i < np; ++i) parts[size_t(i)].x = pos[size_t(i)];
  }

  // ---- Delaunay ------------------------------------------------------------------------------
  progress.beginStage("delaunay");
  TetMesh mesh;
  mesh.points.reserve(static_cast<size_t>(np));
  for (const Particle& q : parts) mesh.points.push_back(q.x);
  parts.clear();
  parts.shrink_to_fit();
  int64_t flat = 0, unused = 0;
  progress.checkCancel();
  mesh.tets = tetgenDelaunay(mesh.points, "", &flat, &unused); // TetGen cannot be interrupted
  progress.checkCancel();
  st.flatTets = flat;
  if (unused > 0) { // points TetGen skipped (duplicates): drop them
    std::vector<int32_t> remap(mesh.points.size(), -1);
    for (const auto& t : mesh.tets)
      for (int32_t v : t) remap[size_t(v)] = 0;
    std::vector<Vec3> kept;
    for (size_t v = 0; v < remap.size(); ++v)
      if (remap[v] == 0) {
        remap[v] = int32_t(kept.size());
        kept.push_back(mesh.points[v]);
      }
    for (auto& t : mesh.tets)
      for (int32_t& v : t) v = remap[size_t(v)];
    mesh.points = std::move(kept);
  }
  mesh.materials.assign(mesh.tets.size(), 0);
  st.delaunayTets = int64_t(mesh.tets.size());
  {
    double vol = 0;
    for (size_t t = 0; t < mesh.tets.size(); ++t) vol += mesh.tetVolume(t);
    const double box = len[0] * len[1] * len[2];
    if (std::abs(vol - box) > 1e-6 * box)
      throw ProcessingError("the Delaunay tets of the particles fill " + num(vol) + " mm^3 of the box's " + num(box) +
                            " mm^3 (" + std::to_string(flat) + " flat tets dropped)");
  }

  // ---- slivers -------------------------------------------------------------------------------
  ImproveParams ip;
  ip.min_angle = p.min_angle;
  ip.max_angle = p.max_angle;
  ip.passes = p.improve_passes;
  st.improve = improveMesh(mesh, ip, progress); // stage "improve"; it measures before and after

  // Spacing: mean edge length at each vertex over the target there.
  {
    std::vector<double> sum(mesh.points.size(), 0.0);
    std::vector<int32_t> cnt(mesh.points.size(), 0);
    std::vector<std::pair<int32_t, int32_t>> edges;
    edges.reserve(mesh.tets.size() * 6);
    for (const auto& t : mesh.tets)
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b)
          edges.emplace_back(std::min(t[size_t(a)], t[size_t(b)]), std::max(t[size_t(a)], t[size_t(b)]));
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    for (const auto& [u, v] : edges) {
      const double d = norm(mesh.points[size_t(u)] - mesh.points[size_t(v)]);
      sum[size_t(u)] += d;
      sum[size_t(v)] += d;
      ++cnt[size_t(u)];
      ++cnt[size_t(v)];
    }
    std::vector<double> ratio;
    ratio.reserve(mesh.points.size());
    for (size_t v = 0; v < mesh.points.size(); ++v)
      if (cnt[v] > 0) ratio.push_back(sum[v] / cnt[v] / L.at(mesh.points[v]));
    if (!ratio.empty()) {
      std::sort(ratio.begin(), ratio.end());
      auto pct = [&](double f) { return ratio[size_t(std::min(double(ratio.size() - 1), f * double(ratio.size())))]; };
      st.spacingMedian = pct(0.5);
      st.spacingP05 = pct(0.05);
      st.spacingP95 = pct(0.95);
    }
  }

  // To physical space.
  for (Vec3& x : mesh.points) x = grid.origin + mul(grid.direction, x);
  BackgroundMesh& bg = res.background;
  bg.boxVolume = len[0] * len[1] * len[2];
  bg.mesh = std::move(mesh);
  return res;
}

void reportParticleMesh(const ParticleStats& s, Report& r) {
  r.set("particles", ReportValue(s.corners + s.edgeParticles + s.faceParticles + s.interiorParticles));
  r.set("particles_boundary", ReportValue(s.corners + s.edgeParticles + s.faceParticles));
  r.set("particles_interior", ReportValue(s.interiorParticles));
  r.set("particles_ideal_count", ReportValue(s.backgroundCharge));
  r.set("poisson_nodes", ReportValue(int64_t(s.poissonNodes)));
  r.set("poisson_cg_iterations", ReportValue(int64_t(s.poissonIterations)));
  r.set("particle_iterations", ReportValue(int64_t(s.iterations)));
  r.set("particle_stop", s.stopReason);
  r.set("particle_seconds_per_iteration", ReportValue(s.secondsPerIteration));
  r.set("particle_energy_first", ReportValue(s.energyFirst));
  r.set("particle_energy_last", ReportValue(s.energyLast));
  r.set("particle_last_max_move", ReportValue(s.lastMaxMove));
  r.set("delaunay_tets", ReportValue(s.delaunayTets));
  r.set("delaunay_min_dihedral", ReportValue(s.improve.minBefore));
  r.set("delaunay_max_dihedral", ReportValue(s.improve.maxBefore));
  r.set("sliver_unfixed", ReportValue(s.improve.unfixedCount));
  r.set("min_dihedral", ReportValue(s.improve.minAfter));
  r.set("max_dihedral", ReportValue(s.improve.maxAfter));
  r.set("spacing_ratio_median", ReportValue(s.spacingMedian));
  r.set("spacing_ratio_p05", ReportValue(s.spacingP05));
  r.set("spacing_ratio_p95", ReportValue(s.spacingP95));
}

} // namespace tetflow
