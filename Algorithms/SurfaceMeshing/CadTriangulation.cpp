// Parameter-space triangulation of a CAD particle sample (CadTriangulation.h, seed §3.4).
#include "CadTriangulation.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include "Algorithms/Core/Errors.h"
#include "Delaunay2D.h"

namespace tetflow {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kMaxRounds = 12;
constexpr int kMaxFlipPasses = 20;
// A degenerate edge gets at most this many intervals (its refinement doubles per failed round).
constexpr int kMaxDegenerateIntervals = 1 << 14;

uint64_t edgeKey(int a, int b) {
  if (a > b) std::swap(a, b);
  return (uint64_t(uint32_t(a)) << 32) | uint64_t(uint32_t(b));
}

// Symmetric 2x2 matrix [[a b] [b c]].
struct Sym2 {
  double a = 1, b = 0, c = 1;
};

Point2 apply(const Sym2& m, const Point2& p) { return {m.a * p.x + m.b * p.y, m.b * p.x + m.c * p.y}; }

// Square root of a symmetric positive (semi-)definite 2x2 matrix: (M + sI) / t with s = sqrt(det M)
// and t = sqrt(trace M + 2s) (Cayley-Hamilton: both eigenvalues of the result are the roots').
Sym2 sqrtSpd(const Sym2& m) {
  const double s = std::sqrt(std::max(0.0, m.a * m.c - m.b * m.b));
  const double t = std::sqrt(m.a + m.c + 2 * s);
  if (!(t > 0)) return {};
  return {(m.a + s) / t, m.b / t, (m.c + s) / t};
}

double dist2D(const Point2& a, const Point2& b) { return std::hypot(a.x - b.x, a.y - b.y); }

double angleAt(const Vec3& apex, const Vec3& p, const Vec3& q) {
  const Vec3 u = p - apex, v = q - apex;
  const double nu = norm(u), nv = norm(v);
  if (nu == 0 || nv == 0) return 0;
  return std::acos(std::clamp(dot(u, v) / (nu * nv), -1.0, 1.0));
}

// A point of a boundary loop.
struct LoopPoint {
  Point2 uv;
  int particle = -1;
  int use = -1;  // the use (index in its loop) it belongs to
  double t = 0;  // curve parameter (curve use) or pcurve parameter (degenerate edge)
};

// A boundary segment: consecutive loop points a -> b (local indices) of one use.
struct Segment {
  int a = -1, b = -1;
  int curve = -1;       // -1: on a degenerate edge
  double ta = 0, tb = 0; // the ends' parameters
  int loop = 0, use = 0;
};

// One patch's triangulation in its parameters; local points are loop points then interior particles.
struct PatchMesh {
  Sym2 scale;                 // A: scaled parameters = A (u, v)
  std::vector<Point2> uv, xy; // parameters and scaled parameters
  std::vector<int> particle;
  // The vertex of the lifted surface each local point stands for: itself, except that all points
  // of a degenerate edge (its ends included) stand for the first of them (one pole).
  std::vector<int> vertex;
  std::vector<std::vector<int>> loops; // local indices, in loop order
  std::vector<Segment> segments;
  std::vector<std::array<int, 3>> triangles; // local, oriented outward, no repeated particle
  std::string collapsed; // a kept triangle joined two copies of a particle that is not a pole
};

// A curve split asked for by some patch: the segment between parameters ta < tb of `curve`.
struct SplitRequest {
  int curve = -1;
  double ta = 0, tb = 0;
  int pa = -1, pb = -1;
};

// What went wrong in a patch this round.
struct PatchOutcome {
  bool ok = true;
  std::vector<SplitRequest> splits;
  std::vector<std::pair<int, int>> degenerate; // (loop, use) of degenerate edges to refine
  std::string firstProblem;                   // for the error message
};

class Triangulator {
public:
  Triangulator(const CadModel& model, CadSample& sample, CadTriangulationStats& stats)
      : model_(model), sample_(sample), stats_(stats) {}

  CadSurfaceMesh run();

private:
  PatchOutcome triangulatePatch(int p);
  std::vector<std::vector<LoopPoint>> buildLoops(int p, Sym2& scale);
  int removeEncroaching(int p, const PatchMesh& pm);
  void keepInside(PatchMesh& pm, const Triangulation2D& tri, int p);
  void cancelFolds(PatchMesh& pm);
  void applySplit(const SplitRequest& s);
  void splitRepeatedCurveEdges();
  void flipPatch(int p, std::unordered_map<uint64_t, int>& edgeCount);
  std::string where(int p) const {
    return "triangulating CAD model '" + model_.source() + "': patch " + std::to_string(p);
  }

