// Smoothing and decimation that keep BEM surfaces closed, manifold and uncrossed (see
// SurfaceSimplify.h).
#include "Algorithms/Surfaces/SurfaceSimplify.h"

#include <algorithm>
#include <cmath>
#include <queue>

#include <unordered_map>

#include "Algorithms/SurfaceMeshing/SurfaceIntersections.h"

namespace tetflow {

namespace {

struct Box3 {
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  void add(const Vec3& p) {
    for (size_t k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], p[k]);
      hi[k] = std::max(hi[k], p[k]);
    }
  }
};

// A uniform hash grid of boxes: query(box) gives every id filed with a box overlapping the
// cells of `box` (ids may repeat, and stale entries of moved triangles stay: callers dedupe and
// test the current geometry).
class TriangleGrid {
public:
  explicit TriangleGrid(double cell) : cell_(cell > 0 ? cell : 1.0) {}
  void insert(int32_t id, const Box3& box) {
    const auto lo = cellOf(box.lo), hi = cellOf(box.hi);
    for (int64_t i = lo[0]; i <= hi[0]; ++i)
      for (int64_t j = lo[1]; j <= hi[1]; ++j)
        for (int64_t k = lo[2]; k <= hi[2]; ++k) cells_[key(i, j, k)].push_back(id);
  }
  template <class F> void query(const Box3& box, F&& f) const {
    const auto lo = cellOf(box.lo), hi = cellOf(box.hi);
    for (int64_t i = lo[0]; i <= hi[0]; ++i)
      for (int64_t j = lo[1]; j <= hi[1]; ++j)
        for (int64_t k = lo[2]; k <= hi[2]; ++k) {
          auto it = cells_.find(key(i, j, k));
          if (it != cells_.end())
            for (int32_t id : it->second) f(id);
        }
  }

private:
  std::array<int64_t, 3> cellOf(const Vec3& p) const {
    return {int64_t(std::floor(p[0] / cell_)), int64_t(std::floor(p[1] / cell_)), int64_t(std::floor(p[2] / cell_))};
  }
  static uint64_t key(int64_t i, int64_t j, int64_t k) {
    return (uint64_t(i & 0x1FFFFF) << 42) | (uint64_t(j & 0x1FFFFF) << 21) | uint64_t(k & 0x1FFFFF);
  }
  double cell_;
  std::unordered_map<uint64_t, std::vector<int32_t>> cells_;
};

double meanEdgeLength(const TriSurface& s) {
  double sum = 0;
  for (const auto& t : s.triangles)
    for (size_t k = 0; k < 3; ++k) sum += norm(s.points[size_t(t[k])] - s.points[size_t(t[(k + 1) % 3])]);
  return s.triangles.empty() ? 0.0 : sum / double(3 * s.triangles.size());
}

double quality(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, bc = c - b, ca = a - c;
  const double l2 = dot(ab, ab) + dot(bc, bc) + dot(ca, ca);
  return l2 > 0 ? 4.0 * std::sqrt(3.0) * 0.5 * norm(cross(ab, c - a)) / l2 : 0.0;
}

// A surface being edited: triangles die (alive = 0) and change corners; points move. pts holds
// the surface's points, then the obstacles' (so that one pair test, SurfaceIntersections.h,
// serves both); callers put a tried point in place, test, and put it back if refused. The
// obstacles' triangles and the surface's own sit in grids for the crossing tests.
class Editable {
public:
  Editable(TriSurface& s, const std::vector<const TriSurface*>& obstacles, double cell)
      : s_(s), pts(s.points), alive_(s.triangles.size(), 1), around_(s.points.size()), obstacleGrid_(cell),
        selfGrid_(cell) {
    for (size_t t = 0; t < s.triangles.size(); ++t)
      for (int32_t v : s.triangles[t]) around_[size_t(v)].push_back(int32_t(t));
    for (const TriSurface* ob : obstacles) {
      const int32_t offset = int32_t(pts.size());
      pts.insert(pts.end(), ob->points.begin(), ob->points.end());
      for (const auto& t : ob->triangles) {
        const Tri tri{t[0] + offset, t[1] + offset, t[2] + offset};
        obstacleGrid_.insert(int32_t(obstacleTris_.size()), boxOf(tri));
        obstacleTris_.push_back(tri);
      }
    }
    inserted_.resize(s.triangles.size());
    obstacleStamp_.assign(obstacleTris_.size(), 0);
    selfStamp_.assign(s.triangles.size(), 0);
    for (size_t t = 0; t < s.triangles.size(); ++t) regrid(int32_t(t));
  }

