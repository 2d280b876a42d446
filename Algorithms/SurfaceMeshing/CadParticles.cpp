// PSYS particle system on a CAD model (CadParticles.h; seed §3.2–3.3).
#include "CadParticles.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <set>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Progress.h"

namespace tetflow {

namespace {

constexpr double kPi = 3.14159265358979323846;
const double kBeta = 0.5 / std::cos(kPi / 6); // ≈ 0.577: neighbour distance / σ in a hexagonal packing
// Splits and deletes: the bias ε of (3.3) is uniform in [0, kEpsilon), and they are tried every
// kChangeEvery iterations so that the particles settle in between (a particle a split leaves
// beside its parent needs a few steps to find its place).
constexpr double kEpsilon = 0.2;
constexpr int kChangeEvery = 5;
// Largest step per unit force, in σ: about a Newton step, since the stiffness of a hexagonal
// neighbourhood at the ideal distance is about 20/σ (six neighbours, E''(0.58 σ) ≈ 6.2/σ).
constexpr double kMaxLambda = 0.04;

// ---- a small k-d tree over particle positions, rebuilt every iteration ----
class KdTree {
public:
  void build(const std::vector<Vec3>& pts, std::vector<int> ids) {
    pts_ = &pts;
    ids_ = std::move(ids);
    nodes_.clear();
    if (!ids_.empty()) buildNode(0, int(ids_.size()));
  }
  // Calls f(id, distance) for every point within r of q.
  template <class F> void radius(const Vec3& q, double r, F&& f) const {
    if (!nodes_.empty()) radiusNode(0, q, r, r * r, f);
  }
  // The nearest point within r of q that `accept` admits; -1 if none. *dist receives its distance.
  template <class A> int nearest(const Vec3& q, double r, A&& accept, double* dist) const {
    int best = -1;
    double bestD2 = r * r;
    if (!nodes_.empty()) nearestNode(0, q, accept, best, bestD2);
    if (dist) *dist = std::sqrt(bestD2);
    return best;
  }

private:
  struct Node {
    int begin, end; // range in ids_
    int left = -1, right = -1;
    int axis = -1;
    double split = 0;
    Vec3 lo{}, hi{};
  };
  int buildNode(int b, int e) {
    const std::vector<Vec3>& P = *pts_;
    Node n{b, e};
    n.lo = n.hi = P[ids_[b]];
    for (int i = b; i < e; ++i)
      for (int k = 0; k < 3; ++k) {
        n.lo[k] = std::min(n.lo[k], P[ids_[i]][k]);
        n.hi[k] = std::max(n.hi[k], P[ids_[i]][k]);
      }
    const int self = int(nodes_.size());
    nodes_.push_back(n);
    if (e - b > 8) {
      int axis = 0;
      for (int k = 1; k < 3; ++k)
        if (n.hi[k] - n.lo[k] > n.hi[axis] - n.lo[axis]) axis = k;
      const int mid = (b + e) / 2;
      std::nth_element(ids_.begin() + b, ids_.begin() + mid, ids_.begin() + e,
                       [&](int x, int y) { return P[x][axis] < P[y][axis]; });
      const int l = buildNode(b, mid);
      const int r = buildNode(mid, e);
      nodes_[self].left = l;
      nodes_[self].right = r;
      nodes_[self].axis = axis;
    }
    return self;
  }
  static double boxDist2(const Node& n, const Vec3& q) {
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
      const double d = q[k] < n.lo[k] ? n.lo[k] - q[k] : (q[k] > n.hi[k] ? q[k] - n.hi[k] : 0.0);
      d2 += d * d;
    }
    return d2;
  }
  template <class F> void radiusNode(int ni, const Vec3& q, double r, double r2, F& f) const {
    const Node& n = nodes_[ni];
    if (boxDist2(n, q) > r2) return;
    if (n.left < 0) {
      for (int i = n.begin; i < n.end; ++i) {
        const Vec3 d = (*pts_)[ids_[i]] - q;
        const double d2 = dot(d, d);
        if (d2 <= r2) f(ids_[i], std::sqrt(d2));
      }
      return;
    }
    radiusNode(n.left, q, r, r2, f);
    radiusNode(n.right, q, r, r2, f);
  }
  template <class A> void nearestNode(int ni, const Vec3& q, A& accept, int& best, double& bestD2) const {
    const Node& n = nodes_[ni];
    if (boxDist2(n, q) >= bestD2) return;
    if (n.left < 0) {
      for (int i = n.begin; i < n.end; ++i) {
        const Vec3 d = (*pts_)[ids_[i]] - q;
        const double d2 = dot(d, d);
        if (d2 < bestD2 && accept(ids_[i])) {
          bestD2 = d2;
          best = ids_[i];
        }
      }
      return;
    }
    const double dl = boxDist2(nodes_[n.left], q), dr = boxDist2(nodes_[n.right], q);
    if (dl <= dr) {
      nearestNode(n.left, q, accept, best, bestD2);
      nearestNode(n.right, q, accept, best, bestD2);
    } else {
      nearestNode(n.right, q, accept, best, bestD2);
      nearestNode(n.left, q, accept, best, bestD2);
    }
  }
  const std::vector<Vec3>* pts_ = nullptr;
  std::vector<int> ids_;
  std::vector<Node> nodes_;
};

// ---- point in a patch's parameter-space domain (even-odd over its loops), bucketed by v ----
class DomainTest {
public:
  void build(std::vector<std::array<Point2, 2>> segs) {
    segs_ = std::move(segs);
    if (segs_.empty()) return;
    v0_ = v1_ = segs_[0][0].y;
    for (const auto& s : segs_)
      for (const auto& p : s) {
        v0_ = std::min(v0_, p.y);
        v1_ = std::max(v1_, p.y);
      }
    rows_ = std::max(1, int(std::sqrt(double(segs_.size()))));
    bucket_.assign(rows_, {});
    for (int i = 0; i < int(segs_.size()); ++i) {
      const double a = std::min(segs_[i][0].y, segs_[i][1].y), b = std::max(segs_[i][0].y, segs_[i][1].y);
      for (int r = row(a); r <= row(b); ++r) bucket_[r].push_back(i);
    }
  }
  bool inside(const Point2& q) const {
    if (segs_.empty() || q.y < v0_ || q.y > v1_) return false;
    bool in = false;
    for (int i : bucket_[row(q.y)]) {
      const Point2& a = segs_[i][0];
      const Point2& b = segs_[i][1];
      if ((a.y > q.y) != (b.y > q.y)) {
        const double x = a.x + (q.y - a.y) * (b.x - a.x) / (b.y - a.y);
        if (x > q.x) in = !in;
      }
    }
    return in;
  }

private:
  int row(double v) const {
    if (v1_ <= v0_) return 0;
    return std::clamp(int((v - v0_) / (v1_ - v0_) * rows_), 0, rows_ - 1);
  }
  std::vector<std::array<Point2, 2>> segs_;
  std::vector<std::vector<int>> bucket_;
  double v0_ = 0, v1_ = 0;
  int rows_ = 1;
};

struct System {
  const CadModel& M;
  const PsysParams& prm;
  double sigmaMin = 0, sigmaMax = 0;
  std::vector<CadParticle> P;
  std::vector<char> alive;
  std::vector<double> sigmaKappa; // cached σ_κ per particle
  std::vector<double> lambda;     // per-particle step
  std::vector<double> gapSize;    // cached σ_τ / s_τ (-1: not yet searched)
  std::vector<double> cornerBall; // per corner, after phase 1 (0 before)
  // Topology.
  std::vector<std::array<int, 2>> curveCorners;
  std::vector<std::set<int>> patchCurves, patchCorners, patchAdjacent;
  std::vector<std::set<int>> cornerCurves;
  std::vector<DomainTest> domain;
  std::mt19937_64 rng;