  const CadModel& model_;
  CadSample& sample_;
  CadTriangulationStats& stats_;
  std::vector<PatchMesh> meshes_;
  // Per patch: intervals multiplier of its degenerate edges, keyed by (loop, use).
  std::vector<std::map<std::pair<int, int>, int>> degenerateRefine_;
};

// Step 1 and 2: the loops' points (degenerate edges filled in the scaled metric) and the scaling.
std::vector<std::vector<LoopPoint>> Triangulator::buildLoops(int p, Sym2& scale) {
  const CadPatch& patch = model_.patches()[size_t(p)];
  const auto& curves = model_.curves();
  // Per loop, per use: its points (a degenerate use: only its start for now).
  std::vector<std::vector<std::vector<LoopPoint>>> pieces(patch.loops.size());
  for (size_t l = 0; l < patch.loops.size(); ++l) {
    const auto& loop = patch.loops[l];
    pieces[l].resize(loop.size());
    for (size_t u = 0; u < loop.size(); ++u) {
      const CadCurveUse& use = loop[u];
      auto& out = pieces[l][u];
      const double ts = use.reversed ? use.t1 : use.t0;
      if (use.curve < 0) {
        out.push_back({model_.useOnPatch(p, use, ts), use.corner, int(u), ts});
        continue;
      }
      const CadCurve& c = curves[size_t(use.curve)];
      out.push_back({model_.useOnPatch(p, use, ts), use.reversed ? c.corner1 : c.corner0, int(u),
                     use.reversed ? c.t1 : c.t0});
      const auto& chain = sample_.onCurve[size_t(use.curve)];
      for (size_t k = 0; k < chain.size(); ++k) {
        const int id = use.reversed ? chain[chain.size() - 1 - k] : chain[k];
        const double t = sample_.particles[size_t(id)].t;
        out.push_back({model_.useOnPatch(p, use, t), id, int(u), t});
      }
    }
  }

  // Metric: the mean of J^T J over the loop points and interior particles with a regular J.
  double ga = 0, gb = 0, gc = 0;
  int n = 0;
  auto addMetric = [&](const Point2& uv) {
    const PatchPoint pp = model_.patchPoint(p, uv.x, uv.y);
    const double a = dot(pp.du, pp.du), b = dot(pp.du, pp.dv), c = dot(pp.dv, pp.dv);
    const double tr = a + c;
    if (!(tr > 0) || !std::isfinite(tr) || a * c - b * b <= 1e-10 * tr * tr) return;
    ga += a, gb += b, gc += c;
    ++n;
  };
  for (const auto& loop : pieces)
    for (const auto& piece : loop)
      for (const auto& lp : piece) addMetric(lp.uv);
  for (int id : sample_.onPatch[size_t(p)]) addMetric(sample_.particles[size_t(id)].uv);
  scale = n > 0 ? sqrtSpd({ga / n, gb / n, gc / n}) : Sym2{};

  // Degenerate edges: points spaced like the neighbouring boundary segments (scaled), at least two.
  std::vector<std::vector<LoopPoint>> loops(patch.loops.size());
  for (size_t l = 0; l < patch.loops.size(); ++l) {
    const auto& loop = patch.loops[l];
    std::vector<LoopPoint> flat;
    for (const auto& piece : pieces[l]) flat.insert(flat.end(), piece.begin(), piece.end());
    const size_t m = flat.size();
    auto scaledLength = [&](size_t i, size_t j) {
      return dist2D(apply(scale, flat[i % m].uv), apply(scale, flat[j % m].uv));
    };
    size_t start = 0; // index in flat of the current use's first point
    for (size_t u = 0; u < loop.size(); ++u) {
      const CadCurveUse& use = loop[u];
      auto& out = loops[l];
      out.insert(out.end(), pieces[l][u].begin(), pieces[l][u].end());
      const size_t here = start;
      start += pieces[l][u].size();
      if (use.curve >= 0) continue;
      const double ts = use.reversed ? use.t1 : use.t0, te = use.reversed ? use.t0 : use.t1;
      double length = 0;
      Point2 prev = apply(scale, model_.useOnPatch(p, use, ts));
      for (int k = 1; k <= 16; ++k) {
        const Point2 q = apply(scale, model_.useOnPatch(p, use, ts + (te - ts) * k / 16.0));
        length += dist2D(prev, q);
        prev = q;
      }
      double spacing = 0;
      int count = 0;
      if (m >= 3) {
        // The segment that ends at this edge's start, and the one that starts at its end.
        const double before = scaledLength(here + m - 1, here), after = scaledLength(here + 1, here + 2);
        if (before > 0) spacing += before, ++count;
        if (after > 0) spacing += after, ++count;
      }
      spacing = count > 0 ? spacing / count : length / 3;
      int intervals = spacing > 0 ? int(std::min(1e6, std::ceil(length / spacing))) : 3;
      intervals = std::max(intervals, 3);
      auto it = degenerateRefine_[size_t(p)].find({int(l), int(u)});
      if (it != degenerateRefine_[size_t(p)].end()) intervals *= it->second;
      intervals = std::min(intervals, kMaxDegenerateIntervals);
      for (int k = 1; k < intervals; ++k) {
        const double t = ts + (te - ts) * k / double(intervals);
        out.push_back({model_.useOnPatch(p, use, t), use.corner, int(u), t});
      }
    }
  }
  return loops;
}

// Step 3: removes (from sample.onPatch[p]) the interior particles strictly inside a boundary
// segment's diametral circle. pm holds the loop points (scaled); returns how many were removed.
int Triangulator::removeEncroaching(int p, const PatchMesh& pm) {
  auto& interior = sample_.onPatch[size_t(p)];
  if (interior.empty() || pm.segments.empty()) return 0;
  const size_t n = interior.size();
  std::vector<Point2> q(n);
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  const Sym2& A = pm.scale;
  for (size_t i = 0; i < n; ++i) {
    q[i] = apply(A, sample_.particles[size_t(interior[i])].uv);
    x0 = std::min(x0, q[i].x), x1 = std::max(x1, q[i].x);
    y0 = std::min(y0, q[i].y), y1 = std::max(y1, q[i].y);
  }
  // Bucket grid with about one particle per cell.
  const double w = std::max(x1 - x0, 0.0), h = std::max(y1 - y0, 0.0);
  double cell = std::sqrt(std::max(w * h, 1e-300) / double(n));
  cell = std::max({cell, 1e-9 * std::max(w, h), 1e-300});
  const int nx = std::clamp(int(w / cell) + 1, 1, 4096), ny = std::clamp(int(h / cell) + 1, 1, 4096);
  const double cx = w > 0 ? nx / (w * (1 + 1e-12)) : 0, cy = h > 0 ? ny / (h * (1 + 1e-12)) : 0;
  auto cellX = [&](double x) { return std::clamp(int((x - x0) * cx), 0, nx - 1); };
  auto cellY = [&](double y) { return std::clamp(int((y - y0) * cy), 0, ny - 1); };
  std::vector<int> first(size_t(nx) * size_t(ny) + 1, 0), items(n);
  for (size_t i = 0; i < n; ++i) ++first[size_t(cellY(q[i].y)) * size_t(nx) + size_t(cellX(q[i].x)) + 1];
  for (size_t c = 1; c < first.size(); ++c) first[c] += first[c - 1];
  {
    std::vector<int> fill(first.begin(), first.end() - 1);
    for (size_t i = 0; i < n; ++i) items[size_t(fill[size_t(cellY(q[i].y)) * size_t(nx) + size_t(cellX(q[i].x))]++)] = int(i);
  }
  std::vector<char> removed(n, 0);
  for (const Segment& s : pm.segments) {
    const Point2 a = pm.xy[size_t(s.a)], b = pm.xy[size_t(s.b)];
    const double len2 = (a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y);
    if (!(len2 > 0)) continue;
    const double r = 0.5 * std::sqrt(len2), mx = 0.5 * (a.x + b.x), my = 0.5 * (a.y + b.y);
    if (mx + r < x0 || mx - r > x1 || my + r < y0 || my - r > y1) continue;
    const int i0 = cellX(mx - r), i1 = cellX(mx + r), j0 = cellY(my - r), j1 = cellY(my + r);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const size_t c = size_t(j) * size_t(nx) + size_t(i);
        for (int k = first[c]; k < first[c + 1]; ++k) {
          const Point2& x = q[size_t(items[size_t(k)])];
          // Strictly inside the diametral circle: the segment subtends an obtuse angle at x.
          const double d = (a.x - x.x) * (b.x - x.x) + (a.y - x.y) * (b.y - x.y);
          if (d < -1e-12 * len2) removed[size_t(items[size_t(k)])] = 1;
        }
      }
  }
  int count = 0;
  std::vector<int> kept;
  kept.reserve(n);
  for (size_t i = 0; i < n; ++i)
    if (removed[i]) ++count;
    else kept.push_back(interior[i]);
  interior.swap(kept);
  return count;
}

