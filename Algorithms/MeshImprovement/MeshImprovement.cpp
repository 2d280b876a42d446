// Mesh improvement: the driver (see MeshImprovement.h).
#include "Algorithms/MeshImprovement/MeshImprovement.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/MeshImprovement/Improver.h"
#include "Algorithms/Quality/TetQuality.h"

namespace tetflow {

namespace {
constexpr double kDeg = M_PI / 180.0;
constexpr int kLastResortRounds = 4; // rounds of the last resort after the passes
} // namespace

namespace {
// The score of a tet whose dihedral cosines lie in [lo, hi].
double scoreOfCosines(double lo, double hi, double minAngle, double maxAngle) {
  const double smallest = std::acos(std::clamp(hi, -1.0, 1.0)) / kDeg;
  const double largest = std::acos(std::clamp(lo, -1.0, 1.0)) / kDeg;
  return std::min(smallest, (180.0 - largest) * minAngle / (180.0 - maxAngle));
}
} // namespace

double improveScore(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, double minAngle, double maxAngle) {
  double lo, hi;
  if (!dihedralCosineRange(a, b, c, d, lo, hi)) return -1.0;
  return scoreOfCosines(lo, hi, minAngle, maxAngle);
}

double ImproveStats::maxVolumeChangePercent() const {
  double w = 0.0;
  for (const auto& m : materials)
    if (m.volumeBefore > 0) w = std::max(w, 100.0 * std::abs(m.volumeAfter - m.volumeBefore) / m.volumeBefore);
  return w;
}

namespace improve_detail {

Improver::Improver(TetMesh& m, const ImproveParams& p, Progress& progress) : m_(m), p_(p), progress_(progress) {
  goal_ = p.min_angle + p.goal_margin;
}

// ---- stars ----

void Improver::starOf(int32_t v, std::vector<int32_t>& out) const {
  auto it = changedStars_.find(v);
  if (it != changedStars_.end()) {
    out = it->second;
    return;
  }
  out.clear();
  if (size_t(v) < nv0_)
    out.assign(csr_.tets.begin() + csr_.offset[size_t(v)], csr_.tets.begin() + csr_.offset[size_t(v) + 1]);
}

std::vector<int32_t>& Improver::mutableStar(int32_t v) {
  auto it = changedStars_.find(v);
  if (it != changedStars_.end()) return it->second;
  std::vector<int32_t> s;
  if (size_t(v) < nv0_) starOf(v, s);
  return changedStars_.emplace(v, std::move(s)).first->second;
}

void Improver::killTet(int32_t t) {
  st_.tetsChanged = true;
  alive_[size_t(t)] = 0;
  for (int32_t v : m_.tets[size_t(t)]) {
    auto& s = mutableStar(v);
    s.erase(std::find(s.begin(), s.end(), t));
  }
}

int32_t Improver::addTet(const Tet& q, int32_t material, int32_t origin) {
  st_.tetsChanged = true;
  const int32_t t = int32_t(m_.tets.size());
  m_.tets.push_back(q);
  m_.materials.push_back(material);
  alive_.push_back(1);
  origin_.push_back(origin);
  for (int32_t v : q) mutableStar(v).push_back(t);
  return t;
}

int32_t Improver::oppositeTet(int32_t t, int face) const {
  const Tet& q = m_.tets[size_t(t)];
  const int32_t x = q[size_t(kTetFaceVertices[face][0])], y = q[size_t(kTetFaceVertices[face][1])],
                z = q[size_t(kTetFaceVertices[face][2])];
  std::vector<int32_t> s;
  starOf(x, s);
  for (int32_t u : s) {
    if (u == t) continue;
    const Tet& o = m_.tets[size_t(u)];
    if (std::find(o.begin(), o.end(), y) != o.end() && std::find(o.begin(), o.end(), z) != o.end()) return u;
  }
  return -1;
}

LocalStar Improver::localStar(const std::vector<int32_t>& ts) const {
  LocalStar s;
  for (int32_t t : ts) {
    s.tets.push_back(m_.tets[size_t(t)]);
    s.mats.push_back(m_.materials[size_t(t)]);
  }
  return s;
}

// ---- scores ----

double Improver::score(const Tet& q) const {
  return improveScore(m_.points[q[0]], m_.points[q[1]], m_.points[q[2]], m_.points[q[3]], p_.min_angle, p_.max_angle);
}

double Improver::scoreWith(const Tet& q, int32_t v, const Vec3& at) const {
  Vec3 p[4];
  for (int k = 0; k < 4; ++k) p[k] = q[k] == v ? at : m_.points[q[k]];
  return improveScore(p[0], p[1], p[2], p[3], p_.min_angle, p_.max_angle);
}

double WorstScore::value() const {
  if (invalid_) return -1.0;
  if (hi_ < -1.5) return 1e9;
  return scoreOfCosines(lo_, hi_, minAngle_, maxAngle_);
}

bool Improver::addWith(WorstScore& w, const Tet& q, int32_t v, const Vec3& at) const {
  Vec3 p[4];
  for (int k = 0; k < 4; ++k) p[k] = q[k] == v ? at : m_.points[q[k]];
  return w.add(p[0], p[1], p[2], p[3]);
}

double Improver::worstOf(const std::vector<int32_t>& ts) const {
  WorstScore w(p_.min_angle, p_.max_angle);
  for (int32_t t : ts) {
    const Tet& q = m_.tets[size_t(t)];
    w.add(m_.points[q[0]], m_.points[q[1]], m_.points[q[2]], m_.points[q[3]]);
  }
  return w.value();
}

size_t Improver::labelIndex(int32_t label) const {
  return size_t(std::lower_bound(labels_.begin(), labels_.end(), label) - labels_.begin());
}

// ---- driver ----


void Improver::scanAll(double& mn, double& mx, int64_t& below, int64_t& above, std::vector<int32_t>* bad) const {
  const int64_t nt = int64_t(m_.tets.size());
  std::vector<uint8_t> isBad(bad ? size_t(nt) : 0);
  // A tet is bad when its score is below the goal: smallest angle below goal_, or largest above
  // 180 - goal_ (180 - max_angle) / min_angle.
  const double cosMin = std::cos(p_.min_angle * kDeg), cosMax = std::cos(p_.max_angle * kDeg);
  const double cosGoalLo = std::cos(goal_ * kDeg);
  const double cosGoalHi = std::cos((180.0 - goal_ * (180.0 - p_.max_angle) / p_.min_angle) * kDeg);
  double hiCos = -1.0, loCos = 1.0;
  int64_t b = 0, a = 0;
  LoopCancel cancel(progress_);
#pragma omp parallel for schedule(static) reduction(min : loCos) reduction(max : hiCos) reduction(+ : b, a)
  for (int64_t t = 0; t < nt; ++t) {
    if (cancel.skip(t) || !alive_[size_t(t)]) continue;
    const Tet& q = m_.tets[size_t(t)];
    double lo = -1.0, hi = 1.0; // flat or inverted: 180 and 0 degrees
    dihedralCosineRange(m_.points[q[0]], m_.points[q[1]], m_.points[q[2]], m_.points[q[3]], lo, hi);
    loCos = std::min(loCos, lo);
    hiCos = std::max(hiCos, hi);
    b += hi > cosMin;
    a += lo < cosMax;
    if (bad && (hi > cosGoalLo || lo < cosGoalHi)) isBad[size_t(t)] = 1;
  }
  cancel.rethrow();
  mn = std::acos(std::clamp(hiCos, -1.0, 1.0)) / kDeg;
  mx = std::acos(std::clamp(loCos, -1.0, 1.0)) / kDeg;
  below = b;
  above = a;
  if (bad)
    for (int64_t t = 0; t < nt; ++t)
      if (isBad[size_t(t)]) bad->push_back(int32_t(t));
}

std::vector<double> Improver::labelVolumes() const {
  // Fixed chunks summed in order: the same sums (to the last bit) for any number of threads, so
  // the volume budgets, and with them every decision, do not depend on the thread count.
  constexpr int64_t kChunk = 1 << 16;
  const int64_t nt = int64_t(m_.tets.size()), chunks = (nt + kChunk - 1) / kChunk;
  const size_t nl = labels_.size();
  std::vector<double> part(size_t(chunks) * nl, 0.0);
  LoopCancel cancel(progress_);
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t c = 0; c < chunks; ++c) {
    if (cancel.skip()) continue;
    double* v = part.data() + size_t(c) * nl;
    int32_t lastLabel = 0;
    size_t last = nl;
    for (int64_t t = c * kChunk; t < std::min(nt, (c + 1) * kChunk); ++t) {
      if (!alive_[size_t(t)]) continue;
      const int32_t L = m_.materials[size_t(t)];
      if (last == nl || L != lastLabel) {
        lastLabel = L;
        last = labelIndex(L);
      }
      v[last] += m_.tetVolume(size_t(t));
    }
  }
  cancel.rethrow();
  std::vector<double> v(nl, 0.0);
  for (int64_t c = 0; c < chunks; ++c)
    for (size_t l = 0; l < nl; ++l) v[l] += part[size_t(c) * nl + l];
  return v;
}

bool Improver::improveTet(int32_t t, std::vector<int32_t>& touched) {
  bool changed = false;
  if (p_.smooth) {
    const Tet q = m_.tets[size_t(t)];
    for (int32_t v : q) {
      changed = smoothVertex(v, touched) || changed;
      if (score(m_.tets[size_t(t)]) >= goal_) return true;
    }
  }
  if (p_.peel && !p_.fixSurfaces && peelCap(t, touched)) return true;
  if (p_.flip) {
    const Tet q = m_.tets[size_t(t)];
    for (const auto& [i, j] : kTetEdges)
      if (removeEdge(q[size_t(i)], q[size_t(j)], false, touched)) return true;
    for (int f = 0; f < 4; ++f)
      if (flip23(t, f, touched)) return true;
  }
  if (p_.collapse && collapseInto(t, touched)) return true;
  if (p_.insert && splitEdge(t, touched)) return true;
  if (p_.flip && !p_.fixSurfaces) { // moving an interface
    const Tet q = m_.tets[size_t(t)];
    for (const auto& [i, j] : kTetEdges)
      if (removeEdge(q[size_t(i)], q[size_t(j)], true, touched)) return true;
  }
  if (p_.smooth) {
    // Stuck: smooth the vertices around (each raises the worst tet of its own star), which can
    // make room for the next pass to move this tet's own vertices.
    const Tet q = m_.tets[size_t(t)];
    std::vector<int32_t> star, ring;
    for (int32_t v : q) {
      starOf(v, star);
      for (int32_t u : star)
        for (int32_t w : m_.tets[size_t(u)])
          if (std::find(q.begin(), q.end(), w) == q.end()) ring.push_back(w);
    }
    std::sort(ring.begin(), ring.end());
    ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
    for (int32_t w : ring) changed = smoothVertex(w, touched) || changed;
  }
  return changed;
}

void Improver::compact(std::vector<int32_t>* nb) {
  // Dead tets out, unreferenced vertices out (collapsed ones), fields carried along.
  const size_t nt = m_.tets.size(), np = m_.points.size();
  std::vector<int32_t> remap(np, -1);
  size_t w = 0;
  std::vector<int32_t> keptOrigin;
  std::vector<int32_t> newIndex;
  if (nb) newIndex.assign(nt, -1);
  for (size_t t = 0; t < nt; ++t) {
    if (!alive_[t]) continue;
    if (nb) newIndex[t] = int32_t(w);
    m_.tets[w] = m_.tets[t];
    m_.materials[w] = m_.materials[t];
    keptOrigin.push_back(origin_[t]);
    ++w;
  }
  m_.tets.resize(w);
  m_.materials.resize(w);
  for (const auto& q : m_.tets)
    for (int32_t v : q) remap[size_t(v)] = 0;
  // Values of the point fields at the new vertices (the mean of the split edge's ends), then
  // everything renumbered.
  for (auto& [name, f] : m_.pointFields) {
    const size_t c = size_t(f.components);
    f.values.resize(np * c);
    for (size_t i = 0; i < splitEnds_.size(); ++i)
      for (size_t k = 0; k < c; ++k)
        f.values[(nv0_ + i) * c + k] =
            0.5 * (f.values[size_t(splitEnds_[i][0]) * c + k] + f.values[size_t(splitEnds_[i][1]) * c + k]);
  }
  int32_t used = 0;
  for (size_t v = 0; v < np; ++v)
    if (remap[v] == 0) remap[v] = used++;
  std::vector<Vec3> pts(static_cast<size_t>(used));
  for (size_t v = 0; v < np; ++v)
    if (remap[v] >= 0) pts[size_t(remap[v])] = m_.points[v];
  for (auto& [name, f] : m_.pointFields) {
    const size_t c = size_t(f.components);
    std::vector<double> vals(size_t(used) * c);
    for (size_t v = 0; v < np; ++v)
      if (remap[v] >= 0)
        for (size_t k = 0; k < c; ++k) vals[size_t(remap[v]) * c + k] = f.values[v * c + k];
    f.values.swap(vals);
  }
  m_.points.swap(pts);
  for (auto& q : m_.tets)
    for (auto& v : q) v = remap[size_t(v)];
  for (auto& [name, f] : m_.cellFields) {
    const size_t c = size_t(f.components);
    std::vector<double> vals(w * c);
    for (size_t t = 0; t < w; ++t)
      for (size_t k = 0; k < c; ++k) vals[t * c + k] = f.values[size_t(keptOrigin[t]) * c + k];
    f.values.swap(vals);
  }
  if (nb) carryFaceNeighbours(*nb, newIndex);
}

void Improver::carryFaceNeighbours(std::vector<int32_t>& nb, const std::vector<int32_t>& newIndex) const {
  // A kept input tet keeps its vertices in their order, so a face it shares with another kept tet
  // is still theirs. Open: the faces of the tets made here, and the kept tets' faces whose
  // neighbour went or that had none (a new tet may cover them); matched by their vertices. In
  // place: a kept tet's new index is never above its old one.
  struct Open {
    std::array<int32_t, 3> v;
    int32_t tf; // 4 * tet + face, after compact()
    bool operator<(const Open& o) const { return v != o.v ? v < o.v : tf < o.tf; }
  };
  std::vector<Open> open;
  auto add = [&](int32_t u, int f) {
    const Tet& q = m_.tets[size_t(u)];
    std::array<int32_t, 3> v{q[size_t(kTetFaceVertices[f][0])], q[size_t(kTetFaceVertices[f][1])],
                             q[size_t(kTetFaceVertices[f][2])]};
    std::sort(v.begin(), v.end());
    open.push_back({v, 4 * u + f});
  };
  for (size_t t = 0; t < nt0_; ++t) {
    const int32_t u = newIndex[t];
    if (u < 0) continue;
    for (int f = 0; f < 4; ++f) {
      const int32_t o = nb[4 * t + size_t(f)];
      const int32_t to = o >= 0 ? newIndex[size_t(o)] : -1;
      nb[4 * size_t(u) + size_t(f)] = to;
      if (to < 0) add(u, f);
    }
  }
  nb.resize(4 * m_.tets.size());
  for (size_t t = nt0_; t < newIndex.size(); ++t)
    if (newIndex[t] >= 0)
      for (int f = 0; f < 4; ++f) add(newIndex[t], f);
  std::sort(open.begin(), open.end());
  for (size_t i = 0; i < open.size();) {
    size_t j = i + 1;
    while (j < open.size() && open[j].v == open[i].v) ++j;
    for (size_t k = i; k < j; ++k)
      nb[size_t(open[k].tf)] = j - i == 1 ? kNoNeighbour
                               : j - i == 2 ? open[i + (k == i ? 1 : 0)].tf / 4
                                            : kCrowdedFace;
    i = j;
  }
}

ImproveStats Improver::run(std::vector<int32_t>* nb) {
  if (!(p_.min_angle > 0 && p_.min_angle < 60))
    throw InputError("mesh improvement: min_angle must be in (0, 60) degrees");
  if (!(p_.max_angle > 90 && p_.max_angle < 180))
    throw InputError("mesh improvement: max_angle must be in (90, 180) degrees");
  if (!(p_.goal_margin >= 0 && p_.goal_margin <= 20))
    throw InputError("mesh improvement: goal_margin must be in [0, 20] degrees");
  if (!(p_.max_volume_change >= 0 && p_.max_volume_change <= 0.1))
    throw InputError("mesh improvement: max_volume_change must be in [0, 0.1] percent");
  if (p_.passes < 0 || p_.passes > 100) throw InputError("mesh improvement: passes must be in [0, 100]");
  progress_.beginStage("improve");
  nv0_ = m_.points.size();
  nt0_ = m_.tets.size();
  if (nb && nb->size() != 4 * nt0_) {
    std::vector<int32_t>().swap(*nb);
    nb = nullptr;
  }
  if (nb && nb->empty()) nb = nullptr;
  st_.tetsBefore = int64_t(nt0_);
  st_.verticesBefore = int64_t(nv0_);
  alive_.assign(nt0_, 1);
  for (size_t t = 0; t < nt0_; ++t) {
    progress_.checkCancelEvery(int64_t(t));
    const int32_t L = m_.materials[t];
    if ((t == 0 || L != m_.materials[t - 1]) && !std::binary_search(labels_.begin(), labels_.end(), L))
      labels_.insert(std::upper_bound(labels_.begin(), labels_.end(), L), L);
  }
  const std::vector<double> before = labelVolumes();
  budget_.resize(labels_.size());
  for (size_t l = 0; l < labels_.size(); ++l) budget_[l] = std::abs(before[l]) * p_.max_volume_change / 100.0;
  change_.assign(labels_.size(), 0.0);
  std::vector<int32_t> bad;
  scanAll(st_.minBefore, st_.maxBefore, st_.belowMinBefore, st_.aboveMaxBefore, &bad);
  if (!bad.empty() && p_.passes > 0) {
    origin_.resize(nt0_);
    for (size_t t = 0; t < nt0_; ++t) origin_[t] = int32_t(t);
    csr_ = vertexStars(m_);
    progress_.checkCancel();
    std::vector<int32_t> touched;
    for (int pass = 0; pass < p_.passes && !bad.empty(); ++pass) {
      ++st_.passes;
      std::vector<std::pair<double, int32_t>> order;
      for (int32_t t : bad)
        if (alive_[size_t(t)]) order.push_back({score(m_.tets[size_t(t)]), t});
      std::sort(order.begin(), order.end());
      order.erase(std::unique(order.begin(), order.end()), order.end());
      std::vector<int32_t> next;
      bool changed = false;
      for (size_t i = 0; i < order.size(); ++i) {
        progress_.checkCancelEvery(int64_t(i), 8);
        const int32_t t = order[i].second;
        if (!alive_[size_t(t)] || score(m_.tets[size_t(t)]) >= goal_) continue;
        touched.clear();
        if (improveTet(t, touched)) changed = true;
        if (alive_[size_t(t)] && score(m_.tets[size_t(t)]) < goal_) next.push_back(t);
        for (int32_t u : touched)
          if (alive_[size_t(u)] && score(m_.tets[size_t(u)]) < goal_) next.push_back(u);
      }
      bad.swap(next);
      if (!changed) break;
    }
    if (!p_.fixSurfaces && (p_.smooth || p_.peel)) {
      // The last resort, for tets the passes left outside the targets themselves (MeshImprovement.h,
      // "last resort"): their constrained vertices may move freely (within the budget), and a tet
      // on a curved boundary may be peeled off. A peel can put the next tet on the boundary: up to
      // kLastResortRounds rounds, while something changes.
      lastResort_ = true;
      for (int round = 0; round < kLastResortRounds && !bad.empty(); ++round) {
        std::vector<std::pair<double, int32_t>> order;
        for (int32_t t : bad)
          if (alive_[size_t(t)]) {
            const double sc = score(m_.tets[size_t(t)]);
            if (sc < p_.min_angle) order.push_back({sc, t});
          }
        std::sort(order.begin(), order.end());
        order.erase(std::unique(order.begin(), order.end()), order.end());
        std::vector<int32_t> next;
        bool changed = false;
        for (const auto& [sc, t] : order) {
          progress_.checkCancel();
          if (!alive_[size_t(t)] || score(m_.tets[size_t(t)]) >= p_.min_angle) continue;
          touched.clear();
          if (p_.smooth) {
            const Tet q = m_.tets[size_t(t)];
            for (int32_t v : q) {
              const int64_t before = st_.smoothed;
              changed = smoothVertex(v, touched) || changed;
              st_.lastResortMoves += st_.smoothed - before;
              if (score(m_.tets[size_t(t)]) >= goal_) break;
            }
          }
          if (p_.peel && score(m_.tets[size_t(t)]) < p_.min_angle && peelBoundaryTet(t)) changed = true;
          if (alive_[size_t(t)] && score(m_.tets[size_t(t)]) < goal_) next.push_back(t);
          for (int32_t u : touched)
            if (alive_[size_t(u)] && score(m_.tets[size_t(u)]) < goal_) next.push_back(u);
        }
        std::sort(next.begin(), next.end());
        next.erase(std::unique(next.begin(), next.end()), next.end());
        bad.swap(next);
        if (!changed) break;
      }
      lastResort_ = false;
    }
    compact(nb);
    alive_.assign(m_.tets.size(), 1);
  }
  std::vector<int32_t> left;
  std::vector<double> after = before;
  if (st_.passes > 0 || st_.belowMinBefore > 0 || st_.aboveMaxBefore > 0) {
    const double goal = goal_;
    goal_ = p_.min_angle; // the tets that miss the target itself
    scanAll(st_.minAfter, st_.maxAfter, st_.belowMinAfter, st_.aboveMaxAfter, &left);
    goal_ = goal;
    after = labelVolumes();
  } else { // nothing was bad: the mesh is as it came
    st_.minAfter = st_.minBefore;
    st_.maxAfter = st_.maxBefore;
  }
  st_.tetsAfter = int64_t(m_.tets.size());
  st_.verticesAfter = int64_t(m_.points.size());
  for (size_t l = 0; l < labels_.size(); ++l) st_.materials.push_back({labels_[l], before[l], after[l]});
  st_.unfixedCount = int64_t(left.size());
  std::vector<std::pair<double, int32_t>> worst;
  for (int32_t t : left) worst.push_back({score(m_.tets[size_t(t)]), t});
  std::sort(worst.begin(), worst.end());
  for (size_t i = 0; i < worst.size() && i < 20; ++i) {
    const int32_t t = worst[i].second;
    const Tet& q = m_.tets[size_t(t)];
    ImproveTet u;
    u.tet = t;
    u.material = m_.materials[size_t(t)];
    u.centroid = 0.25 * (m_.points[q[0]] + m_.points[q[1]] + m_.points[q[2]] + m_.points[q[3]]);
    u.minDihedral = minDihedral(m_.points[q[0]], m_.points[q[1]], m_.points[q[2]], m_.points[q[3]]);
    u.maxDihedral = maxDihedral(m_.points[q[0]], m_.points[q[1]], m_.points[q[2]], m_.points[q[3]]);
    st_.unfixed.push_back(u);
  }
  progress_.endStage();
  return st_;
}

} // namespace improve_detail