  System(const CadModel& m, const PsysParams& p) : M(m), prm(p), rng(p.seed) {}

  static double unitEnergy(double x) { // E(r = x σ) / σ for x in (0, 1)
    const double a = x * kPi / 2;
    return 1.0 / std::tan(a) + a - kPi / 2;
  }
  double idealEnergy(int dim, double sigma) const { return sigma * (dim == 1 ? 2 : 6) * unitEnergy(kBeta); }

  // Curvature → σ_κ.
  double sigmaFromCurvature(double kappa) const {
    if (!(kappa > 0)) return sigmaMax;
    return std::clamp(1.0 / (prm.sKappa * kappa), sigmaMin, sigmaMax);
  }
  double curveKappa(int c, double t) const {
    double k = M.curveCurvature(c, t);
    for (int p : M.curves()[c].patches) {
      const Point2 uv = M.curveOnPatch(c, p, 0, t);
      k = std::max(k, M.patchMaxCurvature(p, uv.x, uv.y));
    }
    return k;
  }
  double computeSigmaKappa(const CadParticle& q) const {
    if (q.dim == 1) return sigmaFromCurvature(curveKappa(q.cell, q.t));
    if (q.dim == 2) return sigmaFromCurvature(M.patchMaxCurvature(q.cell, q.uv.x, q.uv.y));
    double s = sigmaMax; // a corner: its curves' at their ends
    for (int c : cornerCurves[q.cell]) {
      const CadCurve& cv = M.curves()[c];
      if (cv.corner0 == q.cell) s = std::min(s, sigmaFromCurvature(curveKappa(c, cv.t0)));
      if (cv.corner1 == q.cell) s = std::min(s, sigmaFromCurvature(curveKappa(c, cv.t1)));
    }
    return s;
  }