// Step 5 and 6: the Delaunay triangles inside the loops, lifted: repeated particles dropped,
// oriented outward. With every boundary segment an edge, the triangles fall into regions separated
// by the segments, each wholly inside or wholly outside. A region's side is read from the
// orientation of its boundary segments: OpenCASCADE orients a forward face's loops with the face
// on their left (outer loop counter-clockwise, holes clockwise), and A has a positive determinant,
// so a counter-clockwise triangle that runs along a segment in loop order is inside. This is exact,
// unlike an even-odd test of a centroid: a straight pcurve's points are collinear only up to
// rounding after scaling, and the slivers the Delaunay triangulation then puts between such a run
// and the convex hull have their centroids within rounding of the boundary. The even-odd test
// decides only regions whose segments disagree (loops not oriented as expected).
void Triangulator::keepInside(PatchMesh& pm, const Triangulation2D& tri, int p) {
  const size_t nt = tri.triangles.size();
  std::unordered_map<uint64_t, int> boundary; // segment -> its start in loop order
  for (const Segment& s : pm.segments) boundary.emplace(edgeKey(s.a, s.b), s.a);
  std::unordered_map<uint64_t, std::array<int, 2>> edgeTris;
  edgeTris.reserve(nt * 2);
  for (size_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) {
      const uint64_t key = edgeKey(tri.triangles[t][size_t(k)], tri.triangles[t][size_t((k + 1) % 3)]);
      auto [it, fresh] = edgeTris.try_emplace(key, std::array<int, 2>{int(t), -1});
      if (!fresh) it->second[1] = int(t);
    }
  auto evenOdd = [&](const Point2& q) {
    bool in = false;
    for (const auto& loop : pm.loops) {
      const size_t m = loop.size();
      for (size_t i = 0; i < m; ++i) {
        const Point2& a = pm.xy[size_t(loop[i])];
        const Point2& b = pm.xy[size_t(loop[(i + 1) % m])];
        if ((a.y > q.y) != (b.y > q.y)) {
          const double x = a.x + (q.y - a.y) * (b.x - a.x) / (b.y - a.y);
          if (q.x < x) in = !in;
        }
      }
    }
    return in;
  };
  std::vector<int> region(nt, -1);
  std::vector<char> regionInside;
  std::vector<int> stack;
  for (size_t seed = 0; seed < nt; ++seed) {
    if (region[seed] >= 0) continue;
    const int id = int(regionInside.size());
    size_t best = seed; // the largest triangle, for the even-odd fallback
    double bestArea = -1;
    int64_t insideVotes = 0, outsideVotes = 0;
    region[seed] = id;
    stack.assign(1, int(seed));
    while (!stack.empty()) {
      const int t = stack.back();
      stack.pop_back();
      const auto& tr = tri.triangles[size_t(t)];
      const double area = orient2D(pm.xy[size_t(tr[0])], pm.xy[size_t(tr[1])], pm.xy[size_t(tr[2])]);
      if (area > bestArea) bestArea = area, best = size_t(t);
      for (int k = 0; k < 3; ++k) {
        const int a = tr[size_t(k)], b = tr[size_t((k + 1) % 3)];
        const uint64_t key = edgeKey(a, b);
        if (auto seg = boundary.find(key); seg != boundary.end()) {
          ++(seg->second == a ? insideVotes : outsideVotes);
          continue;
        }
        const auto& pair = edgeTris.at(key);
        const int other = pair[0] == t ? pair[1] : pair[0];
        if (other >= 0 && region[size_t(other)] < 0) {
          region[size_t(other)] = id;
          stack.push_back(other);
        }
      }
    }
    bool in = insideVotes > 0;
    if (insideVotes == outsideVotes || (insideVotes > 0 && outsideVotes > 0)) {
      const auto& tr = tri.triangles[best];
      const Point2 c{(pm.xy[size_t(tr[0])].x + pm.xy[size_t(tr[1])].x + pm.xy[size_t(tr[2])].x) / 3,
                     (pm.xy[size_t(tr[0])].y + pm.xy[size_t(tr[1])].y + pm.xy[size_t(tr[2])].y) / 3};
      in = evenOdd(c);
    }
    regionInside.push_back(in ? 1 : 0);
  }
  const bool flip = model_.patches()[size_t(p)].reversed;
  pm.triangles.clear();
  for (size_t t = 0; t < nt; ++t) {
    if (!regionInside[size_t(region[t])]) continue;
    const auto& tr = tri.triangles[t];
    const int a = pm.particle[size_t(tr[0])], b = pm.particle[size_t(tr[1])], c = pm.particle[size_t(tr[2])];
    if (a == b || b == c || a == c) {
      // Two copies of one particle: fine on a pole (the strip along a degenerate edge collapses);
      // elsewhere (the two sides of a seam) the triangle spans the whole patch and its loss
      // leaves a hole.
      const int i = a == b ? 0 : b == c ? 1 : 2;
      const int u = tr[size_t(i)], v = tr[size_t((i + 1) % 3)];
      if (pm.vertex[size_t(u)] != pm.vertex[size_t(v)] && pm.collapsed.empty()) {
        const Vec3& x = sample_.particles[size_t(pm.particle[size_t(u)])].x;
        std::ostringstream os;
        os << "a triangle joins two copies of particle " << pm.particle[size_t(u)] << " (near " << x[0] << ", "
           << x[1] << ", " << x[2] << " mm) across the patch: the sample is too coarse for the patch's width "
           << "there (e.g. across a seam); sample it more finely";
        pm.collapsed = os.str();
      }
      ++stats_.degenerateDropped;
      continue;
    }
    pm.triangles.push_back(flip ? std::array<int, 3>{tr[0], tr[2], tr[1]} : std::array<int, 3>{tr[0], tr[1], tr[2]});
  }
  cancelFolds(pm);
}