  using Tri = std::array<int32_t, 3>;
  TriSurface& s_;
  std::vector<Vec3> pts;
  std::vector<uint8_t> alive_;
  std::vector<std::vector<int32_t>> around_; // triangles at each point (dead ones dropped lazily)
  SurfaceEditStats stats;

  // The living triangles at v.
  const std::vector<int32_t>& trianglesAt(int32_t v) {
    auto& a = around_[size_t(v)];
    a.erase(std::remove_if(a.begin(), a.end(), [&](int32_t t) { return !alive_[size_t(t)]; }), a.end());
    return a;
  }
  std::vector<int32_t> neighbours(int32_t v) {
    std::vector<int32_t> n;
    for (int32_t t : trianglesAt(v))
      for (int32_t w : s_.triangles[size_t(t)])
        if (w != v) n.push_back(w);
    std::sort(n.begin(), n.end());
    n.erase(std::unique(n.begin(), n.end()), n.end());
    return n;
  }

  // Whether triangles `changed` (corners as they would be, points as pts holds them now) pass:
  // not turned over against the `before` normals, quality at least minQuality, and meeting
  // neither each other, nor an obstacle, nor a living triangle of the surface outside `skip`
  // other than in what they share.
  bool acceptable(const std::vector<Tri>& changed, const std::vector<Vec3>& before, const std::vector<int32_t>& skip,
                  double minQuality) {
    for (size_t i = 0; i < changed.size(); ++i) {
      const auto& t = changed[i];
      const Vec3 &a = pts[size_t(t[0])], &b = pts[size_t(t[1])], &c = pts[size_t(t[2])];
      if (dot(cross(b - a, c - a), before[i]) <= 0 || quality(a, b, c) < minQuality) {
        ++stats.refusedShape;
        return false;
      }
    }
    for (size_t i = 0; i < changed.size(); ++i)
      for (size_t j = i + 1; j < changed.size(); ++j)
        if (trianglesIntersect(pts, changed[i], changed[j])) {
          ++stats.refusedCrossing;
          return false;
        }
    for (const auto& t : changed) {
      const Box3 box = boxOf(t);
      // Boxes that do not meet (with the pair test's tolerance to spare) need no pair test.
      const double pad = 1e-9 * (box.hi[0] - box.lo[0] + box.hi[1] - box.lo[1] + box.hi[2] - box.lo[2]);
      auto apart = [&](const Tri& o) {
        for (size_t k = 0; k < 3; ++k) {
          double lo = pts[size_t(o[0])][k], hi = lo;
          for (size_t c = 1; c < 3; ++c) {
            lo = std::min(lo, pts[size_t(o[c])][k]);
            hi = std::max(hi, pts[size_t(o[c])][k]);
          }
          if (hi < box.lo[k] - pad || lo > box.hi[k] + pad) return true;
        }
        return false;
      };
      bool crossing = false;
      ++query_; // each candidate tested once per triangle
      obstacleGrid_.query(box, [&](int32_t o) {
        if (crossing || obstacleStamp_[size_t(o)] == query_) return;
        obstacleStamp_[size_t(o)] = query_;
        crossing = !apart(obstacleTris_[size_t(o)]) && trianglesIntersect(pts, t, obstacleTris_[size_t(o)]);
      });
      selfGrid_.query(box, [&](int32_t o) {
        if (crossing || selfStamp_[size_t(o)] == query_ || !alive_[size_t(o)]) return;
        selfStamp_[size_t(o)] = query_;
        if (std::find(skip.begin(), skip.end(), o) != skip.end()) return;
        crossing = !apart(s_.triangles[size_t(o)]) && trianglesIntersect(pts, t, s_.triangles[size_t(o)]);
      });
      if (crossing) {
        ++stats.refusedCrossing;
        return false;
      }
    }
    return true;
  }