  int add(const CadParticle& q) {
    P.push_back(q);
    alive.push_back(1);
    sigmaKappa.push_back(computeSigmaKappa(q));
    lambda.push_back(0.5 * kMaxLambda * q.sigma);
    gapSize.push_back(-1.0);
    return int(P.size()) - 1;
  }

  void buildTopology() {
    const int nc = int(M.curves().size()), np = int(M.patches().size());
    curveCorners.resize(nc);
    cornerCurves.assign(M.corners().size(), {});
    for (int c = 0; c < nc; ++c) {
      curveCorners[c] = {M.curves()[c].corner0, M.curves()[c].corner1};
      cornerCurves[curveCorners[c][0]].insert(c);
      cornerCurves[curveCorners[c][1]].insert(c);
    }
    patchCurves.assign(np, {});
    patchCorners.assign(np, {});
    patchAdjacent.assign(np, {});
    for (int p = 0; p < np; ++p)
      for (const auto& loop : M.patches()[p].loops)
        for (const auto& u : loop) {
          if (u.curve >= 0) {
            patchCurves[p].insert(u.curve);
            patchCorners[p].insert(curveCorners[u.curve][0]);
            patchCorners[p].insert(curveCorners[u.curve][1]);
          } else {
            patchCorners[p].insert(u.corner);
          }
        }
    for (int p = 0; p < np; ++p)
      for (int q = 0; q < np; ++q) {
        if (p == q) continue;
        for (int k : patchCorners[p])
          if (patchCorners[q].count(k)) {
            patchAdjacent[p].insert(q);
            break;
          }
      }
  }

  // Does particle j (any cell) take part in particle i's energy? i moves on its own cell; j must
  // be on the same cell or on its boundary.
  bool interacts(const CadParticle& a, const CadParticle& b) const {
    if (a.dim == 1) {
      if (b.dim == 1) return b.cell == a.cell;
      if (b.dim == 0) return b.cell == curveCorners[a.cell][0] || b.cell == curveCorners[a.cell][1];
      return false;
    }
    if (a.dim == 2) {
      if (b.dim == 2) return b.cell == a.cell;
      if (b.dim == 1) return patchCurves[a.cell].count(b.cell) > 0;
      return patchCorners[a.cell].count(b.cell) > 0;
    }
    return false;
  }
  // Corners of a cell (for the corner-ball and adjacency rules).
  void cellCorners(const CadParticle& q, std::array<int, 2>& out, int& n) const {
    n = 0;
    if (q.dim == 0) out[n++] = q.cell;
    else if (q.dim == 1) {
      out[n++] = curveCorners[q.cell][0];
      if (curveCorners[q.cell][1] != out[0]) out[n++] = curveCorners[q.cell][1];
    }
  }
  // Does b count for a's gap size σ_τ (b on a cell that is not adjacent to a's)?
  bool gapPartner(int ia, int ib) const {
    const CadParticle& a = P[ia];
    const CadParticle& b = P[ib];
    if (a.dim == 1) {
      if (b.dim == 2) return false;
      if (b.dim == 1 && b.cell == a.cell) return false;
      std::array<int, 2> ca{}, cb{};
      int na = 0, nb = 0;
      cellCorners(a, ca, na);
      cellCorners(b, cb, nb);
      for (int i = 0; i < na; ++i)
        for (int j = 0; j < nb; ++j)
          if (ca[i] == cb[j]) {
            const int k = ca[i];
            if (b.dim == 0) return false; // the curve's own end
            const Vec3& xk = M.corners()[k];
            if (norm(a.x - xk) < cornerBall[k] || norm(b.x - xk) < cornerBall[k]) return false;
          }
      return true;
    }
    if (a.dim == 2) {
      const int p = a.cell;
      if (b.dim == 2) return b.cell != p && !patchAdjacent[p].count(b.cell);
      if (b.dim == 1)
        return !patchCurves[p].count(b.cell) && !patchCorners[p].count(curveCorners[b.cell][0]) &&
               !patchCorners[p].count(curveCorners[b.cell][1]);
      return !patchCorners[p].count(b.cell);
    }
    return false;
  }