// Near a pole the parameters stretch the circles of latitude without bound, so a particle can sit
// between another particle and the degenerate edge in (u, v) while both touch that edge: lifted,
// the two triangles that join them to the pole are one triangle twice, in opposite directions (a
// fold). Such pairs cancel: dropping both keeps every edge's balance of directions, and the
// particle between them, touching only the pole and the other, leaves the surface.
void Triangulator::cancelFolds(PatchMesh& pm) {
  auto P = [&](int local) { return pm.particle[size_t(local)]; };
  struct Key {
    std::array<int, 3> v;
    bool operator==(const Key& o) const { return v == o.v; }
  };
  struct Hash {
    size_t operator()(const Key& k) const {
      return std::hash<uint64_t>()((uint64_t(uint32_t(k.v[0])) << 42) ^ (uint64_t(uint32_t(k.v[1])) << 21) ^
                                   uint64_t(uint32_t(k.v[2])));
    }
  };
  // Sorted particles -> triangles (+1 + index for an even permutation of the sorted order, -1 - index
  // for an odd one).
  std::unordered_map<Key, std::vector<int>, Hash> seen;
  bool any = false;
  for (size_t t = 0; t < pm.triangles.size(); ++t) {
    std::array<int, 3> v{P(pm.triangles[t][0]), P(pm.triangles[t][1]), P(pm.triangles[t][2])};
    // Rotate the smallest first; the orientation is then whether the other two ascend.
    while (v[0] > v[1] || v[0] > v[2]) v = {v[1], v[2], v[0]};
    const bool even = v[1] < v[2];
    if (!even) std::swap(v[1], v[2]);
    auto& list = seen[Key{v}];
    list.push_back(even ? int(t) + 1 : -int(t) - 1);
    any = any || list.size() > 1;
  }
  if (!any) return;
  std::vector<char> drop(pm.triangles.size(), 0);
  for (auto& [key, list] : seen) {
    if (list.size() < 2) continue;
    std::vector<int> pos, neg;
    for (int e : list) (e > 0 ? pos : neg).push_back(e > 0 ? e - 1 : -e - 1);
    const size_t pairs = std::min(pos.size(), neg.size());
    for (size_t i = 0; i < pairs; ++i) drop[size_t(pos[i])] = drop[size_t(neg[i])] = 1;
    stats_.foldsCancelled += int64_t(pairs);
  }
  size_t k = 0;
  for (size_t t = 0; t < pm.triangles.size(); ++t)
    if (!drop[t]) pm.triangles[k++] = pm.triangles[t];
  pm.triangles.resize(k);
}