  // After triangle t moved: filed again only when it left the padded box it was filed with, so
  // that small moves (smoothing) do not pile up entries.
  void regrid(int32_t t) {
    const Box3 box = boxOf(s_.triangles[size_t(t)]);
    Box3& in = inserted_[size_t(t)];
    bool inside = true;
    for (size_t k = 0; k < 3; ++k) inside = inside && box.lo[k] >= in.lo[k] && box.hi[k] <= in.hi[k];
    if (inside) return;
    const double pad = 0.25 * (box.hi[0] - box.lo[0] + box.hi[1] - box.lo[1] + box.hi[2] - box.lo[2]) / 3.0;
    in = box;
    for (size_t k = 0; k < 3; ++k) {
      in.lo[k] -= pad;
      in.hi[k] += pad;
    }
    selfGrid_.insert(t, in);
  }

  Vec3 normalOf(const Tri& t) const {
    const Vec3 &a = pts[size_t(t[0])], &b = pts[size_t(t[1])], &c = pts[size_t(t[2])];
    return cross(b - a, c - a);
  }

  // Drops dead triangles and unused points, renumbering compactly, into the surface.
  void compact() {
    std::vector<int32_t> index(s_.points.size(), -1);
    TriSurface out;
    for (size_t t = 0; t < s_.triangles.size(); ++t) {
      if (!alive_[t]) continue;
      Tri tri{};
      for (size_t k = 0; k < 3; ++k) {
        const int32_t v = s_.triangles[t][k];
        if (index[size_t(v)] < 0) {
          index[size_t(v)] = int32_t(out.points.size());
          out.points.push_back(pts[size_t(v)]);
          out.meshVertex.push_back(s_.meshVertex.empty() ? v : s_.meshVertex[size_t(v)]);
        }
        tri[k] = index[size_t(v)];
      }
      out.triangles.push_back(tri);
    }
    s_ = std::move(out);
  }

private:
  Box3 boxOf(const Tri& t) const {
    Box3 b;
    for (int32_t v : t) b.add(pts[size_t(v)]);
    return b;
  }
  TriangleGrid obstacleGrid_, selfGrid_;
  std::vector<Tri> obstacleTris_;
  std::vector<Box3> inserted_; // the padded box each triangle was filed with
  std::vector<uint32_t> obstacleStamp_, selfStamp_;
  uint32_t query_ = 0;
};

// Symmetric 4x4 quadric, 10 coefficients: a b c d / e f g / h i / j.
struct Quadric {
  double q[10] = {};
  void addPlane(const Vec3& n, double d, double w) {
    const double p[4] = {n[0], n[1], n[2], d};
    int k = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = i; j < 4; ++j) q[k++] += w * p[i] * p[j];
  }
  Quadric operator+(const Quadric& o) const {
    Quadric r;
    for (int k = 0; k < 10; ++k) r.q[k] = q[k] + o.q[k];
    return r;
  }
  double error(const Vec3& x) const {
    const double v[4] = {x[0], x[1], x[2], 1.0};
    double e = 0;
    int k = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = i; j < 4; ++j) e += (i == j ? 1.0 : 2.0) * q[k++] * v[i] * v[j];
    return e;
  }
  // The minimiser, if the 3x3 part is well conditioned.
  bool minimiser(Vec3& x) const {
    const Mat3 A = {{{q[0], q[1], q[2]}, {q[1], q[4], q[5]}, {q[2], q[5], q[7]}}};
    const Vec3 b = {-q[3], -q[6], -q[8]};
    const double d = det(A);
    const double scale = std::abs(q[0] * q[4] * q[7]) + 1e-300;
    if (std::abs(d) < 1e-9 * scale) return false;
    for (int k = 0; k < 3; ++k) {
      Mat3 m = A;
      for (int r = 0; r < 3; ++r) m[size_t(r)][size_t(k)] = b[size_t(r)];
      x[size_t(k)] = det(m) / d;
    }
    return true;
  }
};

} // namespace