  // Position from parameters.
  void place(CadParticle& q) const {
    if (q.dim == 1) q.x = M.curvePoint(q.cell, q.t);
    else if (q.dim == 2) q.x = M.patchPoint(q.cell, q.uv.x, q.uv.y).p;
  }
  bool validParameter(const CadParticle& q) const {
    if (q.dim == 1) {
      const CadCurve& c = M.curves()[q.cell];
      const double eps = 1e-9 * (c.t1 - c.t0);
      return q.t > c.t0 + eps && q.t < c.t1 - eps;
    }
    if (q.dim == 2) return domain[q.cell].inside(q.uv);
    return true;
  }

  void buildDomains() {
    domain.assign(M.patches().size(), {});
    for (size_t p = 0; p < M.patches().size(); ++p) {
      std::vector<std::array<Point2, 2>> segs;
      for (const auto& loop : M.patches()[p].loops)
        for (const auto& u : loop) {
          const int n = 64;
          Point2 prev = M.useOnPatch(int(p), u, u.reversed ? u.t1 : u.t0);
          for (int i = 1; i <= n; ++i) {
            const double s = double(i) / n;
            const double t = u.reversed ? u.t1 + s * (u.t0 - u.t1) : u.t0 + s * (u.t1 - u.t0);
            const Point2 q = M.useOnPatch(int(p), u, t);
            segs.push_back({prev, q});
            prev = q;
          }
        }
      domain[p].build(std::move(segs));
    }
  }