PatchOutcome Triangulator::triangulatePatch(int p) {
  PatchOutcome out;
  PatchMesh pm;
  const std::vector<std::vector<LoopPoint>> loops = buildLoops(p, pm.scale);
  auto addPoint = [&](const Point2& uv, int particle) {
    pm.uv.push_back(uv);
    pm.xy.push_back(apply(pm.scale, uv));
    pm.particle.push_back(particle);
    pm.vertex.push_back(int(pm.uv.size()) - 1);
    return int(pm.uv.size()) - 1;
  };
  const CadPatch& patch = model_.patches()[size_t(p)];
  const auto& curves = model_.curves();
  bool tooSmallLoop = false;
  for (size_t l = 0; l < loops.size(); ++l) {
    const auto& lp = loops[l];
    std::vector<int> local;
    for (const LoopPoint& q : lp) local.push_back(addPoint(q.uv, q.particle));
    // A degenerate edge's points, and the start of the use after it (its end), are one pole.
    const size_t m = lp.size();
    auto degenerate = [&](size_t i) { return patch.loops[l][size_t(lp[i].use)].curve < 0; };
    auto onPole = [&](size_t i) {
      const size_t prev = (i + m - 1) % m;
      return degenerate(i) || (lp[prev].use != lp[i].use && degenerate(prev));
    };
    size_t first = 0;
    while (first < m && onPole(first)) ++first;
    for (size_t k = 1; first < m && k <= m; ++k) {
      const size_t i = (first + k) % m, prev = (i + m - 1) % m;
      if (onPole(i) && onPole(prev)) pm.vertex[size_t(local[i])] = pm.vertex[size_t(local[prev])];
    }
    if (lp.size() < 3) tooSmallLoop = true;
    for (size_t i = 0; i < lp.size(); ++i) {
      const CadCurveUse& use = patch.loops[l][size_t(lp[i].use)];
      Segment s;
      s.a = local[i];
      s.b = local[(i + 1) % lp.size()];
      s.curve = use.curve;
      s.loop = int(l);
      s.use = lp[i].use;
      s.ta = lp[i].t;
      if (i + 1 < lp.size() && lp[i + 1].use == lp[i].use) {
        s.tb = lp[i + 1].t;
      } else if (use.curve >= 0) {
        const CadCurve& c = curves[size_t(use.curve)];
        s.tb = use.reversed ? c.t0 : c.t1;
      } else {
        s.tb = use.reversed ? use.t0 : use.t1;
      }
      pm.segments.push_back(s);
    }
    pm.loops.push_back(std::move(local));
  }

  auto segmentMissing = [&](const Segment& s) {
    out.ok = false;
    if (s.curve >= 0) {
      SplitRequest r{s.curve, std::min(s.ta, s.tb), std::max(s.ta, s.tb), pm.particle[size_t(s.a)],
                     pm.particle[size_t(s.b)]};
      out.splits.push_back(r);
    } else {
      out.degenerate.push_back({s.loop, s.use});
    }
    if (out.firstProblem.empty()) {
      std::ostringstream os;
      os << "the boundary segment between particles " << pm.particle[size_t(s.a)] << " and "
         << pm.particle[size_t(s.b)];
      if (s.curve >= 0) os << " on curve " << s.curve << " (parameters " << s.ta << " to " << s.tb << ")";
      else os << " on the degenerate edge of corner " << pm.particle[size_t(s.a)];
      os << " is not an edge of the parameter-space Delaunay triangulation";
      out.firstProblem = os.str();
    }
  };
  if (tooSmallLoop) {
    // A loop of fewer than three points (a closed curve with one particle or none) bounds no
    // area: split all its segments.
    for (const Segment& s : pm.segments)
      if (pm.loops[size_t(s.loop)].size() < 3) segmentMissing(s);
    meshes_[size_t(p)] = std::move(pm);
    return out;
  }

  stats_.encroachingRemoved += removeEncroaching(p, pm);
  for (int id : sample_.onPatch[size_t(p)]) addPoint(sample_.particles[size_t(id)].uv, id);

  Triangulation2D tri;
  try {
    tri = delaunay2D(pm.xy);
  } catch (const InputError& e) {
    // Fewer than three distinct points or all collinear: more boundary points can only help.
    for (const Segment& s : pm.segments) segmentMissing(s);
    out.firstProblem = std::string("its points admit no triangulation (") + e.what() + ")";
    meshes_[size_t(p)] = std::move(pm);
    return out;
  }
  std::vector<std::array<int32_t, 2>> edges;
  edges.reserve(pm.segments.size());
  for (const Segment& s : pm.segments) edges.push_back({s.a, s.b});
  const std::vector<bool> present = hasEdges(tri, edges);
  double box = 0;
  for (const Point2& q : pm.xy) box = std::max({box, std::abs(q.x), std::abs(q.y)});
  for (size_t i = 0; i < pm.segments.size(); ++i) {
    if (present[i]) continue;
    const Segment& s = pm.segments[i];
    if (dist2D(pm.xy[size_t(s.a)], pm.xy[size_t(s.b)]) <= 1e-11 * box || s.ta == s.tb) {
      std::ostringstream os;
      os << where(p) << ": boundary particles " << pm.particle[size_t(s.a)] << " and " << pm.particle[size_t(s.b)]
         << (s.curve >= 0 ? " on curve " + std::to_string(s.curve) : std::string(" on a degenerate edge"))
         << " coincide in the patch's parameters; the sample has duplicate particles";
      throw ProcessingError(os.str());
    }
    segmentMissing(s);
  }
  if (out.ok) keepInside(pm, tri, p);
  meshes_[size_t(p)] = std::move(pm);
  return out;
}