SurfaceEditStats smoothSurface(TriSurface& s, const std::vector<const TriSurface*>& obstacles, int iterations,
                               const Progress& progress) {
  if (iterations <= 0 || s.triangles.empty()) return {};
  Editable e(s, obstacles, 2.0 * meanEdgeLength(s));
  const size_t n = s.points.size();
  std::vector<std::vector<int32_t>> nbrs(n);
  for (size_t v = 0; v < n; ++v) nbrs[v] = e.neighbours(int32_t(v));
  std::vector<Vec3> target(n);
  std::vector<std::array<int32_t, 3>> changed;
  std::vector<Vec3> before;
  for (int it = 0; it < iterations; ++it)
    for (const double f : {0.5, -0.53}) {
      progress.checkCancel();
      for (size_t v = 0; v < n; ++v) {
        Vec3 mean{0, 0, 0};
        for (int32_t w : nbrs[v]) mean = mean + e.pts[size_t(w)];
        if (nbrs[v].empty()) {
          target[v] = e.pts[v];
          continue;
        }
        mean = (1.0 / double(nbrs[v].size())) * mean;
        target[v] = e.pts[v] + f * (mean - e.pts[v]);
      }
      for (size_t v = 0; v < n; ++v) {
        const std::vector<int32_t> ring = e.trianglesAt(int32_t(v));
        changed.clear();
        before.clear();
        for (int32_t t : ring) {
          changed.push_back(s.triangles[size_t(t)]);
          before.push_back(e.normalOf(s.triangles[size_t(t)]));
        }
        const Vec3 from = e.pts[v];
        e.pts[v] = target[v];
        if (!e.acceptable(changed, before, ring, 0.05)) {
          e.pts[v] = from;
          continue;
        }
        for (int32_t t : ring) e.regrid(t);
        ++e.stats.moves;
      }
    }
  e.compact();
  return e.stats;
}