  // ---- one relaxation phase over the particles of dimension `dim` ----
  PsysPhaseStats relax(int dim, bool useTau, const std::string& name) {
    PsysPhaseStats st;
    st.name = name;
    const auto t0 = std::chrono::steady_clock::now();
    const int maxIt = prm.maxIterations;
    const int stopSplitsAt = int(0.7 * maxIt);
    int lastChange = 0;
    std::uniform_real_distribution<double> unif(0.0, 1.0);
    for (int it = 0; it < maxIt; ++it) {
      if (Progress* pr = currentProgress()) pr->checkCancel();
      // The tree holds every particle of dimension <= dim.
      std::vector<int> ids, movers;
      std::vector<Vec3> pos(P.size());
      for (size_t i = 0; i < P.size(); ++i) {
        pos[i] = P[i].x;
        if (!alive[i] || P[i].dim > dim) continue;
        ids.push_back(int(i));
        if (P[i].dim == dim) movers.push_back(int(i));
      }
      KdTree tree;
      tree.build(pos, ids);
      const int nm = int(movers.size());
      std::vector<double> newSigma(nm), energy(nm), moved(nm, 0.0);
      std::vector<CadParticle> next(nm);
      const double L = prm.lipschitz;
#pragma omp parallel for schedule(dynamic, 64)
      for (int k = 0; k < nm; ++k) {
        const int i = movers[k];
        const CadParticle& q = P[i];
        // Sizing field (Algorithm 2), from the previous iteration's σ.
        double sL = sigmaMax;
        const double reach = std::min(sigmaMax, q.sigma / std::max(1e-3, 1.0 - L)) * 1.0001;
        std::vector<std::pair<int, double>> nb;
        tree.radius(q.x, reach, [&](int j, double r) {
          if (j == i) return;
          sL = std::min(sL, L * r + P[j].sigma);
          if (interacts(q, P[j])) nb.push_back({j, r});
        });
        double s = std::min({sigmaMax, sigmaKappa[i], sL});
        if (useTau) {
          // The gap size is searched every kChangeEvery iterations (the search costs more than
          // the rest of the step: most particles nearby are on adjacent cells).
          if (it % kChangeEvery == 0 || gapSize[i] < 0) {
            double d = 0;
            const int j = tree.nearest(q.x, s / prm.sTau, [&](int j2) { return j2 != i && gapPartner(i, j2); }, &d);
            gapSize[i] = j >= 0 ? d : std::numeric_limits<double>::infinity();
          }
          s = std::min(s, prm.sTau * gapSize[i]);
        }
        s = std::max(sigmaMin, s);
        newSigma[k] = s;
        // Energy and force in 3-D (3.1, 3.2, 3.7).
        auto energyAt = [&](const Vec3& x, Vec3* force) {
          double e = 0;
          if (force) *force = {0, 0, 0};
          for (const auto& [j, r0] : nb) {
            const Vec3 d = x - P[j].x;
            const double r = norm(d);
            const double sij = std::max(q.sigma, P[j].sigma);
            if (r >= sij) continue;
            if (r < 1e-12 * sij) {
              e += 1e12 * sij;
              continue;
            }
            e += psysEnergy(r, sij);
            if (force) *force = *force + (-psysEnergyDerivative(r, sij) / r) * d;
          }
          return e;
        };
        Vec3 f;
        const double e0 = energyAt(q.x, &f);
        energy[k] = e0;
        next[k] = q;
        next[k].sigma = s;
        if (norm(f) == 0) continue;
        // Move in the parameters (3.8, 3.9) with a step λ cut tenfold when E does not fall.
        double lam = lambda[i];
        for (int attempt = 0; attempt < 4; ++attempt) {
          CadParticle c = q;
          Vec3 step = lam * f;
          const double maxStep = 0.1 * q.sigma;
          if (norm(step) > maxStep) step = (maxStep / norm(step)) * step;
          if (q.dim == 1) {
            const Vec3 d = M.curveDerivative(q.cell, q.t);
            const double dd = dot(d, d);
            if (dd <= 0) break;
            c.t = q.t + dot(step, d) / dd;
          } else {
            const PatchPoint pp = M.patchPoint(q.cell, q.uv.x, q.uv.y);
            const double a = dot(pp.du, pp.du), b = dot(pp.du, pp.dv), cc = dot(pp.dv, pp.dv);
            const double det = a * cc - b * b;
            if (!(det > 1e-18 * (a + cc) * (a + cc))) break;
            const double gu = dot(pp.du, step), gv = dot(pp.dv, step);
            c.uv = {q.uv.x + (cc * gu - b * gv) / det, q.uv.y + (a * gv - b * gu) / det};
          }
          if (validParameter(c)) {
            place(c);
            if (energyAt(c.x, nullptr) < e0) {
              c.sigma = s;
              moved[k] = norm(c.x - q.x) / q.sigma;
              next[k] = c;
              lam = std::min(lam * 1.2, kMaxLambda * q.sigma);
              break;
            }
          }
          lam *= 0.1;
        }
        lambda[i] = std::max(lam, 1e-6 * q.sigma);
      }
      // Commit.
      double total = 0;
      for (int k = 0; k < nm; ++k) {
        const int i = movers[k];
        const bool movedNow = moved[k] > 0;
        P[i] = next[k];
        if (movedNow) sigmaKappa[i] = computeSigmaKappa(P[i]);
        total += energy[k];
      }
      // The corners' σ follows the Lipschitz bound of the curve particles around them.
      // One pass over the curve particles, each bounding its curve's two corners.
      if (dim == 1) {
        std::vector<double> cornerSigma(sigmaKappa.begin(), sigmaKappa.begin() + std::ptrdiff_t(M.corners().size()));
        for (int k = 0; k < nm; ++k) {
          const CadParticle& q = P[movers[k]];
          for (int c : curveCorners[q.cell])
            cornerSigma[size_t(c)] = std::min(cornerSigma[size_t(c)], prm.lipschitz * norm(q.x - P[c].x) + q.sigma);
        }
        for (size_t c = 0; c < cornerSigma.size(); ++c) P[c].sigma = std::max(sigmaMin, cornerSigma[c]);
      }
      if (it == 0) st.firstEnergy = total;
      st.lastEnergy = total;
      st.iterations = it + 1;
      // Splits and deletes (3.3–3.5), serial; a changed particle's neighbours wait a turn.
      int changes = 0;
      if (it < stopSplitsAt && it % kChangeEvery == kChangeEvery - 1) {
        std::vector<char> locked(P.size(), 0);
        std::vector<int> onCurve(M.curves().size(), 0); // living particles per curve
        if (dim == 1)
          for (int i : movers) ++onCurve[size_t(P[i].cell)];
        for (int k = 0; k < nm; ++k) {
          const int i = movers[k];
          if (locked[i] || !alive[i]) continue;
          const double eStar = energy[k] * (1.0 + kEpsilon * unif(rng));
          const double ideal = idealEnergy(dim, P[i].sigma);
          const bool split = eStar < 0.35 * ideal, del = eStar > 1.75 * ideal;
          if (!split && !del) continue;
          if (del && dim == 1 && onCurve[size_t(P[i].cell)] <= minOnCurve(P[i].cell)) continue;
          bool changed = false;
          if (split) {
            changed = splitParticle(i, unif, tree);
            if (changed && dim == 1) ++onCurve[size_t(P[i].cell)];
          } else {
            alive[i] = 0;
            ++st.deletes;
            changed = true;
            if (dim == 1) --onCurve[size_t(P[i].cell)];
          }
          if (!changed) continue;
          if (split) ++st.splits;
          ++changes;
          tree.radius(P[i].x, P[i].sigma, [&](int j, double) { locked[j] = 1; });
        }
      }
      if (changes > std::max<int64_t>(1, nm / 500)) lastChange = it;
      // Converged: 99 % of the particles moved less than 1 % of their σ, and two rounds of
      // splits and deletes changed nothing (or they have stopped).
      std::vector<double> mv(moved);
      const size_t q99 = mv.empty() ? 0 : std::min(mv.size() - 1, size_t(0.99 * double(mv.size())));
      if (!mv.empty()) std::nth_element(mv.begin(), mv.begin() + q99, mv.end());
      const double move99 = mv.empty() ? 0.0 : mv[q99];
      if (move99 < 0.01 && (it - lastChange >= 2 * kChangeEvery || it >= stopSplitsAt)) {
        st.converged = true;
        break;
      }
    }
    for (size_t i = 0; i < P.size(); ++i)
      if (alive[i] && P[i].dim == dim) ++st.particles;
    st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return st;
  }