void Triangulator::applySplit(const SplitRequest& s) {
  CadParticle q;
  q.dim = 1;
  q.cell = s.curve;
  q.t = 0.5 * (s.ta + s.tb);
  q.x = model_.curvePoint(s.curve, q.t);
  q.sigma = 0.5 * (sample_.particles[size_t(s.pa)].sigma + sample_.particles[size_t(s.pb)].sigma);
  const int id = int(sample_.particles.size());
  sample_.particles.push_back(q);
  auto& chain = sample_.onCurve[size_t(s.curve)];
  auto at = std::lower_bound(chain.begin(), chain.end(), q.t,
                             [&](int i, double t) { return sample_.particles[size_t(i)].t < t; });
  chain.insert(at, id);
  ++stats_.curveSplits;
}

// Each link of a curve's chain (corner0, its particles, corner1) becomes an edge of the surface,
// so no two links may join the same two particles: a closed curve needs two particles or more, two
// curves between the same corners need one particle or more between them. Links that do are split.
void Triangulator::splitRepeatedCurveEdges() {
  const auto& curves = model_.curves();
  for (int pass = 0; pass < 4; ++pass) {
    std::unordered_map<uint64_t, std::vector<SplitRequest>> links;
    for (size_t c = 0; c < curves.size(); ++c) {
      std::vector<int> chain{curves[c].corner0};
      chain.insert(chain.end(), sample_.onCurve[c].begin(), sample_.onCurve[c].end());
      chain.push_back(curves[c].corner1);
      for (size_t i = 0; i + 1 < chain.size(); ++i) {
        const double ta = i == 0 ? curves[c].t0 : sample_.particles[size_t(chain[i])].t;
        const double tb = i + 2 == chain.size() ? curves[c].t1 : sample_.particles[size_t(chain[i + 1])].t;
        links[edgeKey(chain[i], chain[i + 1])].push_back({int(c), ta, tb, chain[i], chain[i + 1]});
      }
    }
    std::vector<SplitRequest> splits;
    for (const auto& [key, list] : links)
      if (list.size() > 1 || list[0].pa == list[0].pb) splits.insert(splits.end(), list.begin(), list.end());
    if (splits.empty()) return;
    std::sort(splits.begin(), splits.end(), [](const SplitRequest& a, const SplitRequest& b) {
      return a.curve != b.curve ? a.curve < b.curve : a.ta < b.ta;
    });
    for (const SplitRequest& r : splits) applySplit(r);
  }
}