SurfaceEditStats decimateSurface(TriSurface& s, const std::vector<const TriSurface*>& obstacles,
                                 int64_t targetTriangles, const Progress& progress) {
  int64_t living = int64_t(s.triangles.size());
  if (targetTriangles <= 0 || living <= targetTriangles) return {};
  double area = 0;
  for (const auto& t : s.triangles)
    area += 0.5 * norm(cross(s.points[size_t(t[1])] - s.points[size_t(t[0])], s.points[size_t(t[2])] - s.points[size_t(t[0])]));
  // Grid cells about the size of the triangles at the end.
  const double finalEdge = std::sqrt(4.0 * area / (std::sqrt(3.0) * double(std::max<int64_t>(targetTriangles, 4))));
  Editable e(s, obstacles, std::max(finalEdge, 2.0 * meanEdgeLength(s)));
  const size_t n = s.points.size();
  std::vector<Quadric> Q(n);
  for (const auto& t : s.triangles) {
    const Vec3 &a = s.points[size_t(t[0])], &b = s.points[size_t(t[1])], &c = s.points[size_t(t[2])];
    Vec3 nrm = cross(b - a, c - a);
    const double len = norm(nrm);
    if (len <= 0) continue;
    nrm = (1.0 / len) * nrm;
    for (int32_t v : t) Q[size_t(v)].addPlane(nrm, -dot(nrm, a), 0.5 * len);
  }
  std::vector<uint32_t> version(n, 0);
  struct Candidate {
    double cost;
    int32_t u, v;
    uint32_t vu, vv;
    Vec3 to;
    bool operator<(const Candidate& o) const { return cost > o.cost; } // smallest first
  };
  std::priority_queue<Candidate> heap;
  auto push = [&](int32_t u, int32_t v) {
    const Quadric q = Q[size_t(u)] + Q[size_t(v)];
    const Vec3 &pu = e.pts[size_t(u)], &pv = e.pts[size_t(v)];
    const Vec3 mid = 0.5 * (pu + pv);
    Vec3 best = mid;
    double cost = q.error(mid);
    Vec3 x;
    if (q.minimiser(x) && norm(x - mid) <= norm(pu - pv)) {
      const double ex = q.error(x);
      if (ex < cost) {
        cost = ex;
        best = x;
      }
    }
    for (const Vec3& p : {pu, pv})
      if (const double ep = q.error(p); ep < cost) {
        cost = ep;
        best = p;
      }
    heap.push({std::max(cost, 0.0), u, v, version[size_t(u)], version[size_t(v)], best});
  };
  for (const auto& t : s.triangles)
    for (int k = 0; k < 3; ++k) {
      const int32_t u = t[size_t(k)], v = t[size_t((k + 1) % 3)];
      if (u < v) push(u, v);
    }
  std::vector<std::array<int32_t, 3>> changed;
  std::vector<int32_t> changedIds, skip;
  std::vector<Vec3> before;
  int64_t popped = 0;
  while (living > targetTriangles && !heap.empty()) {
    progress.checkCancelEvery(++popped, 12);
    const Candidate c = heap.top();
    heap.pop();
    if (version[size_t(c.u)] != c.vu || version[size_t(c.v)] != c.vv) continue;
    const int32_t u = c.u, v = c.v;
    // The two triangles on the edge, and the link condition.
    std::vector<int32_t> edgeTris;
    for (int32_t t : e.trianglesAt(u)) {
      const auto& tri = s.triangles[size_t(t)];
      if (tri[0] == v || tri[1] == v || tri[2] == v) edgeTris.push_back(t);
    }
    if (edgeTris.size() != 2) {
      if (!edgeTris.empty()) ++e.stats.refusedTopology;
      continue;
    }
    const std::vector<int32_t> nu = e.neighbours(u), nv = e.neighbours(v);
    std::vector<int32_t> common;
    std::set_intersection(nu.begin(), nu.end(), nv.begin(), nv.end(), std::back_inserter(common));
    bool ok = common.size() == 2 && nu.size() + nv.size() - 4 >= 3; // u keeps 3 neighbours or more
    for (int32_t w : common) ok = ok && e.neighbours(w).size() > 3;
    if (!ok || living <= 4) {
      ++e.stats.refusedTopology;
      continue;
    }
    changed.clear();
    changedIds.clear();
    before.clear();
    skip = edgeTris;
    for (int32_t end : {u, v})
      for (int32_t t : e.trianglesAt(end)) {
        if (t == edgeTris[0] || t == edgeTris[1]) continue;
        if (std::find(changedIds.begin(), changedIds.end(), t) != changedIds.end()) continue;
        auto tri = s.triangles[size_t(t)];
        before.push_back(e.normalOf(tri));
        for (int32_t& w : tri)
          if (w == v) w = u;
        changed.push_back(tri);
        changedIds.push_back(t);
        skip.push_back(t);
      }
    const Vec3 from = e.pts[size_t(u)];
    e.pts[size_t(u)] = c.to;
    if (!e.acceptable(changed, before, skip, 0.1)) {
      e.pts[size_t(u)] = from;
      continue;
    }
    // Collapse v into u.
    for (int32_t t : edgeTris) e.alive_[size_t(t)] = 0;
    living -= 2;
    for (size_t i = 0; i < changedIds.size(); ++i) {
      s.triangles[size_t(changedIds[i])] = changed[i];
      e.regrid(changedIds[i]);
    }
    auto& au = e.around_[size_t(u)];
    for (int32_t t : e.trianglesAt(v))
      if (std::find(au.begin(), au.end(), t) == au.end()) au.push_back(t);
    e.around_[size_t(v)].clear();
    Q[size_t(u)] = Q[size_t(u)] + Q[size_t(v)];
    ++version[size_t(u)];
    ++version[size_t(v)];
    ++e.stats.collapses;
    for (int32_t w : e.neighbours(u)) push(std::min(u, w), std::max(u, w));
  }
  e.compact();
  return e.stats;
}

} // namespace tetflow