  // A curve keeps at least one particle (two on a closed curve) so that no two curves between
  // the same corners give the same edge.
  int minOnCurve(int c) const { return curveCorners[size_t(c)][0] == curveCorners[size_t(c)][1] ? 2 : 1; }

  // A split puts the new particle at the ideal distance β σ from its parent: on a curve into the
  // larger of the two gaps to its neighbours along the curve, on a patch in a random direction
  // of the tangent plane, whichever attempt lands inside the cell and farthest from the others.
  template <class U> bool splitParticle(int i, U& unif, const KdTree& tree) {
    const CadParticle& q = P[i];
    const double len = kBeta * q.sigma;
    CadParticle best;
    double bestClear = -1;
    for (int attempt = 0; attempt < 6; ++attempt) {
      CadParticle c = q;
      if (c.dim == 1) {
        const Vec3 d = M.curveDerivative(c.cell, q.t);
        const double dn = norm(d);
        if (dn <= 0) return false;
        c.t = q.t + (attempt % 2 == 0 ? -1 : 1) * len / dn;
        if (attempt >= 2) break;
      } else {
        const PatchPoint pp = M.patchPoint(c.cell, q.uv.x, q.uv.y);
        const double ang = 2 * kPi * unif(rng);
        const double nu = norm(pp.du), nv = norm(pp.dv);
        if (nu <= 0 || nv <= 0) return false;
        c.uv = {q.uv.x + len * std::cos(ang) / nu, q.uv.y + len * std::sin(ang) / nv};
      }
      if (!validParameter(c)) continue;
      place(c);
      double clear = 0;
      const int j = tree.nearest(c.x, q.sigma, [&](int k) { return k != i && interacts(q, P[k]); }, &clear);
      if (j < 0) clear = q.sigma;
      if (clear > bestClear) {
        bestClear = clear;
        best = c;
      }
    }
    if (bestClear < 0) return false;
    add(best);
    return true;
  }