// Step 7: Delaunay edge flips in 3-D inside patch p. edgeCount: the number of triangles of the
// whole surface on each particle pair, kept up to date. Two triangles are neighbours when they
// share an edge of the lifted surface inside the patch: the same two local points, or points that
// stand for the same pole (the triangles between them, along the degenerate edge, were dropped).
void Triangulator::flipPatch(int p, std::unordered_map<uint64_t, int>& edgeCount) {
  PatchMesh& pm = meshes_[size_t(p)];
  auto& tris = pm.triangles;
  const auto& x = sample_.particles;
  auto V = [&](int local) { return pm.vertex[size_t(local)]; };
  std::unordered_set<uint64_t> boundaryLocal, boundaryParticles;
  for (const Segment& s : pm.segments) {
    boundaryLocal.insert(edgeKey(V(s.a), V(s.b)));
    boundaryParticles.insert(edgeKey(pm.particle[size_t(s.a)], pm.particle[size_t(s.b)]));
  }
  auto X = [&](int local) -> const Vec3& { return x[size_t(pm.particle[size_t(local)])].x; };
  // Does triangle (a, b, c) (local) face within 90° of the surface normal at its centroid?
  auto facesOut = [&](int a, int b, int c) {
    const Vec3 n = cross(X(b) - X(a), X(c) - X(a));
    const double u = (pm.uv[size_t(a)].x + pm.uv[size_t(b)].x + pm.uv[size_t(c)].x) / 3;
    const double v = (pm.uv[size_t(a)].y + pm.uv[size_t(b)].y + pm.uv[size_t(c)].y) / 3;
    return dot(n, model_.patchNormal(p, u, v)) > 0;
  };
  for (int pass = 0; pass < kMaxFlipPasses; ++pass) {
    std::unordered_map<uint64_t, std::array<int, 2>> edgeTris;
    edgeTris.reserve(tris.size() * 2);
    for (size_t t = 0; t < tris.size(); ++t)
      for (int k = 0; k < 3; ++k) {
        auto [it, fresh] = edgeTris.try_emplace(edgeKey(V(tris[t][size_t(k)]), V(tris[t][size_t((k + 1) % 3)])),
                                                std::array<int, 2>{int(t), -1});
        if (!fresh) it->second[1] = it->second[1] == -1 ? int(t) : -2; // -2: more than two
      }
    std::vector<char> touched(tris.size(), 0);
    int64_t flips = 0;
    for (size_t t = 0; t < tris.size(); ++t) {
      for (int k = 0; k < 3 && !touched[t]; ++k) {
        const int a = tris[t][size_t(k)], b = tris[t][size_t((k + 1) % 3)], c = tris[t][size_t((k + 2) % 3)];
        const uint64_t key = edgeKey(V(a), V(b));
        if (boundaryLocal.count(key)) continue;
        const auto& pair = edgeTris.at(key);
        if (pair[1] < 0) continue;
        const int t2 = pair[0] == int(t) ? pair[1] : pair[0];
        if (touched[size_t(t2)]) continue;
        // t2 must run b -> a; d is its third vertex.
        const auto& o = tris[size_t(t2)];
        int d = -1;
        for (int j = 0; j < 3; ++j)
          if (V(o[size_t(j)]) == V(b) && V(o[size_t((j + 1) % 3)]) == V(a)) d = o[size_t((j + 2) % 3)];
        if (d < 0) continue;
        const int pa = pm.particle[size_t(a)], pb = pm.particle[size_t(b)];
        const int pc = pm.particle[size_t(c)], pd = pm.particle[size_t(d)];
        if (pc == pd || boundaryParticles.count(edgeKey(pa, pb))) continue;
        const auto ab = edgeCount.find(edgeKey(pa, pb));
        if (ab == edgeCount.end() || edgeCount.count(edgeKey(pc, pd))) continue;
        const double before = angleAt(X(c), X(a), X(b)) + angleAt(X(d), X(b), X(a));
        if (!(before > kPi + 1e-9)) continue;
        // The flipped pair must be better by the same measure (no flip-back cycles on curved quads).
        const double after = angleAt(X(a), X(d), X(c)) + angleAt(X(b), X(c), X(d));
        if (!(after < before)) continue;
        if (!facesOut(a, d, c) || !facesOut(d, b, c)) continue;
        tris[t] = {a, d, c};
        tris[size_t(t2)] = {d, b, c};
        if ((ab->second -= 2) <= 0) edgeCount.erase(ab);
        edgeCount[edgeKey(pc, pd)] = 2;
        touched[t] = touched[size_t(t2)] = 1;
        ++flips;
      }
    }
    stats_.flips += flips;
    if (flips == 0) break;
  }
}