ImproveStats improveMesh(TetMesh& mesh, const ImproveParams& params, Progress& progress,
                         std::vector<int32_t>* faceNeighbours) {
  improve_detail::Improver im(mesh, params, progress);
  return im.run(faceNeighbours);
}

void writeImproveReport(const ImproveStats& s, const ImproveParams& p, Report& rep) {
  rep.set("improve_tets_before", s.tetsBefore);
  rep.set("improve_min_dihedral_before", s.minBefore);
  rep.set("improve_max_dihedral_before", s.maxBefore);
  rep.set("improve_below_min_before", s.belowMinBefore);
  rep.set("improve_above_max_before", s.aboveMaxBefore);
  rep.set("improve_min_dihedral_after", s.minAfter);
  rep.set("improve_max_dihedral_after", s.maxAfter);
  rep.set("improve_below_min_after", s.belowMinAfter);
  rep.set("improve_above_max_after", s.aboveMaxAfter);
  rep.set("improve_smoothed", s.smoothed);
  rep.set("improve_edge_removals", s.edgeRemovals);
  rep.set("improve_interface_flips", s.interfaceFlips);
  rep.set("improve_flips23", s.flips23);
  rep.set("improve_collapses", s.collapses);
  rep.set("improve_caps_removed", s.capsRemoved);
  rep.set("improve_boundary_peels", s.boundaryPeels);
  rep.set("improve_last_resort_moves", s.lastResortMoves);
  rep.set("improve_insertions", s.insertions);
  rep.set("improve_passes", int64_t(s.passes));
  rep.set("improve_max_volume_change_percent", s.maxVolumeChangePercent());
  rep.set("improve_unfixed_tets", s.unfixedCount);
  std::ostringstream where;
  for (size_t i = 0; i < s.unfixed.size() && i < 5; ++i) {
    const auto& u = s.unfixed[i];
    if (i) where << "; ";
    where << "tet " << u.tet << " (material " << u.material << ") at (" << u.centroid[0] << ", " << u.centroid[1]
          << ", " << u.centroid[2] << ") mm: [" << u.minDihedral << ", " << u.maxDihedral << "] deg";
  }
  if (!s.unfixed.empty()) rep.set("improve_unfixed_where", where.str());
  rep.set("improve_target_min_dihedral", p.min_angle);
  rep.set("improve_target_max_dihedral", p.max_angle);
}

} // namespace tetflow