  // ---- seeding ----
  void seedCurves() {
    for (size_t c = 0; c < M.curves().size(); ++c) {
      const CadCurve& cv = M.curves()[c];
      // σ along the curve from curvature, sampled; particles at equal steps of ∫ ds / (β σ).
      const int n = 256;
      std::vector<double> ts(n + 1), cum(n + 1, 0.0);
      for (int i = 0; i <= n; ++i) ts[i] = cv.t0 + (cv.t1 - cv.t0) * i / n;
      Vec3 prev = M.curvePoint(int(c), ts[0]);
      for (int i = 1; i <= n; ++i) {
        const Vec3 x = M.curvePoint(int(c), ts[i]);
        const double sig = sigmaFromCurvature(curveKappa(int(c), 0.5 * (ts[i] + ts[i - 1])));
        cum[i] = cum[i - 1] + norm(x - prev) / (kBeta * sig);
        prev = x;
      }
      const bool closed = cv.corner0 == cv.corner1;
      const int count = std::max(closed ? 2 : 1, int(std::lround(cum[n])) - 1);
      for (int k = 1; k <= count; ++k) {
        const double target = cum[n] * k / (count + 1);
        const int j = int(std::lower_bound(cum.begin(), cum.end(), target) - cum.begin());
        const int a = std::max(1, std::min(j, n));
        const double w = cum[a] > cum[a - 1] ? (target - cum[a - 1]) / (cum[a] - cum[a - 1]) : 0.5;
        CadParticle q;
        q.dim = 1;
        q.cell = int(c);
        q.t = ts[a - 1] + w * (ts[a] - ts[a - 1]);
        place(q);
        q.sigma = sigmaFromCurvature(curveKappa(int(c), q.t));
        add(q);
      }
    }
  }

  void seedPatches() {
    // Boundary particles of every patch in a tree, for the Lipschitz bound of the seeds' σ.
    std::vector<int> ids;
    std::vector<Vec3> pos(P.size());
    for (size_t i = 0; i < P.size(); ++i) {
      pos[i] = P[i].x;
      if (alive[i] && P[i].dim <= 1) ids.push_back(int(i));
    }
    KdTree tree;
    tree.build(pos, ids);
    std::uniform_real_distribution<double> unif(0.0, 1.0);
    for (size_t p = 0; p < M.patches().size(); ++p) {
      const CadPatch& pa = M.patches()[p];
      auto sigmaAt = [&](const Point2& uv, const Vec3& x) {
        double s = sigmaFromCurvature(M.patchMaxCurvature(int(p), uv.x, uv.y));
        tree.radius(x, sigmaMax, [&](int j, double r) { s = std::min(s, prm.lipschitz * r + P[j].sigma); });
        return std::max(sigmaMin, s);
      };
      // Expected count ∫ dA / (area per particle), by Monte Carlo over the parameter box.
      const int samples = 4000;
      const double boxArea = (pa.u1 - pa.u0) * (pa.v1 - pa.v0);
      double sum = 0, dmax = 0;
      for (int k = 0; k < samples; ++k) {
        const Point2 uv{pa.u0 + unif(rng) * (pa.u1 - pa.u0), pa.v0 + unif(rng) * (pa.v1 - pa.v0)};
        if (!domain[p].inside(uv)) continue;
        const PatchPoint pp = M.patchPoint(int(p), uv.x, uv.y);
        const double s = sigmaAt(uv, pp.p);
        const double d = norm(cross(pp.du, pp.dv)) / (std::sqrt(3.0) / 2 * kBeta * kBeta * s * s);
        sum += d;
        dmax = std::max(dmax, d);
      }
      const int64_t want = std::llround(sum * boxArea / samples);
      int64_t placed = 0;
      for (int64_t attempt = 0; placed < want && attempt < 200 * (want + 10); ++attempt) {
        const Point2 uv{pa.u0 + unif(rng) * (pa.u1 - pa.u0), pa.v0 + unif(rng) * (pa.v1 - pa.v0)};
        if (!domain[p].inside(uv)) continue;
        const PatchPoint pp = M.patchPoint(int(p), uv.x, uv.y);
        const double s = sigmaAt(uv, pp.p);
        const double d = norm(cross(pp.du, pp.dv)) / (std::sqrt(3.0) / 2 * kBeta * kBeta * s * s);
        if (unif(rng) * dmax > d) continue;
        // Not on top of a boundary particle.
        double dmin = 0;
        if (tree.nearest(pp.p, 0.5 * kBeta * s, [](int) { return true; }, &dmin) >= 0) continue;
        CadParticle q;
        q.dim = 2;
        q.cell = int(p);
        q.uv = uv;
        q.x = pp.p;
        q.sigma = s;
        add(q);
        ++placed;
      }
    }
  }
};

} // namespace