CadSurfaceMesh Triangulator::run() {
  const int np = int(model_.patches().size());
  const int nc = int(model_.curves().size());
  bool matches = sample_.onCurve.size() == size_t(nc) && sample_.onPatch.size() == size_t(np) &&
                 sample_.particles.size() >= model_.corners().size();
  const size_t n = sample_.particles.size();
  for (size_t c = 0; matches && c < size_t(nc); ++c)
    for (int id : sample_.onCurve[c]) matches = matches && id >= 0 && size_t(id) < n;
  for (size_t p = 0; matches && p < size_t(np); ++p)
    for (int id : sample_.onPatch[p]) matches = matches && id >= 0 && size_t(id) < n;
  if (!matches)
    throw ProcessingError("triangulating CAD model '" + model_.source() +
                          "': the sample does not match the model (its curve or patch lists, particle indices "
                          "or corner particles)");
  meshes_.assign(size_t(np), {});
  degenerateRefine_.assign(size_t(np), {});
  splitRepeatedCurveEdges();
  std::vector<char> todo(size_t(np), 1);
  for (int round = 1;; ++round) {
    stats_.rounds = round;
    std::map<std::pair<int, double>, SplitRequest> splits; // by (curve, lower parameter)
    std::vector<char> next(size_t(np), 0);
    int failed = -1;
    std::string problem;
    for (int p = 0; p < np; ++p) {
      if (!todo[size_t(p)]) continue;
      PatchOutcome o = triangulatePatch(p);
      if (o.ok) continue;
      if (failed < 0) failed = p, problem = o.firstProblem;
      next[size_t(p)] = 1;
      for (const SplitRequest& s : o.splits) splits.try_emplace({s.curve, s.ta}, s);
      for (const auto& lu : o.degenerate) {
        int& f = degenerateRefine_[size_t(p)][lu];
        f = std::max(f, 1) * 2;
      }
    }
    if (failed < 0) break;
    if (round == kMaxRounds)
      throw ProcessingError(where(failed) + ": " + problem + " after " + std::to_string(kMaxRounds) +
                            " rounds of curve splits; the sample is too coarse on its boundary for the "
                            "patch's parameterisation");
    for (const auto& [key, s] : splits) {
      applySplit(s);
      for (int q : model_.curves()[size_t(s.curve)].patches) next[size_t(q)] = 1;
    }
    todo.swap(next);
  }

  for (int p = 0; p < np; ++p)
    if (!meshes_[size_t(p)].collapsed.empty()) throw ProcessingError(where(p) + ": " + meshes_[size_t(p)].collapsed);

  std::unordered_map<uint64_t, int> edgeCount;
  for (const PatchMesh& pm : meshes_)
    for (const auto& t : pm.triangles)
      for (int k = 0; k < 3; ++k)
        ++edgeCount[edgeKey(pm.particle[size_t(t[size_t(k)])], pm.particle[size_t(t[size_t((k + 1) % 3)])])];
  for (int p = 0; p < np; ++p) flipPatch(p, edgeCount);

  // The surface must be closed and consistently oriented: every directed edge once, with its
  // opposite. Anything else is a sample this construction cannot connect (e.g. two copies of a
  // sliver along a seam near a pole); say where.
  {
    std::unordered_map<uint64_t, int> directed; // (a, b) -> patch
    directed.reserve(edgeCount.size() * 2);
    for (int p = 0; p < np; ++p) {
      const PatchMesh& pm = meshes_[size_t(p)];
      for (const auto& t : pm.triangles)
        for (int k = 0; k < 3; ++k) {
          const int a = pm.particle[size_t(t[size_t(k)])], b = pm.particle[size_t(t[size_t((k + 1) % 3)])];
          const uint64_t key = (uint64_t(uint32_t(a)) << 32) | uint64_t(uint32_t(b));
          auto [it, fresh] = directed.emplace(key, p);
          const int count = edgeCount[edgeKey(a, b)];
          if (fresh && count == 2) continue;
          const Vec3& x = sample_.particles[size_t(a)].x;
          std::ostringstream os;
          os << where(p) << ": the surface is not closed and manifold at the edge between particles " << a
             << " and " << b << " (near " << x[0] << ", " << x[1] << ", " << x[2] << " mm), in " << count
             << " triangles" << (fresh ? "" : " and twice in the same direction")
             << "; the sample is too coarse there for the patch's parameterisation";
          throw ProcessingError(os.str());
        }
    }
  }

  CadSurfaceMesh mesh;
  mesh.points.reserve(sample_.particles.size());
  for (const CadParticle& q : sample_.particles) mesh.points.push_back(q.x);
  for (int p = 0; p < np; ++p)
    for (const auto& t : meshes_[size_t(p)].triangles) {
      const auto& pm = meshes_[size_t(p)];
      mesh.triangles.push_back({pm.particle[size_t(t[0])], pm.particle[size_t(t[1])], pm.particle[size_t(t[2])]});
      mesh.trianglePatch.push_back(p);
    }
  return mesh;
}

} // namespace

CadSurfaceMesh triangulateCadSample(const CadModel& model, CadSample& sample, CadTriangulationStats* stats) {
  CadTriangulationStats local;
  CadTriangulationStats& s = stats ? *stats : local;
  s = {};
  return Triangulator(model, sample, s).run();
}

} // namespace tetflow