double psysEnergy(double r, double sigma) {
  if (r >= sigma) return 0.0;
  const double a = r / sigma * kPi / 2;
  return sigma * (1.0 / std::tan(a) + a - kPi / 2);
}

double psysEnergyDerivative(double r, double sigma) {
  if (r >= sigma) return 0.0;
  const double s = std::sin(r / sigma * kPi / 2);
  return kPi / 2 * (1.0 - 1.0 / (s * s));
}

CadSample sampleCadModel(const CadModel& model, const PsysParams& prm, PsysStats* stats) {
  auto bad = [](const std::string& what) { throw InputError(what); };
  if (!(prm.sKappa > 0)) bad("s_kappa must be > 0 (the seed's default is 2)");
  if (!(prm.sTau > 0 && prm.sTau <= 1)) bad("s_tau must be in (0, 1] (the seed's default is 0.5)");
  if (!(prm.lipschitz >= 0 && prm.lipschitz < 1)) bad("lipschitz must be in [0, 1) (the seed's default is 0.3)");
  if (prm.maxIterations < 1) bad("particle iterations must be >= 1");
  const auto box = model.bounds();
  const double diag = norm(box[1] - box[0]);
  System S(model, prm);
  S.sigmaMin = prm.minSize > 0 ? prm.minSize : diag / 1000;
  S.sigmaMax = prm.maxSize > 0 ? prm.maxSize : diag / 10;
  if (S.sigmaMin > S.sigmaMax)
    bad("min_size (" + std::to_string(S.sigmaMin) + " mm) is larger than max_size (" +
        std::to_string(S.sigmaMax) + " mm)");
  S.buildTopology();
  S.buildDomains();
  // Corners: fixed particles.
  for (size_t c = 0; c < model.corners().size(); ++c) {
    CadParticle q;
    q.dim = 0;
    q.cell = int(c);
    q.x = model.corners()[c];
    q.sigma = S.sigmaMax;
    S.add(q);
    q.sigma = S.sigmaKappa.back();
    S.P.back().sigma = q.sigma;
  }
  S.cornerBall.assign(model.corners().size(), 0.0);
  PsysStats st;
  st.minSize = S.sigmaMin;
  st.maxSize = S.sigmaMax;
  S.seedCurves();
  st.phases.push_back(S.relax(1, false, "curves (curvature, Lipschitz)"));
  for (size_t c = 0; c < model.corners().size(); ++c) S.cornerBall[c] = S.P[c].sigma;
  st.phases.push_back(S.relax(1, true, "curves (gap size)"));
  S.seedPatches();
  st.phases.push_back(S.relax(2, true, "patches"));

  // Compact: corners first (as they are), then the living others.
  CadSample out;
  out.onCurve.assign(model.curves().size(), {});
  out.onPatch.assign(model.patches().size(), {});
  st.sigmaMin = std::numeric_limits<double>::infinity();
  st.sigmaMax = 0;
  for (size_t i = 0; i < S.P.size(); ++i) {
    if (!S.alive[i]) continue;
    const CadParticle& q = S.P[i];
    const int id = int(out.particles.size());
    out.particles.push_back(q);
    st.sigmaMin = std::min(st.sigmaMin, q.sigma);
    st.sigmaMax = std::max(st.sigmaMax, q.sigma);
    if (q.dim == 1) out.onCurve[q.cell].push_back(id);
    if (q.dim == 2) out.onPatch[q.cell].push_back(id);
  }
  for (auto& list : out.onCurve)
    std::sort(list.begin(), list.end(), [&](int a, int b) { return out.particles[a].t < out.particles[b].t; });
  if (stats) *stats = st;
  return out;
}

} // namespace tetflow
